"""Mitsuba stereo frames of a target: two parallel pinhole cameras (Table 1 of Maestrini et al.).

The chaser camera frame C is the frame of eq. 1 of Maestrini et al.:
``p^C = [−(b/α)(v − v0), (b/α)(u − u0), −f d b/α]``. With ``u`` the image
column (to the right) and ``v`` counted *upwards* this frame is right-handed:
``x_C`` points down the image, ``y_C`` to the right, ``z_C`` against the
boresight (the cameras look along ``−z_C``). The left camera is at the origin
of C, the right one at ``+b y_C``, both looking along ``−z_C`` (parallel axes,
Fig. 4 of Maestrini et al.). C is the servicer body frame S (DESIGN.md).

The target pose is given as ``v_C = C_CT v_T + r_TC_C``. Rendering uses the
target frame as Mitsuba's world (W = T, as the light-curve renderer does): the
meshes stay put and the two cameras, the Sun (a directional emitter from
``sun_C``, the unit vector from the target to the Sun) and an optional point
lamp between the cameras are moved through
:class:`lightcurves.scene.ScenePoser`, so a sequence of frames neither
reloads nor rewrites meshes. The background is black.

Surface texture. The shared targets are flat-shaded meshes with uniform
materials; a stereo matcher finds nothing on a uniform face (only corners),
unlike on a real spacecraft (MLI wrinkles, cell grids, bolts — the paper's
Envisat model is textured). With ``texture=True`` (default) each part's
diffuse reflectance is modulated by a fixed random pattern (blurred noise,
blobs of ~6 cm, values 0.35–1 of the material's albedo) mapped on every face
by planar projection along its dominant normal axis; the geometry and the
specular lobe are the shared ones. ``texture=False`` renders the bare
materials.

The ground-truth depth (``z`` along the boresight, m) comes from Mitsuba's
``aov`` integrator (``dd.y``, the ray distance from the near-clip point) and
is for tests only; pixels only partly covered by the target are NaN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

from estimators.attitude import quat_to_dcm
from estimators.state import Q_TS, R_ST_T
from lightcurves import scene as lscene
from lightcurves.targets import Target

__all__ = ["StereoCamera", "StereoFrame", "StereoRenderer", "pose_from_relative_state", "pointing_dcm"]

import mitsuba as mi  # noqa: E402  (lightcurves.scene points Dr.Jit at a good libLLVM first)

#: Mitsuba camera axes (x left, y up, z forward) expressed in C (x down, y right, z backward).
_C_FROM_MITSUBA = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
_NEAR_CLIP_M = 0.01


@dataclass(frozen=True)
class StereoCamera:
    """Parallel-axis stereo camera of Table 1 of Maestrini et al.

    ``resolution_px`` is the rendered square size; the focal length in pixels
    scales with it so the field of view is always that of the full
    ``full_resolution_px`` sensor (34.8° for Table 1).
    """

    focal_length_m: float = 0.034
    pixel_density_px_m: float = 48_000.0
    baseline_m: float = 1.0
    full_resolution_px: int = 1024
    resolution_px: int = 512

    def __post_init__(self):
        if not (self.focal_length_m > 0 and self.pixel_density_px_m > 0 and self.baseline_m > 0):
            raise ValueError("focal_length_m, pixel_density_px_m and baseline_m must be positive")
        if not (16 <= int(self.resolution_px) <= 8192 and 16 <= int(self.full_resolution_px) <= 8192):
            raise ValueError(f"resolution_px must be an integer in 16..8192, got {self.resolution_px}")

    @property
    def f_px(self) -> float:
        """Focal length in pixels of the rendered image, ``f d`` scaled to ``resolution_px``."""
        return self.focal_length_m * self.pixel_density_px_m * self.resolution_px / self.full_resolution_px

    @property
    def fov_deg(self) -> float:
        """Full horizontal (= vertical) field of view, degrees."""
        return float(np.rad2deg(2.0 * np.arctan(0.5 * self.resolution_px / self.f_px)))

    @property
    def center_px(self) -> float:
        """Principal point ``u0 = v0`` in pixel coordinates (pixel ``i`` spans ``[i, i+1)``)."""
        return 0.5 * self.resolution_px

    def project(self, p_C) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Left-image column ``u``, row ``r`` (pixel coordinates) and disparity ``α`` of points in C.

        The inverse of eq. 1: ``α = f d b / (−z)``, ``u = u0 + y α / b``, ``r = r0 + x α / b``.
        """
        p = np.asarray(p_C, dtype=float)
        depth = -p[..., 2]
        alpha = self.f_px * self.baseline_m / depth
        return self.center_px + p[..., 1] * alpha / self.baseline_m, self.center_px + p[..., 0] * alpha / self.baseline_m, alpha


@dataclass(frozen=True)
class StereoFrame:
    """One rendered stereo pair.

    ``left``/``right``: (H, W, 3) linear RGB radiance, W m⁻² sr⁻¹.
    ``depth_left``/``depth_right``: (H, W) ground-truth depth along the
    boresight, m (NaN off the target or on partly covered pixels).
    ``white_radiance``: radiance of a white Lambertian plate facing the Sun
    (``E/π``), the natural exposure reference. ``variant``: Mitsuba variant used.
    """

    left: np.ndarray
    right: np.ndarray
    depth_left: np.ndarray
    depth_right: np.ndarray
    camera: StereoCamera
    white_radiance: float
    variant: str


def pose_from_relative_state(x) -> tuple[np.ndarray, np.ndarray]:
    """``(C_CT, r_TC_C)`` from a relative state ``[q_TS, ω_ST_T, r_ST_T, …]`` (Renis et al.), with C = S.

    ``C_CT = R(q_TS)ᵀ``; ``r_ST_T`` is the servicer relative to the target in T,
    so the target relative to the camera is ``r_TC_C = −C_CT r_ST_T``.
    """
    x = np.asarray(x, dtype=float)
    C_CT = quat_to_dcm(x[Q_TS]).T
    return C_CT, -C_CT @ x[R_ST_T]


def pointing_dcm(los_I, up_I) -> np.ndarray:
    """``C_IC`` of a camera whose boresight ``−z_C`` points along ``los_I``.

    ``−x_C`` (image up) is the part of ``up_I`` normal to the line of sight.
    """
    z = -np.asarray(los_I, dtype=float)
    z /= np.linalg.norm(z)
    up = np.asarray(up_I, dtype=float)
    x = -(up - (up @ z) * z)
    nx = np.linalg.norm(x)
    if nx < 1e-9:
        raise ValueError("pointing_dcm: up_I is parallel to the line of sight")
    x /= nx
    return np.stack([x, np.cross(z, x), z], axis=1)


def _texture_pattern(rng: np.random.Generator, n: int = 128, blur_texels: float = 4.0) -> np.ndarray:
    """Blurred uniform noise on an ``n × n`` periodic grid, rescaled to [0.35, 1]."""
    g = gaussian_filter(rng.random((n, n)), blur_texels, mode="wrap")
    g = (g - g.min()) / (g.max() - g.min())
    return (0.35 + 0.65 * g).astype(np.float32)


def _textured_bsdf(bsdf: dict, pattern: np.ndarray, tile_m: float) -> dict:
    """``bsdf`` with every diffuse ``reflectance`` ``ρ`` replaced by the texture ``ρ · pattern``."""
    out = {}
    for key, val in bsdf.items():
        if isinstance(val, dict):
            val = _textured_bsdf(val, pattern, tile_m)
            if val.get("type") == "diffuse":
                rho = float(val["reflectance"])
                val = dict(val, reflectance={"type": "bitmap", "bitmap": mi.Bitmap(rho * pattern[..., None]), "raw": True, "wrap_mode": "repeat"})
        out[key] = val
    return out


def _textured_mesh(part, pattern: np.ndarray, tile_m: float):
    """``part`` as a Mitsuba mesh with unshared vertices and planar-projected texture coordinates."""
    V = part.vertices_T[part.faces].reshape(-1, 3)
    F = np.arange(len(V), dtype=np.uint32).reshape(-1, 3)
    n = np.cross(V[1::3] - V[0::3], V[2::3] - V[0::3])
    axis = np.repeat(np.argmax(np.abs(n), axis=1), 3)
    others = np.array([[1, 2], [0, 2], [0, 1]])[axis]
    uv = np.take_along_axis(V, others, axis=1) / tile_m
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(_textured_bsdf(lscene.bsdf_dict(part.material), pattern, tile_m))
    N = None if part.normals_T is None else part.normals_T[part.faces].reshape(-1, 3)
    mesh = mi.Mesh(part.name, len(V), len(F), props=props, has_vertex_normals=N is not None, has_vertex_texcoords=True)
    mp = mi.traverse(mesh)
    if N is not None:
        mp["vertex_normals"] = type(mp["vertex_normals"])(N.astype(np.float32).ravel())
    mp["vertex_positions"] = type(mp["vertex_positions"])(V.astype(np.float32).ravel())
    mp["faces"] = type(mp["faces"])(F.ravel())
    mp["vertex_texcoords"] = type(mp["vertex_texcoords"])(uv.astype(np.float32).ravel())
    mp.update()
    return mesh


class StereoRenderer:
    """Renders stereo pairs of one target; the scene is loaded once.

    Parameters
    ----------
    target : a :class:`lightcurves.targets.Target` (meshes in its frame T).
    camera : the stereo camera (Table 1 by default, rendered at 512 px).
    lamp_intensity_w_sr : radiant intensity of a chaser-mounted point lamp
        between the cameras, W/sr (0: the Sun is the only light).
    texture : modulate the diffuse albedo with a surface pattern (module docstring).
    texture_seed : seed of that pattern (a property of the target, fixed per scene).
    variant : Mitsuba variant, see :func:`lightcurves.scene.select_variant`.
    """

    def __init__(
        self,
        target: Target,
        camera: StereoCamera | None = None,
        *,
        lamp_intensity_w_sr: float = 0.0,
        texture: bool = True,
        texture_seed: int = 0,
        variant: str | None = None,
    ):
        if lamp_intensity_w_sr < 0:
            raise ValueError(f"lamp_intensity_w_sr must be >= 0, got {lamp_intensity_w_sr}")
        self.camera = camera or StereoCamera()
        self.target = target
        self.variant = lscene.select_variant(variant)
        cam = self.camera
        sensors = {}
        for key, offset in (("camera_left", 0.0), ("camera_right", cam.baseline_m)):
            # distinct initial transforms: Mitsuba merges identical plugin dicts into one object
            sensors[key] = {
                "type": "perspective",
                "to_world": mi.ScalarTransform4f(self._to_world(np.eye(3), np.array([0.0, offset, 0.0]))),
                "fov": cam.fov_deg,
                "fov_axis": "x",
                "near_clip": _NEAR_CLIP_M,
                "far_clip": 1e5,
                "film": {
                    "type": "hdrfilm",
                    "width": int(cam.resolution_px),
                    "height": int(cam.resolution_px),
                    "rfilter": {"type": "box"},
                    "pixel_format": "rgba",
                },
                "sampler": {"type": "independent", "sample_count": 16},
            }
        d = lscene.scene_dict(
            target, np.array([0.0, 0.0, 1.0]), sensors=sensors, integrator={"type": "aov", "aovs": "dd.y:depth", "integrator": {"type": "direct"}}
        )
        if texture:
            pattern = _texture_pattern(np.random.default_rng(texture_seed))
            for part in target.parts:
                d[lscene.part_key(part.name)] = _textured_mesh(part, pattern, tile_m=2.0)
        self.lamp = lamp_intensity_w_sr > 0
        if self.lamp:
            d["lamp"] = {"type": "point", "position": [0.0, 0.0, 0.0], "intensity": float(lamp_intensity_w_sr)}
        self.scene = mi.load_dict(d)
        self.poser = lscene.ScenePoser(self.scene, target)
        self._sensors = {s.id(): s for s in self.scene.sensors()}
        n = cam.resolution_px
        c = (np.arange(n) + 0.5 - cam.center_px) / cam.f_px
        # cos of the angle between each pixel ray and the boresight: z-depth = ray length × cos
        self._cos = 1.0 / np.sqrt(1.0 + c[:, None] ** 2 + c[None, :] ** 2)

    @staticmethod
    def _to_world(C_TC: np.ndarray, origin_T: np.ndarray) -> np.ndarray:
        """Camera-to-world (W = T) matrix of a camera at ``origin_T`` with axes C."""
        M = np.eye(4)
        M[:3, :3] = C_TC @ _C_FROM_MITSUBA
        M[:3, 3] = origin_T
        return M

    def render(self, C_CT, r_TC_C, sun_C, *, spp: int = 16, seed: int = 0) -> StereoFrame:
        """Render the pair with the target at attitude ``C_CT`` and position ``r_TC_C`` (m) in C.

        ``sun_C``: unit vector from the target towards the Sun in C.
        ``spp``: samples per pixel; ``seed``: Mitsuba's sampler seed.
        """
        C_CT = np.asarray(C_CT, dtype=float)
        r = np.asarray(r_TC_C, dtype=float)
        if C_CT.shape != (3, 3) or not np.allclose(C_CT @ C_CT.T, np.eye(3), atol=1e-6):
            raise ValueError("C_CT must be a 3x3 rotation matrix")
        if r.shape != (3,) or not np.all(np.isfinite(r)) or r[2] >= 0:
            raise ValueError(f"r_TC_C must be a finite 3-vector in m in front of the camera (z < 0), got {r}")
        if int(spp) < 1:
            raise ValueError(f"spp must be >= 1, got {spp}")
        C_TC = C_CT.T
        o_left_T = -C_TC @ r  # camera origin relative to the target centre, in T
        b_T = self.camera.baseline_m * C_TC[:, 1]  # right camera at +b y_C
        self.poser.set_sensor("camera_left", self._to_world(C_TC, o_left_T))
        self.poser.set_sensor("camera_right", self._to_world(C_TC, o_left_T + b_T))
        self.poser.set_sun(C_TC @ np.asarray(sun_C, dtype=float))
        if self.lamp:
            self.poser.params["lamp.position"] = mi.Point3f(*(float(v) for v in o_left_T + 0.5 * b_T))
            self.poser.params.update()
        out = {}
        for side in ("left", "right"):
            img = np.array(mi.render(self.scene, sensor=self._sensors[f"camera_{side}"], spp=int(spp), seed=int(seed)), dtype=float)
            rgb, alpha, ray_t = img[..., :3], img[..., 3], img[..., 4]
            # dd.y is the mean hit distance from the near-clip point: z = (t + near/cos) cos
            depth = np.where(alpha > 0.999, (ray_t / np.maximum(alpha, 1e-12)) * self._cos + _NEAR_CLIP_M, np.nan)
            out[side] = (rgb, depth)
        return StereoFrame(
            left=out["left"][0],
            right=out["right"][0],
            depth_left=out["left"][1],
            depth_right=out["right"][1],
            camera=self.camera,
            white_radiance=lscene.SUN_IRRADIANCE_W_M2 / np.pi,
            variant=self.variant,
        )
