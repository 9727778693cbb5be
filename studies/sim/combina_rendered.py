"""The rendered measurement chain of CoMBiNa (Maestrini et al. §IV.A): Mitsuba stereo → point cloud → BCPD.

At each measurement epoch the chaser points its stereo camera at the
*estimated* target position, Mitsuba renders the pair with the target at its
*true* pose (:class:`perception.render.StereoRenderer`), OpenCV features give
the cloud (:func:`perception.stereo.stereo_cloud`), and BCPD registers it
against the coarse model seeded by the filters' prediction (eqs 3–8,
:func:`perception.measure.measure_pose`). The result is converted to the
:class:`perception.simulated_bcpd.RegisteredPose` the filters consume.

Choices made here:

* the coarse model is the *ideal* one (points uniform on the mesh surface in
  T, :func:`perception.model.mesh_surface_points`), i.e. a preliminary phase
  whose model frame coincides with the principal axes; building it from a
  rendered inspection orbit (:func:`perception.model.build_coarse_model`)
  leaves a model frame a few degrees off the principal axes, which the
  truth comparison would then have to carry — not done here;
* the Sun is fixed in I, on the chaser's side of the target at the start
  (40° phase, tilted towards the orbit normal); as LVLH turns with the orbit
  the lit side turns away and dark views give degenerate clouds, which are
  recorded as rejected registrations;
* the chaser's camera axes follow :func:`perception.render.pointing_dcm`
  (boresight at the estimate, image up along the orbit normal); its attitude
  is known (§III of Maestrini et al.).
"""

from __future__ import annotations

import numpy as np

from estimators.attitude import dcm_to_quat, quat_to_dcm, rotvec_to_quat
from lightcurves.targets import Target
from perception.measure import measure_pose
from perception.model import mesh_surface_points
from perception.render import StereoCamera, StereoRenderer, pointing_dcm
from perception.simulated_bcpd import RegisteredPose
from perception.stereo import stereo_cloud


class RenderedBCPD:
    """Stereo rendering + point cloud + BCPD pose measurement of a mesh target.

    Parameters
    ----------
    target : lightcurves.targets.Target
        the mesh target (frame T = its principal axes).
    t_s, C_LI : (N,), (N, 3, 3)
        the chaser's LVLH attitude at the measurement epochs.
    rng : numpy.random.Generator
        draws the model points and the renderer's sampler seeds.
    resolution_px, spp : int
        rendered image size and samples per pixel.
    n_model : int
        points of the coarse model.
    """

    def __init__(self, target: Target, t_s, C_LI, rng: np.random.Generator, *, resolution_px: int = 512, spp: int = 8, n_model: int = 3000):
        self.target = target
        self.t_s = np.asarray(t_s, dtype=float)
        self.C_LI = np.asarray(C_LI, dtype=float)
        self.rng = rng
        self.spp = int(spp)
        self.renderer = StereoRenderer(target, StereoCamera(resolution_px=int(resolution_px)))
        self.model_T, _ = mesh_surface_points(target, int(n_model), rng)
        C_IL0 = self.C_LI[0].T
        toward_chaser = rotvec_to_quat(np.deg2rad(40.0) * np.array([0.0, 0.0, 1.0]))
        s_L = quat_to_dcm(toward_chaser) @ np.array([-1.0, 0.0, 0.0]) + np.array([0.0, 0.0, 0.3])
        self.sun_I = C_IL0 @ (s_L / np.linalg.norm(s_L))

    def measure(self, t: float, r_L_true, q_IT_true, *, r_L_hat, q_IT_hat) -> RegisteredPose:
        """Render at the true pose, register from the predicted one (eqs 3–8)."""
        i = int(np.argmin(np.abs(self.t_s - t)))
        C_IL = self.C_LI[i].T
        r_L_hat = np.asarray(r_L_hat, dtype=float)
        C_IC = pointing_dcm(C_IL @ r_L_hat, C_IL[:, 2])
        C_CI = C_IC.T
        r_TC_C = C_CI @ C_IL @ np.asarray(r_L_true, dtype=float)
        if r_TC_C[2] >= 0:  # target behind the camera: no image
            return _no_registration(t, "target outside the field of view")
        frame = self.renderer.render(C_CI @ quat_to_dcm(q_IT_true), r_TC_C, C_CI @ self.sun_I, spp=self.spp, seed=int(self.rng.integers(2**31)))
        cloud = stereo_cloud(frame.left, frame.right, self.renderer.camera)
        cloud_L = cloud.points_C @ (self.C_LI[i] @ C_IC).T  # relative to the chaser, in L
        m = measure_pose(cloud.points_C, self.model_T, C_TI_hat=quat_to_dcm(q_IT_hat).T, C_IC=C_IC, C_IL=C_IL, r_L_hat=r_L_hat)
        if m.registration is None:
            return _no_registration(t, m.reason, cloud_L)
        return RegisteredPose(t=float(t), r_L=m.r_L, q_IT=dcm_to_quat(m.C_TI.T), scale=m.scale, kind="rendered", cloud_L=cloud_L)


def _no_registration(t: float, reason: str, cloud_L=None) -> RegisteredPose:
    nan3 = np.full(3, np.nan)
    return RegisteredPose(t=float(t), r_L=nan3, q_IT=np.full(4, np.nan), scale=float("nan"), kind=f"no registration: {reason}", cloud_L=cloud_L)
