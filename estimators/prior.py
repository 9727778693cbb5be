"""Spin priors in the filter (Renis et al. §5.3, §6): tuning, initialisation, proxy measurement.

A :class:`BodyRatePrior` is the target's rate vector in its own principal-axes frame,
``ω_T_T`` (rad/s), with a 1-σ per axis. A light curve gives only the rate's
magnitude and its 1-σ (:class:`lightcurves.prior.SpinPrior`, the one rate prior);
:meth:`lightcurves.prior.SpinPrior.body_rate_prior` turns it into this vector about
an assumed spin axis. :meth:`BodyRatePrior.from_truth` makes the truth with a
percentage error as in §5.3.
Its three uses, each a switch of the caller:

1. **tuning** — :func:`tuning_for_prior` names the scenario-specific tuning
   (slow/fast, one/two axes) that the prior points to;
2. **initialisation** — :func:`initialize_with_prior`: ``ω̂_ST_0`` from the prior
   and the ``ω`` block of ``P_0`` from its uncertainty (§6.2);
3. **proxy measurement** — :func:`rate_proxy`: the prior as a fictitious
   measurement of the target's rate with ``R_ω = 1e-3 I`` (§6.3), pushed at
   every step (``"always"``) or only while the camera's measurements are
   rejected or missing (``"on_reject"``).

The state holds the *relative* rate ``ω_ST_T = R_TS ω_S_S − ω_T_T`` (eq. 1),
so both 2 and 3 go through eq. 1 with the servicer's own rate from its AODS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.attitude import quat_to_dcm
from estimators.measurement import TargetRateMeasurement
from estimators.state import DW_ST_T, Q_TS, W_B, W_ST_T

PROXY_MODES = ("always", "on_reject")
#: ``R_ω`` of §6.3, (rad/s)².
R_OMEGA_PROXY = 1e-3


def _checked_covariance(C, sigma: np.ndarray) -> np.ndarray:
    """``C`` as a symmetric positive-definite (3, 3) array whose diagonal is ``sigma²``; ValueError otherwise."""
    C = np.asarray(C, dtype=float)
    if C.shape != (3, 3) or not np.all(np.isfinite(C)):
        raise ValueError(f"spin prior covariance_rad2_s2: shape {C.shape}: expected a finite (3, 3) array in (rad/s)^2")
    if not np.allclose(C, C.T, rtol=1e-9, atol=0.0):
        raise ValueError("spin prior covariance_rad2_s2: not symmetric: expected a symmetric (3, 3) covariance")
    if not np.allclose(np.sqrt(np.diag(C)), sigma, rtol=1e-9, atol=0.0):
        raise ValueError(f"spin prior sigma_rad_s {sigma.tolist()}: expected the square root of the covariance's diagonal")
    if np.linalg.eigvalsh(C)[0] <= 0.0:
        raise ValueError("spin prior covariance_rad2_s2: not positive definite: expected a positive-definite covariance")
    return 0.5 * (C + C.T)


def _unit(axis) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    n = float(np.linalg.norm(a)) if a.shape == (3,) else 0.0
    if not (np.isfinite(n) and n > 0):
        raise ValueError(f"spin axis must be a non-zero 3-vector in the target frame, got {axis!r}")
    return a / n


@dataclass(frozen=True)
class BodyRatePrior:
    """The filters' prior: the target's spin ``w_T_T_rad_s`` (3,) in its body frame and its uncertainty.

    ``sigma_rad_s`` (3,) is the 1-σ per axis. ``covariance_rad2_s2`` (3, 3), when given, is the full
    covariance (a light-curve inversion's axis uncertainty is correlated across axes); ``sigma_rad_s``
    must then be the square root of its diagonal. Without it the covariance is ``diag(sigma²)``.
    """

    w_T_T_rad_s: np.ndarray
    sigma_rad_s: np.ndarray
    source: str = ""  #: where it came from ("truth +5%", a light-curve file, ...)
    covariance_rad2_s2: np.ndarray | None = None

    def __post_init__(self):
        if self.w_T_T_rad_s is None:
            raise ValueError("spin prior has no rate: w_T_T_rad_s must be three numbers (rad/s)")
        w = np.asarray(self.w_T_T_rad_s, dtype=float)
        s = np.broadcast_to(np.asarray(self.sigma_rad_s, dtype=float), (3,)).copy() if self.sigma_rad_s is not None else None
        if w.shape != (3,) or not np.all(np.isfinite(w)):
            raise ValueError(f"spin prior rate w_T_T_rad_s must be three finite numbers (rad/s), got {self.w_T_T_rad_s!r}")
        if s is None or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError(f"spin prior sigma_rad_s must be positive (rad/s), got {self.sigma_rad_s!r}")
        object.__setattr__(self, "w_T_T_rad_s", w)
        object.__setattr__(self, "sigma_rad_s", s)
        if self.covariance_rad2_s2 is not None:
            object.__setattr__(self, "covariance_rad2_s2", _checked_covariance(self.covariance_rad2_s2, s))

    @property
    def covariance(self) -> np.ndarray:
        """(3, 3) covariance of ``w_T_T_rad_s``, (rad/s)²."""
        return self.covariance_rad2_s2 if self.covariance_rad2_s2 is not None else np.diag(self.sigma_rad_s**2)

    @classmethod
    def from_truth(cls, w_T_T_true, error_fraction: float) -> "BodyRatePrior":
        """A prior off the true rate by ``error_fraction`` of its magnitude (§5.3: 5 %).

        A light curve measures the period, so the error is on the rate's
        magnitude: ``ω_prior = (1 + e) ω_true``, 1-σ ``e |ω_true|`` per axis.
        """
        w = np.asarray(w_T_T_true, dtype=float)
        if not (np.isfinite(error_fraction) and error_fraction > 0):
            raise ValueError(f"prior error must be a positive fraction (e.g. 0.05), got {error_fraction!r}")
        sigma = error_fraction * max(float(np.linalg.norm(w)), 1e-6)
        return cls((1.0 + error_fraction) * w, np.full(3, sigma), source=f"truth {100 * error_fraction:+.1f}%")

    @classmethod
    def from_rate(cls, rate_rad_s, sigma_rad_s, axis_T=(0.0, 0.0, 1.0), source: str = "light curve") -> "BodyRatePrior":
        """A prior from a rate magnitude and its 1-σ — what a light curve gives — about an assumed axis.

        A light curve gives the spin rate, not its axis or sense; ``axis_T`` (unit
        vector in the target's principal frame, default ``z_T``, the paper's
        one-axis tumbles) supplies them. ``rate_rad_s`` of ``None`` (no significant
        period) is refused: a prior without a rate cannot be used.

        Given a light curve's :class:`lightcurves.prior.SpinPrior`, call its
        :meth:`~lightcurves.prior.SpinPrior.body_rate_prior`; this constructor is for
        a rate and 1-σ read from elsewhere (``lcnav run --prior-json``).
        """
        if rate_rad_s is None:
            raise ValueError("spin prior has no rate (the light curve gave no significant period)")
        r = float(rate_rad_s)
        s = None if sigma_rad_s is None else float(sigma_rad_s)
        if not (np.isfinite(r) and r >= 0):
            raise ValueError(f"spin prior rate must be a finite rate >= 0 (rad/s), got {rate_rad_s!r}")
        if s is None or not (np.isfinite(s) and s > 0):
            raise ValueError(f"spin prior sigma_rad_s must be positive (rad/s), got {sigma_rad_s!r}")
        return cls(r * _unit(axis_T), np.full(3, s), source=source)


def tuning_for_prior(prior: BodyRatePrior, *, fast_rad_s: float = 0.1, single_axis_deg: float = 10.0, conservative: bool = True) -> str:
    """Scenario-specific tuning name (``sc1``–``sc4``) for the prior's spin (study 1 of Renis et al.).

    Fast if ``|ω| ≥ fast_rad_s`` (Table 1: slow 0.05, fast 0.2/0.18 rad/s);
    one-axis if ``ω`` is within ``single_axis_deg`` of a principal axis.
    ``conservative``: the variant with the settling phase (``sc3-conservative``, the default: not over-confident from
    the default ``P_0``, :mod:`estimators.tuning`); ``False`` gives the paper's own (``sc3-paper``, over-confident from it).
    """
    w = prior.w_T_T_rad_s
    n = float(np.linalg.norm(w))
    fast = n >= fast_rad_s
    one_axis = n == 0.0 or np.max(np.abs(w)) / n >= np.cos(np.radians(single_axis_deg))
    scenario = {(True, False): "sc1", (True, True): "sc2", (False, False): "sc3", (False, True): "sc4"}[(one_axis, fast)]
    return f"{scenario}-conservative" if conservative else f"{scenario}-paper"


def initialize_with_prior(x0, P0, prior: BodyRatePrior, servicer) -> tuple[np.ndarray, np.ndarray]:
    """``x̂_0`` with ``ω̂_ST_0 = R(q̂_TS,0) ω_S_S − ω_prior`` and ``P_0``'s ω block the prior's covariance.

    ``servicer``: the servicer's absolute state (13) at ``t_0``. Cross terms of
    the ω block with the other states are zeroed.
    """
    x0 = np.array(x0, dtype=float)
    P0 = np.array(P0, dtype=float)
    w_S = np.asarray(servicer, dtype=float)[W_B]
    x0[W_ST_T] = quat_to_dcm(x0[Q_TS] / np.linalg.norm(x0[Q_TS])) @ w_S - prior.w_T_T_rad_s
    P0[DW_ST_T, :] = 0.0
    P0[:, DW_ST_T] = 0.0
    P0[DW_ST_T, DW_ST_T] = prior.covariance  # ω_ST = R ω_S − ω_T: the sign does not change the covariance
    return x0, P0


def rate_proxy(prior: BodyRatePrior, servicer, R_w: float = R_OMEGA_PROXY) -> tuple[TargetRateMeasurement, np.ndarray]:
    """``(source, z)``: the prior as a fictitious measurement of ``ω_T_T`` for ``update``.

    Its noise is ``R_ω I`` (§6.3) plus the prior's own covariance: a prior whose axis a light-curve inversion
    left open (an axisymmetric target's azimuth, an unsettled sense) must not pull the estimate to its mean as
    if it knew it. For the paper's 5 % prior the added term is ~1 % of ``R_ω``.
    """
    src = TargetRateMeasurement(w_S_S=np.asarray(servicer, dtype=float)[W_B], R=R_w * np.eye(3) + prior.covariance)
    return src, prior.w_T_T_rad_s
