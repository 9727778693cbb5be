"""Observation geometry of a ground telescope watching a tumbling target.

* :class:`KeplerOrbit` — two-body orbit from classical elements; ``state(t_s)``
  gives GCRS (≈ ECI, frame I) position and velocity in closed form (Kepler's
  equation solved by Newton's method).
* :func:`observe` — for times ``t_s`` (s after ``epoch``): target, observer and
  Sun positions in I, range, topocentric elevation of the target and of the
  Sun, phase angle, Earth shadow (cylindrical umbra: no signal in eclipse),
  airmass and visibility. Sun and site positions come from astropy on nodes
  ten minutes apart, interpolated (:data:`NODE_SPACING_S`; :func:`site_sun_exact`
  at every time is the reference).
* :func:`find_visible_start` — first time after ``epoch`` from which the target
  stays visible for a whole arc.
* :func:`bisector_rate` — how fast the Sun–observer bisector turns about a
  spin axis: a light curve measures the *synodic* rate
  ``ω_syn = ω_sid − bisector_rate`` (the lighting geometry repeats when the
  body has turned by 2π relative to the bisector, not to inertial space).
* :func:`spin_attitude` — the target's attitude ``q_IT`` from torque-free
  rigid-body motion (:mod:`estimators.dynamics`): a single-axis spin about a
  principal axis is the steady solution; any other axis tumbles.

Everything is SI inside; astropy ``Time``/``EarthLocation`` at the boundary.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import astropy.units as u
import numpy as np
from astropy.coordinates import GCRS, ITRS, CartesianRepresentation, EarthLocation, get_body
from astropy.time import Time
from scipy.interpolate import CubicSpline

from estimators.attitude import dcm_to_quat, quat_derivative, quat_normalize
from estimators.dynamics import MU_EARTH, R_EARTH, euler_rhs, integrate_truth

__all__ = ["KeplerOrbit", "Observation", "observe", "site_sun_exact", "topocentric_elevation", "find_visible_start", "spin_attitude",
           "pole_quaternion", "bisector_rate", "DEFAULT_SITE"]

#: ESA Optical Ground Station, Teide Observatory, Tenerife (a site that observes debris).
DEFAULT_SITE = EarthLocation.from_geodetic(lon=-16.5097 * u.deg, lat=28.2995 * u.deg, height=2393.0 * u.m)


@dataclass(frozen=True)
class KeplerOrbit:
    """Classical orbital elements at the epoch (SI, radians)."""

    a_m: float
    e: float = 0.0
    i_rad: float = 0.0
    raan_rad: float = 0.0
    argp_rad: float = 0.0
    nu0_rad: float = 0.0  #: true anomaly at the epoch

    def __post_init__(self):
        if not (np.isfinite(self.a_m) and self.a_m > R_EARTH):
            raise ValueError(f"orbit a_m must exceed the Earth's radius ({R_EARTH:.0f} m), got {self.a_m}")
        if not (0.0 <= self.e < 1.0):
            raise ValueError(f"orbit eccentricity e must be in [0, 1), got {self.e}")
        if self.a_m * (1.0 - self.e) <= R_EARTH:
            raise ValueError(f"orbit perigee {self.a_m * (1 - self.e):.0f} m is inside the Earth")

    @property
    def mean_motion(self) -> float:
        """rad/s."""
        return float(np.sqrt(MU_EARTH / self.a_m**3))

    def state(self, t_s) -> tuple[np.ndarray, np.ndarray]:
        """Position and velocity (m, m/s) in I at ``t_s`` seconds after the epoch, shapes (N, 3)."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        e = self.e
        E0 = 2.0 * np.arctan2(np.sqrt(1 - e) * np.sin(self.nu0_rad / 2), np.sqrt(1 + e) * np.cos(self.nu0_rad / 2))
        M = E0 - e * np.sin(E0) + self.mean_motion * t
        E = M.copy()
        for _ in range(30):  # Newton on Kepler's equation E - e sin E = M
            dE = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
            E -= dE
            if np.max(np.abs(dE)) < 1e-14:
                break
        cE, sE = np.cos(E), np.sin(E)
        r = self.a_m * (1.0 - e * cE)
        x_p = np.stack([self.a_m * (cE - e), self.a_m * np.sqrt(1 - e * e) * sE, np.zeros_like(E)], -1)
        v_fac = np.sqrt(MU_EARTH * self.a_m) / r
        v_p = np.stack([-v_fac * sE, v_fac * np.sqrt(1 - e * e) * cE, np.zeros_like(E)], -1)
        R = _rot_z(self.raan_rad) @ _rot_x(self.i_rad) @ _rot_z(self.argp_rad)  # perifocal -> I
        return x_p @ R.T, v_p @ R.T


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


@dataclass(frozen=True)
class Observation:
    """Geometry at each sample time (arrays of length N; vectors (N, 3) in I, metres)."""

    t_s: np.ndarray  #: s after the epoch
    epoch: Time
    r_target_I: np.ndarray
    r_observer_I: np.ndarray
    r_sun_I: np.ndarray
    range_m: np.ndarray
    elevation_rad: np.ndarray  #: of the target above the site's horizon (geodetic, no refraction)
    sun_elevation_rad: np.ndarray  #: of the Sun at the site
    phase_angle_rad: np.ndarray  #: Sun–target–observer angle
    sunlit: np.ndarray  #: bool, target outside the Earth's (cylindrical) shadow
    airmass: np.ndarray  #: Kasten & Young (1989); inf below the horizon
    visible: np.ndarray  #: bool: sunlit, above ``min_elevation`` and the site in darkness

    @property
    def sun_dir_I(self) -> np.ndarray:
        """Unit vectors target -> Sun."""
        d = self.r_sun_I - self.r_target_I
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    @property
    def observer_dir_I(self) -> np.ndarray:
        """Unit vectors target -> observer."""
        d = self.r_observer_I - self.r_target_I
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    @property
    def sun_distance_m(self) -> np.ndarray:
        return np.linalg.norm(self.r_sun_I - self.r_target_I, axis=1)


#: Spacing (s) of the nodes at which astropy evaluates the site and the Sun for :func:`observe`, which interpolates between them
#: (cubic spline): the site turns 0.044 rad between nodes, so the interpolation error is ≈ (5/384)·(0.044)⁴·R⊕ ≈ 0.3 m, against
#: 70 µs of astropy (erfa's ``epv00`` and the GCRS↔ITRS rotations) per sample time (10× per 6-h visibility block at 60 s steps).
NODE_SPACING_S = 600.0


def site_sun_exact(times: Time, site: EarthLocation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Site position, the site's local (geodetic) vertical and the Sun's apparent position, all in GCRS (I), at each of ``times``:
    arrays (N, 3), metres except the unit vertical; astropy at every time (:func:`observe` interpolates this)."""
    pos, _ = site.get_gcrs_posvel(times)
    lat, lon = site.lat.to_value(u.rad), site.lon.to_value(u.rad)
    up_itrs = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    # geocentric ITRS -> GCRS is a rotation, so the unit vector maps as a position would
    up = ITRS(CartesianRepresentation(np.repeat(up_itrs[:, None], len(times), axis=1) * u.m), obstime=times).transform_to(GCRS(obstime=times))
    up_I = up.cartesian.xyz.to_value(u.m).T
    sun = get_body("sun", times)
    return pos.xyz.to_value(u.m).T, up_I / np.linalg.norm(up_I, axis=1, keepdims=True), sun.cartesian.xyz.to_value(u.m).T


def _site_sun(t_s: np.ndarray, epoch: Time, site: EarthLocation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`site_sun_exact` at ``epoch + t_s``, evaluated on nodes :data:`NODE_SPACING_S` apart and interpolated (directly
    when there are fewer samples than nodes)."""
    lo, hi = float(np.min(t_s)), float(np.max(t_s))
    n = max(4, int(np.ceil((hi - lo) / NODE_SPACING_S)) + 1)
    if n >= t_s.size:
        return site_sun_exact(epoch + t_s * u.s, site)
    nodes = np.linspace(lo, hi, n)
    r_O, up, r_S = (CubicSpline(nodes, v, axis=0)(t_s) for v in site_sun_exact(epoch + nodes * u.s, site))
    return r_O, up / np.linalg.norm(up, axis=1, keepdims=True), r_S


def topocentric_elevation(r_I: np.ndarray, r_site_I: np.ndarray, up_I: np.ndarray) -> np.ndarray:
    """Topocentric geodetic elevation (rad) of positions ``r_I`` seen from the site at ``r_site_I`` with vertical ``up_I`` (all in I)."""
    d = r_I - r_site_I
    return np.arcsin(np.clip(np.einsum("ij,ij->i", d, up_I) / np.linalg.norm(d, axis=1), -1.0, 1.0))


def _airmass(elevation_rad: np.ndarray) -> np.ndarray:
    """Kasten & Young (1989) relative air mass; inf below the horizon."""
    h = np.degrees(elevation_rad)
    with np.errstate(invalid="ignore", divide="ignore"):
        X = 1.0 / (np.sin(elevation_rad) + 0.50572 * (h + 6.07995) ** -1.6364)
    return np.where(h > 0, X, np.inf)


def observe(orbit: KeplerOrbit, t_s, epoch: Time, site: EarthLocation = DEFAULT_SITE, *, min_elevation_deg: float = 15.0,
            max_sun_elevation_deg: float = -12.0) -> Observation:
    """Observation geometry at ``t_s`` seconds after ``epoch`` (see :class:`Observation`).

    Visibility: the target is sunlit, at least ``min_elevation_deg`` above the
    horizon, and the Sun at most ``max_sun_elevation_deg`` (nautical twilight).
    """
    t = np.atleast_1d(np.asarray(t_s, dtype=float))
    r_T, _ = orbit.state(t)
    r_O, up_I, r_S = _site_sun(t, epoch, site)  # r_S geocentric
    los = r_O - r_T
    rng = np.linalg.norm(los, axis=1)
    to_sun = r_S - r_T
    cos_phase = np.einsum("ij,ij->i", to_sun, los) / (np.linalg.norm(to_sun, axis=1) * rng)
    phase = np.arccos(np.clip(cos_phase, -1.0, 1.0))
    s_hat = r_S / np.linalg.norm(r_S, axis=1, keepdims=True)
    along = np.einsum("ij,ij->i", r_T, s_hat)
    perp = np.linalg.norm(r_T - along[:, None] * s_hat, axis=1)
    sunlit = (along > 0) | (perp > R_EARTH)  # cylindrical umbra
    elev = topocentric_elevation(r_T, r_O, up_I)
    sun_elev = topocentric_elevation(r_S, r_O, up_I)
    visible = sunlit & (elev >= np.radians(min_elevation_deg)) & (sun_elev <= np.radians(max_sun_elevation_deg))
    return Observation(t, epoch, r_T, r_O, r_S, rng, elev, sun_elev, phase, sunlit, _airmass(elev), visible)


def find_visible_start(orbit: KeplerOrbit, epoch: Time, duration_s: float, site: EarthLocation = DEFAULT_SITE, *, search_s: float = 2 * 86400.0,
                       step_s: float = 60.0, **visibility) -> float:
    """Earliest ``t0`` (s after ``epoch``, on a ``step_s`` grid) with the target visible over ``[t0, t0 + duration_s]``.

    The visibility grid is evaluated in 6-hour blocks (cached) and the search
    stops at the first block that holds the arc. Raises ``ValueError`` when no
    such arc exists within ``search_s``.
    """
    if not (duration_s > 0 and step_s > 0):
        raise ValueError(f"duration_s and step_s must be > 0, got {duration_s}, {step_s}")
    key = (site.lat.deg, site.lon.deg, site.height.to_value(u.m))
    opts = tuple(sorted(visibility.items()))
    block = int(np.ceil(6 * 3600.0 / step_s))
    n_total = int(np.ceil((search_s + duration_s) / step_s)) + 1
    need = int(np.ceil(duration_s / step_s)) + 1
    run = 0
    for k0 in range(0, n_total, block):
        vis = _visibility_block(orbit, epoch.utc.isot, key, k0 * step_s, min(block, n_total - k0), step_s, opts)
        for j, v in enumerate(vis):
            run = run + 1 if v else 0
            if run >= need:
                return float((k0 + j - need + 1) * step_s)
    raise ValueError(f"the target is never visible for {duration_s:.0f} s within {search_s / 86400:.1f} days of {epoch.isot} from this site")


@functools.lru_cache(maxsize=256)
def _visibility_block(orbit: KeplerOrbit, epoch_isot: str, site_key: tuple, t0_s: float, n: int, step_s: float, visibility: tuple) -> np.ndarray:
    """Visibility at ``t0_s + step_s·k``, k < n, cached: arcs of one scenario share the search (astropy transforms dominate)."""
    site = EarthLocation.from_geodetic(lon=site_key[1] * u.deg, lat=site_key[0] * u.deg, height=site_key[2] * u.m)
    vis = observe(orbit, t0_s + step_s * np.arange(n), Time(epoch_isot, scale="utc"), site, **dict(visibility)).visible
    vis.setflags(write=False)
    return vis


def pole_quaternion(axis_T, pole_I, phase_rad: float = 0.0) -> np.ndarray:
    """Attitude ``q_IT`` that puts the body axis ``axis_T`` along the inertial direction ``pole_I``,
    then turns the body by ``phase_rad`` about it."""
    a = np.asarray(axis_T, dtype=float)
    p = np.asarray(pole_I, dtype=float)
    a, p = a / np.linalg.norm(a), p / np.linalg.norm(p)
    # Orthonormal frames [a, b, a×b] in T and [p, c, p×c] in I; C_IT maps one onto the other.
    b = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    b /= np.linalg.norm(b)
    c = np.cross(p, [1.0, 0.0, 0.0] if abs(p[0]) < 0.9 else [0.0, 1.0, 0.0])
    c /= np.linalg.norm(c)
    cp, sp = np.cos(phase_rad), np.sin(phase_rad)
    c_rot = cp * c + sp * np.cross(p, c)
    F_T = np.stack([a, b, np.cross(a, b)], 1)
    F_I = np.stack([p, c_rot, np.cross(p, c_rot)], 1)
    return dcm_to_quat(F_I @ F_T.T)


def _attitude_rhs(t, x, J_diag):
    q, w = x[:4], x[4:]
    return np.concatenate([quat_derivative(q, w), euler_rhs(w, J_diag)])


def spin_attitude(q_IT0, w_T0, J_diag, t_s) -> tuple[np.ndarray, np.ndarray]:
    """Torque-free attitude ``q_IT`` (N, 4) and body rate ``ω_T`` (N, 3) at ``t_s`` from ``(q_IT0, ω_T0)``.

    Euler's equations with ``J_diag`` (eq. 29 of Maestrini et al.) and ``q̇ = ½ q ⊗ [0, ω]``,
    integrated by DOP853 at 1e-12 (:func:`estimators.dynamics.integrate_truth`).
    """
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("t_s must be a strictly increasing 1-D array with at least 2 samples")
    J = np.asarray(J_diag, dtype=float) / np.max(J_diag)
    x0 = np.concatenate([quat_normalize(np.asarray(q_IT0, dtype=float)), np.asarray(w_T0, dtype=float)])
    if t[0] != 0.0:  # integrate from the epoch of the initial state
        xs = integrate_truth(_attitude_rhs, np.concatenate([[0.0], t]), x0, J)[1:]
    else:
        xs = integrate_truth(_attitude_rhs, t, x0, J)
    return quat_normalize(xs[:, :4]), xs[:, 4:]


def bisector_rate(obs: Observation, pole_I) -> float:
    """Mean rate (rad/s, right-handed about ``pole_I``) of the Sun–observer bisector's azimuth.

    The least-squares slope of the unwrapped azimuth of
    ``b = ŝ + ô`` projected on the plane normal to ``pole_I``.
    """
    p = np.asarray(pole_I, dtype=float)
    p = p / np.linalg.norm(p)
    b = obs.sun_dir_I + obs.observer_dir_I
    b = b - np.outer(b @ p, p)
    e1 = b[0] / np.linalg.norm(b[0])
    e2 = np.cross(p, e1)
    azimuth = np.unwrap(np.arctan2(b @ e2, b @ e1))
    return float(np.polyfit(obs.t_s, azimuth, 1)[0])
