"""The layouts of lcnav's state vectors, named once.

Three vectors are in use; every index into them goes through these names
(``x[W_ST_T]``, ``P[DW_ST_T, DW_ST_T]``, ``s[W_B]``), never a bare ``x[4:7]``,
because the same numbers mean different things in the three layouts.

* The 15-state relative vector of eq. 17 of Renis et al.,
  ``x = [q_TS, ω_ST_T, r_ST_T, v_ST_T, k1, k2]``: the attitude of the servicer
  S relative to the target T (scalar-first, maps S to T), the rate of S relative
  to T in T (rad/s), the position and velocity of S relative to T in T (m, m/s),
  and the inertia ratios ``k1 = ln(A/B)``, ``k2 = ln(B/C)`` (eq. 18–19).
* The 14-error-state of both filters (:mod:`estimators.error_state`),
  ``δx = [δp, δω_ST_T, δr_ST_T, δv_ST_T, δk1, δk2]``: ``δp`` is the attitude
  error (four times the MRP, ≈ the rotation vector in rad); the rest is additive.
* The absolute state of one rigid body B (the servicer S or the target T),
  ``s = [r_I, v_I, q_IB, ω_B]``: ECI position and velocity (m, m/s), the
  attitude mapping B to ECI, the body rate in B (rad/s).

The constants are plain ``slice`` objects: numba compiles module-level slices
as constants, so the compiled dynamics use the same names.
"""

from __future__ import annotations

# ---------------------------------------------------------------- 15-state relative vector (Renis et al. eq. 17)

N_STATE = 15
Q_TS = slice(0, 4)
W_ST_T = slice(4, 7)
R_ST_T = slice(7, 10)
V_ST_T = slice(10, 13)
K = slice(13, 15)
#: Everything after the quaternion: the components a filter adds and subtracts.
X_ADDITIVE = slice(4, 15)
N_ADDITIVE = 11

#: The state's groups by the short names used in tables and metrics.
STATE_GROUPS = {"q": Q_TS, "w": W_ST_T, "r": R_ST_T, "v": V_ST_T, "k": K}

# ---------------------------------------------------------------- 14-error-state (estimators.error_state)

N_ERROR = 14
DTHETA = slice(0, 3)
DW_ST_T = slice(3, 6)
DR_ST_T = slice(6, 9)
DV_ST_T = slice(9, 12)
DK = slice(12, 14)
#: The error state's additive part, one to one with :data:`X_ADDITIVE`.
DX_ADDITIVE = slice(3, 14)

#: Error-state indices of ``k1, k2``: the states a filter considers instead of estimating in a one-axis tumble,
#: where the inertia ratios are unobservable.
K_STATES = tuple(range(N_ERROR)[DK])

#: The error state's groups by the same short names as :data:`STATE_GROUPS`.
ERROR_GROUPS = {"q": DTHETA, "w": DW_ST_T, "r": DR_ST_T, "v": DV_ST_T, "k": DK}

# ---------------------------------------------------------------- absolute rigid-body state [r_I, v_I, q_IB, ω_B]

N_ABSOLUTE = 13
R_I = slice(0, 3)
V_I = slice(3, 6)
Q_IB = slice(6, 10)
W_B = slice(10, 13)

# ---------------------------------------------------------------- the joint vector [x (15), s (13)] of the compiled dynamics

JOINT_X = slice(0, N_STATE)
JOINT_S = slice(N_STATE, N_STATE + N_ABSOLUTE)
