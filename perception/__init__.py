"""Stereo perception and pose measurements for CoMBiNa (§III–IV.A of ``000_…``).

Mitsuba stereo frames (:mod:`perception.render`), point clouds from OpenCV
features (:mod:`perception.stereo`), the coarse model of the preliminary phase
(:mod:`perception.model`), rigid BCPD registration (:mod:`perception.bcpd`)
and the pose measurements built on it (:mod:`perception.measure`).
"""

from perception.bcpd import BCPDResult, bcpd_rigid

__all__ = ["BCPDResult", "bcpd_rigid"]
