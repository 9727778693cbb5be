"""Light curves: Mitsuba renders of unresolved targets, observation geometry, WindowCLEAN, spin priors.

Notebook use::

    from lightcurves import window_clean, extract_spin_prior
    prior = extract_spin_prior(t_s, mag, mag_err)
    prior.rate_deg_s, prior.rate_sigma_deg_s, prior.maxima_per_rotation

Modules: :mod:`~lightcurves.targets` (shapes, materials, mass properties),
:mod:`~lightcurves.scene` (Mitsuba pieces shared with ``perception``),
:mod:`~lightcurves.render`, :mod:`~lightcurves.geometry`,
:mod:`~lightcurves.photometry`, :mod:`~lightcurves.simulate`,
:mod:`~lightcurves.io`, :mod:`~lightcurves.clean`, :mod:`~lightcurves.prior`
(with its compiled kernels :mod:`~lightcurves.nufft`, :mod:`~lightcurves.harmonic_fits`,
:mod:`~lightcurves.phasors`).
Importing this package does not import Mitsuba (only ``scene``/``render`` do).

References
----------
.. [1] Renis, Price, Hellmich, Battipede, Salzmann, *Leveraging Light-Curve Inversion for Real-Time
   Kinematic State Estimation of Uncooperative Targets*.
"""

from lightcurves.clean import WindowCleanResult, window_clean
from lightcurves.prior import SpinPrior, extract_spin_prior
from lightcurves.samples import BadSeries

__all__ = ["window_clean", "WindowCleanResult", "extract_spin_prior", "SpinPrior", "BadSeries"]
