"""Stereo perception and pose measurements for CoMBiNa (§III–IV.A of Maestrini et al.).

Mitsuba stereo frames (:mod:`perception.render`), point clouds from OpenCV
features (:mod:`perception.stereo`), the coarse model of the preliminary phase
(:mod:`perception.model`), rigid BCPD registration (:mod:`perception.bcpd`)
and the pose measurements built on it (:mod:`perception.measure`).

Only the numpy/scipy parts are imported here; ``perception.render`` and
``perception.stereo`` load Mitsuba and OpenCV when imported themselves.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
.. [2] Hirose, *A Bayesian formulation of coherent point drift*, IEEE TPAMI 43(7), 2021.
"""

from perception.bcpd import BCPDResult, bcpd_rigid
from perception.measure import PoseMeasurement, measure_pose

__all__ = ["BCPDResult", "bcpd_rigid", "PoseMeasurement", "measure_pose"]
