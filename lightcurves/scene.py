"""Mitsuba scene pieces shared by both renderers: variant, materials, the Sun, target meshes, poses.

Stable API (shared with ``perception``; DESIGN.md)
---------------------------------------------------
* :func:`select_variant` ``(variant=None) -> str`` — sets Mitsuba's variant:
  ``llvm_ad_rgb`` when a libLLVM >= 16 is usable, else ``scalar_rgb``; returns
  the name that runs. Call it (or :func:`scene_dict`, which calls it) before
  building any Mitsuba object. Importing this module points
  ``DRJIT_LIBLLVM_PATH`` at the newest ``/usr/lib/*/libLLVM*.so*`` of version
  >= 16 unless it is already set: Dr.Jit would otherwise pick up libLLVM-15,
  which aborts the process inside LLVM.
* :func:`bsdf_dict` ``(material) -> dict`` — Cook-Torrance BSDF (two-sided).
* :func:`cook_torrance_brdf` — the same BRDF in closed form (numpy), for checks.
* :func:`sun_dict` ``(sun_W, irradiance_w_m2=1361) -> dict`` — the Sun as a
  directional emitter; ``sun_W`` is the unit vector *from the target to the
  Sun* in the world frame W.
* :func:`target_meshes` ``(target) -> {key: mi.Mesh}``; keys are
  :func:`part_key` ``(part_name)`` = ``"target_<part>"``.
* :func:`scene_dict` ``(target, sun_W, sensors=None, integrator=None) -> dict``
  — a ``mi.load_dict``-able scene: the meshes, the Sun (key ``"sun"``), the
  given sensors (``{key: sensor dict}``) and a ``direct`` integrator
  (self-shadowing included). Add your own cameras through ``sensors``.
* :class:`ScenePoser` ``(scene, target)`` — moves things in a loaded scene
  through ``mi.traverse`` without reloading: ``set_target_pose(C_WT, r_W)``
  (rewrites vertex positions/normals from the T-frame originals),
  ``set_sun(sun_W)``, ``set_sensor(key, to_world_4x4)``; each ends with
  ``params.update()``.
* :func:`load_mesh_target` ``({part: (path, Material)}, ...) -> Target`` —
  user OBJ/PLY files (Mitsuba's loaders), one file per part, each with its
  own material.
* :func:`look_at_matrix` ``(origin, target, up) -> (4, 4)`` — Mitsuba's
  camera convention (local +z forward, +y up, +x = up × forward, i.e. left);
  :func:`frame_from_z` ``(z)`` — a rotation (4×4) whose local +z is ``z``.

World frame W is the caller's: the light-curve renderer uses W = T (the target
stays put; the Sun and the sensor move), the stereo renderer poses the target.
"""

from __future__ import annotations

import glob
import os
import re
from pathlib import Path

import numpy as np
from scipy.special import erf

from lightcurves.targets import Material, Part, Target, make_target

__all__ = [
    "SUN_IRRADIANCE_W_M2",
    "libllvm_path",
    "select_variant",
    "bsdf_dict",
    "cook_torrance_brdf",
    "sun_dict",
    "part_key",
    "target_meshes",
    "scene_dict",
    "look_at_matrix",
    "frame_from_z",
    "ScenePoser",
    "load_mesh_target",
]

SUN_IRRADIANCE_W_M2 = 1361.0
"""Total solar irradiance at 1 au, W/m² (Kopp & Lean 2011)."""

_LLVM_MIN = 16


def libllvm_path() -> str | None:
    """Path of a libLLVM usable by Dr.Jit: ``$DRJIT_LIBLLVM_PATH`` or the newest system one >= 16."""
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env:
        return env
    best: tuple[int, str] | None = None
    for path in glob.glob("/usr/lib/*/libLLVM*.so*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"):
        m = re.search(r"libLLVM(?:-(\d+)|\.so\.(\d+))", os.path.basename(path))
        if not m:
            continue
        version = int(m.group(1) or m.group(2))
        if version >= _LLVM_MIN and (best is None or version > best[0]):
            best = (version, path)
    return best[1] if best else None


_path = libllvm_path()
if _path and "DRJIT_LIBLLVM_PATH" not in os.environ:
    os.environ["DRJIT_LIBLLVM_PATH"] = _path

import mitsuba as mi  # noqa: E402  (after DRJIT_LIBLLVM_PATH is set)

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


def select_variant(variant: str | None = None) -> str:
    """Set Mitsuba's variant and return its name.

    ``variant=None`` picks ``llvm_ad_rgb`` when a libLLVM >= 16 is present
    (:func:`libllvm_path`), else ``scalar_rgb``. An explicit ``"llvm_ad_rgb"``
    without a good libLLVM raises ``ValueError`` rather than crashing later.
    """
    if variant is None:
        variant = "llvm_ad_rgb" if libllvm_path() else "scalar_rgb"
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    if variant.startswith("llvm") and not libllvm_path():
        raise ValueError(f"variant {variant!r} needs libLLVM >= {_LLVM_MIN} (e.g. Debian's libllvm19); none found, use 'scalar_rgb'")
    if mi.variant() != variant:
        mi.set_variant(variant)
    return variant


# ---------------------------------------------------------------- materials


def bsdf_dict(material: Material) -> dict:
    """Cook-Torrance BSDF of ``material`` as a Mitsuba dict (two-sided).

    ``blendbsdf`` of a ``diffuse`` and a Beckmann ``roughconductor`` (complex
    Fresnel of ``eta + i k``), both with reflectance ``d + s`` and blend weight
    ``s / (d + s)``, so the sum is ``d/π + s·F D G/(4 cos θ_i cos θ_o)``
    (:func:`cook_torrance_brdf`).
    """
    d, s = material.diffuse_albedo, material.specular_albedo
    if s == 0.0:
        inner = {"type": "diffuse", "reflectance": d}
    else:
        total = d + s
        inner = {
            "type": "blendbsdf",
            "weight": s / total,
            "bsdf_0": {"type": "diffuse", "reflectance": total},
            "bsdf_1": {
                "type": "roughconductor",
                "distribution": "beckmann",
                "alpha": material.roughness,
                "eta": material.eta,
                "k": material.k,
                "specular_reflectance": total,
            },
        }
    return {"type": "twosided", "bsdf": inner}


def _fresnel_conductor(cos_i, eta: float, k: float):
    """Unpolarised Fresnel reflectance at a conductor/dielectric of index ``eta + i k`` (Born & Wolf §13.2)."""
    n2 = complex(eta, k) ** 2
    c = np.asarray(cos_i, dtype=complex)
    root = np.sqrt(n2 - (1.0 - c * c))
    r_s = np.abs((c - root) / (c + root)) ** 2
    r_p = np.abs((n2 * c - root) / (n2 * c + root)) ** 2
    return 0.5 * (r_s + r_p)


def _smith_g1_beckmann(cos_v, alpha: float):
    """Exact Smith masking of the Beckmann distribution, ``1/(1+Λ(a))``, ``a = 1/(α tan θ)`` (Walter et al. 2007, eq. 27)."""
    cos_v = np.clip(cos_v, 1e-12, 1.0)
    tan_v = np.sqrt(np.maximum(1.0 - cos_v**2, 0.0)) / cos_v
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 1.0 / (alpha * tan_v)
        lam = 0.5 * (erf(a) - 1.0) + np.exp(-a * a) / (2.0 * a * np.sqrt(np.pi))
    return np.where(tan_v == 0.0, 1.0, 1.0 / (1.0 + lam))


def cook_torrance_brdf(material: Material, n, wi, wo) -> np.ndarray:
    """Closed-form Cook-Torrance BRDF (1/sr) for unit normal ``n``, light ``wi`` and view ``wo`` directions.

    ``f = d/π + s F(wi·h) D(h) G1(wi) G1(wo) / (4 cos θ_i cos θ_o)``,
    ``D(h) = exp(-tan²θ_h/α²)/(π α² cos⁴θ_h)`` (Beckmann), zero below the
    horizon. Vectorised over leading dimensions.
    """
    n, wi, wo = (np.asarray(v, dtype=float) for v in (n, wi, wo))
    cos_i = np.einsum("...k,...k->...", n, wi)
    cos_o = np.einsum("...k,...k->...", n, wo)
    f = np.full(np.broadcast(cos_i, cos_o).shape, material.diffuse_albedo / np.pi)
    if material.specular_albedo > 0.0:
        h = wi + wo
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        cos_h = np.clip(np.einsum("...k,...k->...", n, h), 1e-12, 1.0)
        a2 = material.roughness**2
        D = np.exp(-(1.0 - cos_h**2) / (cos_h**2 * a2)) / (np.pi * a2 * cos_h**4)
        G = _smith_g1_beckmann(cos_i, material.roughness) * _smith_g1_beckmann(cos_o, material.roughness)
        F = _fresnel_conductor(np.einsum("...k,...k->...", wi, h), material.eta, material.k)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = f + material.specular_albedo * F * D * G / (4.0 * cos_i * cos_o)
    return np.where((cos_i > 0) & (cos_o > 0), f, 0.0)


# ---------------------------------------------------------------- emitters, meshes, transforms


def look_at_matrix(origin, target, up) -> np.ndarray:
    """4×4 camera-to-world matrix in Mitsuba's convention (``ScalarTransform4f.look_at``)."""
    origin, target, up = (np.asarray(v, dtype=float) for v in (origin, target, up))
    d = target - origin
    d /= np.linalg.norm(d)
    left = np.cross(up, d)
    nl = np.linalg.norm(left)
    if nl < 1e-9:
        raise ValueError("look_at: 'up' is parallel to the viewing direction")
    left /= nl
    new_up = np.cross(d, left)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = left, new_up, d, origin
    return M


def frame_from_z(z) -> np.ndarray:
    """A rotation (4×4) whose local +z is the unit vector ``z``."""
    z = np.asarray(z, dtype=float)
    helper = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return look_at_matrix(np.zeros(3), z, helper)


def _unit(v, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    nv = np.linalg.norm(v)
    if not (np.isfinite(nv) and nv > 0):
        raise ValueError(f"{name} must be a finite non-zero 3-vector, got {v}")
    return v / nv


def sun_dict(sun_W, irradiance_w_m2: float = SUN_IRRADIANCE_W_M2) -> dict:
    """Directional emitter for the Sun; ``sun_W`` points from the target to the Sun."""
    s = _unit(sun_W, "sun_W")
    return {"type": "directional", "to_world": mi.ScalarTransform4f(frame_from_z(-s)), "irradiance": float(irradiance_w_m2)}


def part_key(part_name: str) -> str:
    """Scene-dict key of a target part's mesh."""
    return f"target_{part_name}"


def _set_buffer(params, key: str, values, dtype=np.float32) -> None:
    """Write a flat buffer parameter with the variant's own array type (JIT or scalar)."""
    params[key] = type(params[key])(np.ascontiguousarray(values, dtype=dtype).ravel())


def _fill_mesh(params, V: np.ndarray, N: np.ndarray | None, prefix: str = "") -> None:
    _set_buffer(params, prefix + "vertex_positions", V)
    if N is not None:
        _set_buffer(params, prefix + "vertex_normals", N)


def target_meshes(target: Target) -> dict:
    """One ``mi.Mesh`` per part (positions in T), keyed by :func:`part_key`."""
    out = {}
    for p in target.parts:
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf_dict(p.material))
        mesh = mi.Mesh(p.name, len(p.vertices_T), len(p.faces), props=props, has_vertex_normals=p.normals_T is not None)
        mp = mi.traverse(mesh)
        _fill_mesh(mp, p.vertices_T, p.normals_T)
        _set_buffer(mp, "faces", p.faces, np.uint32)
        mp.update()
        out[part_key(p.name)] = mesh
    return out


def scene_dict(target: Target, sun_W, sensors: dict | None = None, integrator: dict | None = None, variant: str | None = None) -> dict:
    """A loadable scene: target meshes (in T), the Sun (key ``"sun"``), ``sensors``, an integrator.

    The default integrator is ``direct`` (one bounce of sunlight, shadows
    traced), which is what an unresolved light curve needs; pass e.g.
    ``{"type": "path", "max_depth": 3}`` to add inter-reflections.
    """
    if mi.variant() is None or variant is not None:
        select_variant(variant)
    d = {"type": "scene", "integrator": integrator or {"type": "direct"}, "sun": sun_dict(sun_W)}
    d.update(target_meshes(target))
    for key, sensor in (sensors or {}).items():
        if key in d:
            raise ValueError(f"sensor key {key!r} clashes with a scene key")
        d[key] = sensor
    return d


class ScenePoser:
    """Update a loaded scene in place through ``mi.traverse`` (no reloading).

    ``ScenePoser(scene, target)``; ``set_target_pose(C_WT, r_W)`` places the
    target (``v_W = C_WT v_T + r_W``); ``set_sun(sun_W)``; ``set_sensor(key,
    M)`` with a 4×4 camera-to-world matrix (e.g. :func:`look_at_matrix`, times
    a scale for orthographic film size).
    """

    def __init__(self, scene, target: Target):
        self.params = mi.traverse(scene)
        self.target = target

    def set_target_pose(self, C_WT, r_W) -> None:
        C = np.asarray(C_WT, dtype=float).reshape(3, 3)
        r = np.asarray(r_W, dtype=float).reshape(3)
        for p in self.target.parts:
            normals = None if p.normals_T is None else p.normals_T @ C.T
            _fill_mesh(self.params, p.vertices_T @ C.T + r, normals, prefix=part_key(p.name) + ".")
        self.params.update()

    def set_sun(self, sun_W) -> None:
        self.params["sun.to_world"] = mi.Transform4f(frame_from_z(-_unit(sun_W, "sun_W")))
        self.params.update()

    def set_sensor(self, key: str, to_world) -> None:
        self.params[f"{key}.to_world"] = mi.Transform4f(np.asarray(to_world, dtype=float))
        self.params.update()


def load_mesh_target(parts: dict, *, name: str = "mesh", scale: float = 1.0, density_kg_m3: float = 1.0) -> Target:
    """Target from user mesh files: ``{part_name: (path, Material), ...}``.

    Each file (OBJ or PLY, read with Mitsuba's loaders, so binary PLY works)
    is one part with one material, in metres times ``scale``. Coincident
    vertices are welded; the union of the parts must be closed. Sets Mitsuba's
    variant (:func:`select_variant`) if none is set yet.
    """
    if mi.variant() is None:
        select_variant()

    if not parts:
        raise ValueError("load_mesh_target: give at least one part {name: (path, Material)}")
    built = []
    for pname, spec in parts.items():
        try:
            path, mat = spec
        except (TypeError, ValueError):
            raise ValueError(f"part {pname!r}: expected (path, Material), got {spec!r}") from None
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"part {pname!r}: mesh file not found: {path}")
        kind = path.suffix.lower().lstrip(".")
        if kind not in ("obj", "ply"):
            raise ValueError(f"part {pname!r}: mesh file must be .obj or .ply, got {path.name}")
        try:
            shape = mi.load_dict({"type": kind, "filename": str(path), "face_normals": True})
        except Exception as e:  # Mitsuba raises RuntimeError for malformed files
            raise ValueError(f"part {pname!r}: cannot read {path.name}: {str(e).splitlines()[0]}") from None
        p = mi.traverse(shape)
        V = np.array(p["vertex_positions"], dtype=float).reshape(-1, 3) * float(scale)
        F = np.array(p["faces"], dtype=np.int64).reshape(-1, 3)
        # Loaders split vertices at normal/uv seams: weld by position so the surface is closed.
        Vw, inv = np.unique(np.round(V, 9), axis=0, return_inverse=True)
        built.append(Part(pname, Vw, inv.reshape(-1)[F], mat))
    return make_target(name, built, density_kg_m3, dict(files={k: str(v[0]) for k, v in parts.items()}, scale=scale))
