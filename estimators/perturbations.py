"""Perturbations the navigation filters do not model: the physics of the perturbed truth.

The filters' process model (:mod:`estimators.dynamics`, eq. 21 of Renis et al.) is
Keplerian and torque-free. A real target also feels the gravity-gradient torque, both
orbits feel J2, drag and solar-radiation pressure, and a tumbling rocket body with
liquid residuals or flexible parts dissipates energy. This module holds those terms,
one function each, and the right-hand side of one body's absolute state
``s = [r_I, v_I, q_IB, ω_B]`` (13) with the terms a :class:`TruthPhysics` switches on.

Why a library module and not ``studies/sim``: the terms are pure dynamics (arrays in,
arrays out, like :mod:`estimators.dynamics`), and the filters' process noise is built
from them (:func:`perturbing_accelerations`, the unmodelled accelerations along a
trajectory): ``estimators`` may not import ``studies``. The scenario-level truth and
budget (:func:`studies.sim.truth.simulate_truth`, :mod:`studies.sim.disturbance`) call
this module.

Terms (each a compiled function on 3-tuples, like :func:`estimators.dynamics.euler_rate`,
so that the truth integration calls them tens of thousands of times without numpy's
per-call cost):

* :func:`gravity_gradient_torque` on the target, ``τ = 3μ/r⁵ (r_B × J r_B)``;
* :func:`j2_acceleration` on both orbits (Vallado ch. 8);
* :func:`drag_acceleration`: cannonball drag in an exponential atmosphere co-rotating
  with the Earth (Vallado Table 8-4, the band of the orbit's initial altitude);
* :func:`srp_acceleration`: cannonball solar-radiation pressure with the cylindrical
  Earth shadow, Sun direction fixed at the epoch;
* :func:`dissipation_torque`: an energy sink that keeps ``|H|`` and lowers the
  rotational energy toward the major-axis spin.

Inertia scale: the scenarios store the target inertia normalised (``B = 1``). Every
torque here is linear in ``J`` (``τ_gg`` is, ``τ_diss`` is by construction), so the
angular accelerations ``J⁻¹ τ`` depend only on the ratios; the torques come out in the
units of ``J`` times s⁻² (N m when ``J`` is in kg m²).

Conventions of :mod:`estimators.dynamics` (SI, scalar-first ``q_IB`` mapping B to I,
``I`` = GCRS, treated as inertial with the Earth's pole along its z axis: precession and
nutation of the pole, ~0.3° since J2000, are neglected for J2 and for the co-rotating
atmosphere).

References
----------
.. [1] Hughes, *Spacecraft Attitude Dynamics*, Wiley 1986 (Dover 2004): the gravity-gradient torque,
   the pitch libration and the Jacobi integral of a rigid body on a circular orbit; Wie, *Space Vehicle
   Dynamics and Control*, AIAA 2008, ch. 6.
.. [2] Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., Microcosm 2013:
   ch. 8 (J2 acceleration, drag, solar-radiation pressure; Table 8-4, the exponential
   atmosphere), eq. 9-41 (secular nodal regression).
.. [3] Likins, *Effects of energy dissipation on the free body motions of spacecraft*, NASA
   JPL TR 32-860, 1966; Hughes 1986 (the energy-sink hypothesis: internal dissipation keeps
   ``H`` and lowers ``E`` toward the major-axis spin).
"""

from __future__ import annotations

import functools
from dataclasses import asdict, dataclass, replace

import numba
import numpy as np

from estimators.dynamics import (  # noqa: F401 - gravity_gradient_torque: one of this module's terms, shared with the filters' model
    MU_EARTH,
    R_EARTH,
    absolute_rhs_nb,
    cross3,
    get3,
    get4,
    gravity_gradient_torque,
    integrate_absolute,
    mat_t_vec,
    quat_to_dcm_nb,
)
from estimators.state import N_ABSOLUTE, Q_IB, R_I, V_I, W_B

J2_EARTH = 1.08263e-3
"""Earth's second zonal harmonic (EGM96/WGS-84, unnormalised; Vallado Table D-1)."""
OMEGA_EARTH_RAD_S = 7.292115e-5
"""Earth's rotation rate, rad/s (WGS-84), that of the co-rotating atmosphere."""
SOLAR_PRESSURE_N_M2 = 4.56e-6
"""Solar radiation pressure at 1 au on a black surface, ``P = Φ/c`` with Φ = 1367 W/m² (Vallado §8.6.4), N/m²."""

#: Vallado Table 8-4 (exponential atmosphere, after CIRA-72/US Std. 1976), the bands from 300 km up:
#: ``(base altitude h₀ m, nominal density ρ₀ kg/m³, scale height H m)``; a band holds from its ``h₀`` to the next.
ATMOSPHERE_BANDS = (
    (300e3, 2.418e-11, 53.628e3),
    (350e3, 9.518e-12, 53.298e3),
    (400e3, 3.725e-12, 58.515e3),
    (450e3, 1.585e-12, 60.828e3),
    (500e3, 6.967e-13, 63.822e3),
    (600e3, 1.454e-13, 71.835e3),
    (700e3, 3.614e-14, 88.667e3),
    (800e3, 1.170e-14, 124.64e3),
    (900e3, 5.245e-15, 181.05e3),
    (1000e3, 3.019e-15, 268.00e3),
)

TRUTH_PHYSICS = ("torque-free", "perturbed")
"""Names accepted by :func:`get_truth_physics` (and ``--truth``)."""

# Layout of the parameter vector of one body (what the compiled right-hand side reads); a switched-off term has 0.
P_MU, P_J2, P_GG, P_CD_AM, P_RHO0, P_H0, P_HSCALE, P_SRP, P_SUN, P_INV_TAU = 0, 1, 2, 3, 4, 5, 6, 7, slice(8, 11), 11
N_PARAMS = 12
#: Names of the translational (in I, m/s²) and angular (in B, rad/s²) terms of :func:`perturbing_accelerations`.
TRANSLATIONAL_TERMS = ("j2", "drag", "srp")
ANGULAR_TERMS = ("gravity_gradient", "dissipation")


class TruthPhysicsError(ValueError):
    """A truth-physics name or parameter is not of the expected form (one line naming the field)."""


# ---------------------------------------------------------------- the terms (compiled, on 3-tuples)


@numba.njit(cache=True, error_model="numpy")
def j2_acceleration(r_I, mu, j2, r_e):
    """J2 acceleration (Vallado 2013 ch. 8), m/s², 3-tuple in I (z along the Earth's pole).

    ``a = −(3/2) J2 μ R_E²/r⁵ [x (1 − 5z²/r²), y (1 − 5z²/r²), z (3 − 5z²/r²)]``,
    ``r_I`` in m; ``j2`` dimensionless, ``r_e`` the equatorial radius (m).
    """
    x, y, z = r_I[0], r_I[1], r_I[2]
    r2 = x * x + y * y + z * z
    k = -1.5 * j2 * mu * r_e * r_e / (r2 * r2 * np.sqrt(r2))
    f = 5.0 * z * z / r2
    return (k * x * (1.0 - f), k * y * (1.0 - f), k * z * (3.0 - f))


@numba.njit(cache=True, error_model="numpy")
def atmosphere_density(r_norm, r_e, rho0, h0, scale_h):
    """Exponential atmosphere ``ρ = ρ₀ exp(−(h − h₀)/H)``, kg/m³, with ``h = |r| − R_E`` (spherical Earth; Vallado 2013 Table 8-4)."""
    return rho0 * np.exp(-((r_norm - r_e) - h0) / scale_h)


@numba.njit(cache=True, error_model="numpy")
def drag_acceleration(r_I, v_I, cd_area_to_mass, rho):
    """Cannonball drag ``a = −½ ρ (C_D A/m) |v_rel| v_rel`` (Vallado 2013 ch. 8), m/s², 3-tuple in I.

    ``v_rel = v_I − ω_E × r_I``: the velocity relative to the atmosphere, which co-rotates with the Earth
    (:data:`OMEGA_EARTH_RAD_S` about z). ``cd_area_to_mass`` = ``C_D A/m`` (m²/kg), ``rho`` kg/m³.
    """
    w = OMEGA_EARTH_RAD_S
    vr = (v_I[0] + w * r_I[1], v_I[1] - w * r_I[0], v_I[2])
    k = -0.5 * rho * cd_area_to_mass * np.sqrt(vr[0] ** 2 + vr[1] ** 2 + vr[2] ** 2)
    return (k * vr[0], k * vr[1], k * vr[2])


@numba.njit(cache=True, error_model="numpy")
def srp_acceleration(r_I, sun_dir_I, p_cr_area_to_mass, r_e):
    """Cannonball solar-radiation pressure (Vallado 2013 ch. 8) with the cylindrical Earth shadow, m/s², 3-tuple in I.

    ``a = −ν P C_r (A/m) ŝ`` with ``ŝ`` the unit direction to the Sun (``sun_dir_I``; the body–Sun and
    Earth–Sun directions differ by < 3e-5 rad in LEO), ``p_cr_area_to_mass = P C_r A/m`` (m/s²) and the
    shadow function ``ν = 0`` behind the Earth (``r·ŝ < 0`` and ``|r − (r·ŝ) ŝ| < R_E``), 1 otherwise.
    """
    along = r_I[0] * sun_dir_I[0] + r_I[1] * sun_dir_I[1] + r_I[2] * sun_dir_I[2]
    perp2 = r_I[0] ** 2 + r_I[1] ** 2 + r_I[2] ** 2 - along * along
    if along < 0.0 and perp2 < r_e * r_e:
        return (0.0, 0.0, 0.0)
    return (-p_cr_area_to_mass * sun_dir_I[0], -p_cr_area_to_mass * sun_dir_I[1], -p_cr_area_to_mass * sun_dir_I[2])


@numba.njit(cache=True, error_model="numpy")
def dissipation_torque(w_B, J, inv_tau):
    """Energy-sink torque ``τ = −(1/τ_d) P⊥ J P⊥ ω`` with ``P⊥ = 1 − Ĥ Ĥᵀ``, ``H = J ω`` (3-tuple in B).

    Internal energy dissipation (propellant slosh, flexible parts) keeps the angular momentum and lowers the
    rotational energy toward the major-axis spin (the energy-sink hypothesis, Likins 1966, Hughes 1986).
    This model realises it in a rigid-body state with a torque perpendicular to ``H``, so that

    * ``d|H|/dt = Ĥ·τ = 0``: ``|H|`` is kept exactly (the inertial direction of H moves by at most
      ``∫|τ|/|H| dt``, the price of keeping the body rigid);
    * ``Ė = ω·τ = −(P⊥ω)ᵀ J (P⊥ω)/τ_d = −2 T⊥/τ_d`` ≤ 0, with ``T⊥`` the kinetic energy of the rate component
      off the angular momentum (the nutation); zero only for a pure spin (``ω ∥ H``), so the major-axis spin is the
      stable end state and ``E → |H|²/(2 J_max)``;
    * near the major-axis spin (axis 3, ``C = J_max``; the others ``A``, ``B``) the nutation's excess energy decays as
      ``E − E_min ∝ exp(−(2 − (A + B)/C) t/τ_d)`` averaged over a nutation cycle: linearising,
      ``P⊥ω ≈ (1 − J_i/C) δω_i``, so ``Ė = −Σ J_i (1 − J_i/C)² δω_i²/τ_d`` while ``E − E_min = Σ J_i (1 − J_i/C) δω_i²/2``,
      and the free nutation shares ``J_i (C − J_i) ⟨δω_i²⟩`` equally between the two axes.

    ``ω̇ = τ/J`` depends only on the inertia ratios. ``inv_tau = 1/τ_d`` (1/s); 0 switches the term off.
    """
    H = (J[0] * w_B[0], J[1] * w_B[1], J[2] * w_B[2])
    H2 = H[0] ** 2 + H[1] ** 2 + H[2] ** 2
    if inv_tau == 0.0 or H2 == 0.0:
        return (0.0, 0.0, 0.0)
    a = (w_B[0] * H[0] + w_B[1] * H[1] + w_B[2] * H[2]) / H2
    p = (w_B[0] - a * H[0], w_B[1] - a * H[1], w_B[2] - a * H[2])  # P⊥ ω
    jp = (J[0] * p[0], J[1] * p[1], J[2] * p[2])
    b = (jp[0] * H[0] + jp[1] * H[1] + jp[2] * H[2]) / H2
    return (-inv_tau * (jp[0] - b * H[0]), -inv_tau * (jp[1] - b * H[1]), -inv_tau * (jp[2] - b * H[2]))


# ---------------------------------------------------------------- one body's right-hand side


@numba.njit(cache=True)
def _terms(s, J, p):
    """The perturbing accelerations at state ``s``: ``(j2, drag, srp)`` in I (m/s²), ``(gg, diss)`` ω̇ in B (rad/s²)."""
    z = (0.0, 0.0, 0.0)
    r = get3(s, R_I)
    v = get3(s, V_I)
    w = get3(s, W_B)
    rn = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
    a_j2 = j2_acceleration(r, p[P_MU], p[P_J2], R_EARTH) if p[P_J2] != 0.0 else z
    a_drag = z
    if p[P_CD_AM] != 0.0:
        a_drag = drag_acceleration(r, v, p[P_CD_AM], atmosphere_density(rn, R_EARTH, p[P_RHO0], p[P_H0], p[P_HSCALE]))
    a_srp = srp_acceleration(r, (p[P_SUN.start], p[P_SUN.start + 1], p[P_SUN.start + 2]), p[P_SRP], R_EARTH) if p[P_SRP] != 0.0 else z
    w_gg = z
    if p[P_GG] != 0.0:
        tau = gravity_gradient_torque(mat_t_vec(quat_to_dcm_nb(get4(s, Q_IB)), r), J, p[P_MU])
        w_gg = (tau[0] / J[0], tau[1] / J[1], tau[2] / J[2])
    tau = dissipation_torque(w, J, p[P_INV_TAU])
    w_diss = (tau[0] / J[0], tau[1] / J[1], tau[2] / J[2])
    return a_j2, a_drag, a_srp, w_gg, w_diss


@numba.njit(cache=True)
def perturbed_rhs_nb(s, J, p):
    """``ṡ`` of ``s = [r_I, v_I, q_IB, ω_B]`` (13): Kepler + Euler (:func:`estimators.dynamics.absolute_rhs_nb`) plus the
    perturbations switched on in the parameter vector ``p`` (:meth:`TruthPhysics.body_params`).

    ``v̇_I += a_J2 + a_drag + a_SRP``; ``ω̇_B += J⁻¹ (τ_gg + τ_diss)``.
    """
    out = absolute_rhs_nb(s, J, p[P_MU])
    a_j2, a_drag, a_srp, w_gg, w_diss = _terms(s, J, p)
    i, k = V_I.start, W_B.start
    for j in range(3):
        out[i + j] += a_j2[j] + a_drag[j] + a_srp[j]
        out[k + j] += w_gg[j] + w_diss[j]
    return out


@numba.njit(cache=True)
def _terms_along(y, J, p):
    n = y.shape[0]
    out = np.empty((n, 5, 3))
    for m in range(n):
        terms = _terms(y[m], J, p)
        for t in range(5):
            for j in range(3):
                out[m, t, j] = terms[t][j]
    return out


def perturbing_accelerations(y, J_diag, params) -> dict[str, np.ndarray]:
    """The unmodelled accelerations of one body along a trajectory, per term.

    ``y``: ``(N, 13)`` absolute states ``[r_I, v_I, q_IB, ω_B]``; ``J_diag``: principal inertia (ratios suffice);
    ``params``: :meth:`TruthPhysics.body_params` of that body. Returns ``{term: (N, 3)}``: the translational terms
    :data:`TRANSLATIONAL_TERMS` in I (m/s²) and the angular ones :data:`ANGULAR_TERMS` (``ω̇``) in B (rad/s²);
    a switched-off term is zeros.
    """
    y = np.ascontiguousarray(y, dtype=float)
    if y.ndim != 2 or y.shape[1] != N_ABSOLUTE or not np.all(np.isfinite(y)):
        raise TruthPhysicsError(f"y: shape {y.shape}: expected finite absolute states of shape (N, {N_ABSOLUTE})")
    a = _terms_along(y, np.asarray(J_diag, dtype=float), np.asarray(params, dtype=float))
    return dict(zip(TRANSLATIONAL_TERMS + ANGULAR_TERMS, np.moveaxis(a, 1, 0)))


def integrate_perturbed(y0, t_eval, J_diag, params):
    """:func:`estimators.dynamics.integrate_absolute` (DOP853, 1e-12, scaled) of :func:`perturbed_rhs_nb`."""
    J = np.asarray(J_diag, dtype=float)
    p = np.asarray(params, dtype=float)
    return integrate_absolute(y0, t_eval, J, float(p[P_MU]), rhs=lambda s: perturbed_rhs_nb(s, J, p))


# ---------------------------------------------------------------- the named physics models


def atmosphere_band(altitude_m: float) -> tuple[float, float, float]:
    """``(h₀ m, ρ₀ kg/m³, H m)`` of the :data:`ATMOSPHERE_BANDS` band holding ``altitude_m`` (300 km and up)."""
    if not (np.isfinite(altitude_m) and ATMOSPHERE_BANDS[0][0] <= altitude_m):
        raise TruthPhysicsError(f"altitude: {altitude_m!r} m: expected at least {ATMOSPHERE_BANDS[0][0]:g} m (the exponential atmosphere's table)")
    return [b for b in ATMOSPHERE_BANDS if b[0] <= altitude_m][-1]


@functools.lru_cache(maxsize=16)
def sun_direction_I(epoch_utc: str) -> tuple[float, float, float]:
    """Unit vector Earth → Sun in GCRS at ``epoch_utc`` (ISO time), from astropy's ``get_sun`` (low-precision ephemeris)."""
    from astropy.coordinates import get_sun
    from astropy.time import Time

    try:
        t = Time(epoch_utc, scale="utc")
    except ValueError:
        raise TruthPhysicsError(f"epoch_utc: {epoch_utc!r}: expected an ISO time, e.g. '2026-03-20T12:00:00'") from None
    xyz = np.asarray(get_sun(t).cartesian.xyz.value, dtype=float)
    return tuple((xyz / np.linalg.norm(xyz)).tolist())


@dataclass(frozen=True)
class TruthPhysics:
    """Which unmodelled physics the truth carries, and their parameters (SI).

    ``torque-free`` (:func:`get_truth_physics`) switches everything off: Kepler orbits and torque-free attitude, what the
    filters model. ``perturbed`` switches on the gravity-gradient torque on the target, J2 on both orbits, drag on both
    and the nutation damping of the target; solar-radiation pressure stays off (its differential acceleration between
    the two bodies is ~3e-8 m/s², and the shadow boundary is a discontinuity the integrator must step through); switch
    it on with ``with_terms(physics, srp=True)``.

    The servicer's attitude stays torque-free in every model: it is actively controlled, and the filters read it from
    its own attitude determination. Area-to-mass ratios are for the cannonball drag and SRP models: a spent upper stage
    (~0.01 m²/kg: a 1.5 t, 2.4 m × 6.5 m stage tumbling shows ~15 m² on average) and a compact servicer (~0.005 m²/kg).
    ``nutation_time_constant_s`` is chosen, not measured: slow (1 day) so that a 300–5400 s run sees a small but present
    decay (Explorer 1's whip antennas turned its minor-axis spin into a flat spin within its first orbit; a rocket
    body's slosh is far slower).
    Measured on SC3: the excess energy ``E − E_min`` falls by 0.46 % in 600 s and 3.8 % in 5400 s, while the inertial
    direction of H moves by < 3e-4° (the torque turns with the body and averages out).
    """

    name: str
    gravity_gradient: bool = False
    j2: bool = False
    drag: bool = False
    srp: bool = False
    dissipation: bool = False
    nutation_time_constant_s: float = 86400.0  #: τ_d of :func:`dissipation_torque`, s
    target_area_to_mass_m2_kg: float = 0.01
    servicer_area_to_mass_m2_kg: float = 0.005
    drag_coefficient: float = 2.2  #: C_D (Vallado §8.6.2: 2.2 for a flat plate in free-molecular flow)
    reflectivity_coefficient: float = 1.3  #: C_r (1 black, 2 mirror)
    epoch_utc: str = "2026-03-20T12:00:00"  #: fixes the Sun direction for SRP (the scenarios carry no epoch)

    def __post_init__(self):
        for f in ("nutation_time_constant_s", "target_area_to_mass_m2_kg", "servicer_area_to_mass_m2_kg", "drag_coefficient",
                  "reflectivity_coefficient"):
            v = getattr(self, f)
            if isinstance(v, bool) or not isinstance(v, int | float) or not (np.isfinite(v) and v > 0):
                raise TruthPhysicsError(f"{f}: {v!r}: expected a positive finite number")

    @property
    def terms(self) -> tuple[str, ...]:
        """Names of the terms switched on (empty for torque-free)."""
        return tuple(t for t in ("gravity_gradient", "j2", "drag", "srp", "dissipation") if getattr(self, t))

    @property
    def torque_free(self) -> bool:
        return not self.terms

    def as_dict(self) -> dict:
        """Everything, for metadata (``metrics.json``, ``truth.parquet``, ``study.json``)."""
        return {**asdict(self), "terms": list(self.terms)}

    def body_params(self, body: str, r0_I) -> np.ndarray:
        """Parameter vector of :func:`perturbed_rhs_nb` for ``body`` (``target`` or ``servicer``) starting at ``r0_I`` (m).

        The gravity-gradient torque and the dissipation act on the target only; the atmosphere band is that of the
        initial altitude (a near-circular orbit stays within it).
        """
        if body not in ("target", "servicer"):
            raise TruthPhysicsError(f"body: {body!r}: expected target or servicer")
        p = np.zeros(N_PARAMS)
        p[P_MU] = MU_EARTH
        p[P_J2] = J2_EARTH if self.j2 else 0.0
        is_target = body == "target"
        am = self.target_area_to_mass_m2_kg if is_target else self.servicer_area_to_mass_m2_kg
        if self.drag:
            h0, rho0, scale_h = atmosphere_band(float(np.linalg.norm(r0_I)) - R_EARTH)
            p[P_CD_AM], p[P_RHO0], p[P_H0], p[P_HSCALE] = self.drag_coefficient * am, rho0, h0, scale_h
        if self.srp:
            p[P_SRP] = SOLAR_PRESSURE_N_M2 * self.reflectivity_coefficient * am
            p[P_SUN] = sun_direction_I(self.epoch_utc)
        p[P_GG] = 1.0 if (self.gravity_gradient and is_target) else 0.0
        p[P_INV_TAU] = 1.0 / self.nutation_time_constant_s if (self.dissipation and is_target) else 0.0
        return p


_MODELS = {
    "torque-free": TruthPhysics("torque-free"),
    "perturbed": TruthPhysics("perturbed", gravity_gradient=True, j2=True, drag=True, dissipation=True),
}


def get_truth_physics(name: str | TruthPhysics) -> TruthPhysics:
    """The named model (``torque-free`` or ``perturbed``; a :class:`TruthPhysics` passes through)."""
    if isinstance(name, TruthPhysics):
        return name
    if name not in _MODELS:
        raise TruthPhysicsError(f"truth: {name!r}: expected torque-free or perturbed")
    return _MODELS[name]


def with_terms(physics: TruthPhysics, **switches: bool) -> TruthPhysics:
    """A copy of ``physics`` with some terms switched (``with_terms(p, srp=True)``), named after what it holds."""
    out = replace(physics, **switches)
    return replace(out, name=_MODELS["torque-free"].name if out.torque_free else "+".join(out.terms))
