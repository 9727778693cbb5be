"""Light-curve inversion: the spin state (pole, sidereal period, phase, body spin axis) from light curves.

One light curve gives a (synodic) rate; several, seen under changing Sun–observer geometry, give the
pole — the angular-momentum direction, so the sense too — and the sidereal period. This subpackage
is a pure library (arrays in, result objects out; no files, no progress bars):

* :mod:`~lightcurves.inversion.data` — :class:`InversionCurve`, one light curve with its per-sample
  geometry (Sun and observer directions in the inertial frame I), the input of everything here.
* :mod:`~lightcurves.inversion.spin` — :class:`SpinState`, the attitude of a principal-axis rotation.
* :mod:`~lightcurves.inversion.convex` — :class:`ConvexModel` (free facet areas), :class:`EllipsoidModel`.
* :mod:`~lightcurves.inversion.search` — :func:`invert`: pole/period grid, refinement.
* :mod:`~lightcurves.inversion.periods` — :func:`~lightcurves.inversion.periods.period_ranges`: the period ranges to search, from each curve's own period.
* :mod:`~lightcurves.inversion.profile` — the pole's profile likelihood: :func:`pole_profile_chi2` at one pole,
  :func:`pole_profile_region` over the region it defines.
* :mod:`~lightcurves.inversion.phase_screen` — the known-shape screen over pole × body axis × rate × phase.
* :mod:`~lightcurves.inversion.posterior` — :class:`SpinSolution`, :class:`InversionResult`.
* :mod:`~lightcurves.inversion.known_shape` — :class:`KnownShapeModel`, a known target as facets: its intensity (W/sr) as Mitsuba renders it.
* :mod:`~lightcurves.inversion.frames`, :mod:`~lightcurves.inversion.io` — pole conversions; DAMIT, ECSV and CSV readers.

References
----------
.. [1] Kaasalainen & Torppa, *Optimization methods for asteroid lightcurve inversion I: shape
   determination*, Icarus 153 (2001).
.. [2] Kaasalainen, Torppa & Muinonen, *Optimization methods for asteroid lightcurve inversion II:
   the complete inverse problem*, Icarus 153 (2001).
"""

from lightcurves.inversion.convex import ConvexModel, EllipsoidModel
from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.known_shape import KnownShapeModel
from lightcurves.inversion.posterior import InversionResult, SpinSolution
from lightcurves.inversion.profile import PoleProfileRegion, pole_profile_chi2, pole_profile_region
from lightcurves.inversion.search import invert
from lightcurves.inversion.spin import SpinState

__all__ = ["InversionCurve", "SpinState", "ConvexModel", "EllipsoidModel", "KnownShapeModel", "SpinSolution", "InversionResult", "invert", "pole_profile_chi2",
           "pole_profile_region", "PoleProfileRegion"]
