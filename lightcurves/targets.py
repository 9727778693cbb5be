"""Target models: named triangle-mesh parts with materials, and their mass properties.

Stable API (shared with ``perception``; DESIGN.md)
---------------------------------------------------
* :class:`Material` — Cook-Torrance surface parameters (turned into a Mitsuba
  BSDF by :func:`lightcurves.scene.bsdf_dict`).
* :class:`Part` — ``name``, ``vertices_T`` (n, 3) metres in the target frame T,
  ``faces`` (m, 3) int vertex indices (counter-clockwise seen from outside, so
  the right-hand normal points out of the solid), optional ``normals_T`` (n, 3)
  unit vertex normals for smooth shading, and ``material``.
* :class:`MassProperties` — mass, volume, density, centre of mass and principal
  axes of the *build* frame B the mesh was modelled in, principal moments
  ``inertia_T`` = ``[A, B, C]`` (kg m²) and ``k1 = ln(A/B)``, ``k2 = ln(B/C)``.
* :class:`Target` — ``name``, ``parts``, ``mass``, ``params``; ``J_diag``,
  ``k``, ``radius_m`` (bounding-sphere radius about the centre of mass).
* :func:`get_target` ``(name, **params)`` — the registry (``TARGETS``); raises
  ``ValueError`` naming the known targets.
* User OBJ/PLY meshes become a :class:`Target` through
  :func:`lightcurves.scene.load_mesh_target` (it needs Mitsuba's loaders; this
  module does not import Mitsuba, and ``scene`` imports this one, never the
  other way round).

The target frame T
------------------
Every mesh is expressed in T: origin at the centre of mass, axes along the
principal axes of inertia of the solid (uniform density). The principal axes
are labelled and signed to be the ones closest to the build frame's x, y, z,
so a model built along y keeps its long axis as T's y axis; when the build
frame is already principal (all symmetric models here) T is B shifted to the
centre of mass. ``J_diag`` is therefore ordered as T's axes, not sorted: the
rocket body, built along y, gives ``J ≈ diag(A, B, A)`` with ``B`` the small
moment, as the ``diag(4.33, 1, 4)`` of Renis et al. §6.

Mass properties come from the closed surface formed by the union of all parts
(the parts partition the surface) by signed-tetrahedron volume integrals
(divergence theorem): each face with the origin spans a tetrahedron of signed
volume ``det[a b c]/6`` and second moment ``det/120 (Σ v vᵀ + s sᵀ)``,
``s = a + b + c`` (Tonon 2004, *J. Math. Stat.* 1(1); Eberly, *Polyhedral Mass
Properties*).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from estimators.dynamics import k_from_inertia

__all__ = [
    "Material",
    "Part",
    "MassProperties",
    "Target",
    "mass_properties",
    "make_target",
    "atlas_centaur",
    "vespa",
    "box_wing",
    "sphere",
    "TARGETS",
    "get_target",
]


# ---------------------------------------------------------------- data


@dataclass(frozen=True)
class Material:
    """Cook-Torrance surface: Lambertian diffuse plus a Beckmann microfacet lobe.

    ``f = diffuse_albedo/π + specular_albedo · F(θ_h) D(h) G(i, o) / (4 cos θ_i cos θ_o)``
    (Cook & Torrance 1982), ``F`` the conductor Fresnel reflectance of the
    complex index ``eta + i k`` (``k = 0``: a dielectric such as paint or glass),
    ``D`` the Beckmann distribution with RMS slope ``roughness``, ``G`` Smith's
    separable shadowing-masking. ``diffuse_albedo + specular_albedo <= 1``.
    """

    name: str
    diffuse_albedo: float
    specular_albedo: float = 0.0
    roughness: float = 0.3
    eta: float = 1.5
    k: float = 0.0

    def __post_init__(self):
        d, s = self.diffuse_albedo, self.specular_albedo
        if not (0.0 <= d <= 1.0 and 0.0 <= s <= 1.0 and d + s <= 1.0 + 1e-12):
            raise ValueError(f"material {self.name!r}: need 0 <= diffuse_albedo, specular_albedo and their sum <= 1, got {d}, {s}")
        if not (0.0 < self.roughness <= 2.0):
            raise ValueError(f"material {self.name!r}: roughness (Beckmann RMS slope) must be in (0, 2], got {self.roughness}")
        if not (self.eta > 0.0 and self.k >= 0.0):
            raise ValueError(f"material {self.name!r}: need eta > 0 and k >= 0, got eta={self.eta}, k={self.k}")


@dataclass(frozen=True)
class Part:
    """A named triangle mesh with one material, in the target frame T (metres)."""

    name: str
    vertices_T: np.ndarray  #: (n, 3) m
    faces: np.ndarray  #: (m, 3) int, outward right-hand winding
    material: Material
    normals_T: np.ndarray | None = None  #: (n, 3) unit vertex normals for smooth shading, or None (flat)


@dataclass(frozen=True)
class MassProperties:
    """Uniform-density mass properties of a closed surface."""

    volume_m3: float
    density_kg_m3: float
    mass_kg: float
    com_B: np.ndarray  #: (3,) centre of mass in the build frame, m
    C_BT: np.ndarray  #: (3, 3) principal axes (columns) in the build frame: v_B = C_BT v_T
    inertia_T: np.ndarray  #: (3,) principal moments [A, B, C] about the centre of mass, kg m²
    k1: float  #: ln(A/B)
    k2: float  #: ln(B/C)


@dataclass(frozen=True)
class Target:
    """A target: parts expressed in its principal-axis frame T, plus mass properties."""

    name: str
    parts: tuple[Part, ...]
    mass: MassProperties
    params: dict = field(default_factory=dict)

    @property
    def J_diag(self) -> np.ndarray:
        """Principal moments ``[A, B, C]`` (kg m²) along T's x, y, z."""
        return self.mass.inertia_T

    @property
    def k(self) -> tuple[float, float]:
        """``(k1, k2)`` of eq. 19 of Renis et al."""
        return self.mass.k1, self.mass.k2

    @property
    def radius_m(self) -> float:
        """Radius of the smallest origin-centred sphere containing every vertex, m."""
        return float(max(np.linalg.norm(p.vertices_T, axis=1).max() for p in self.parts))

    def part(self, name: str) -> Part:
        for p in self.parts:
            if p.name == name:
                return p
        raise ValueError(f"target {self.name!r} has no part {name!r}; parts: {[p.name for p in self.parts]}")


# ---------------------------------------------------------------- mass properties


def mass_properties(vertices, faces, density_kg_m3: float = 1.0) -> MassProperties:
    """Mass properties of the solid bounded by a closed, outward-wound triangle mesh.

    Parameters
    ----------
    vertices : (n, 3) array, m, in the build frame B.
    faces : (m, 3) int array; the surface must be closed and wound so that the
        right-hand normals point outwards (positive volume).
    density_kg_m3 : uniform density.
    """
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))  # 6 × signed tetrahedron volume
    vol = det.sum() / 6.0
    if not (np.isfinite(vol) and vol > 0):
        raise ValueError(f"mesh encloses no positive volume ({vol:.3g} m^3): it must be closed with outward-facing faces")
    s = a + b + c
    first = (det[:, None] * s).sum(axis=0) / 24.0  # ∫ x dV
    com = first / vol
    # ∫ x xᵀ dV = Σ det/120 (a aᵀ + b bᵀ + c cᵀ + s sᵀ)
    outer = (np.einsum("i,ij,ik->jk", det, a, a) + np.einsum("i,ij,ik->jk", det, b, b)
             + np.einsum("i,ij,ik->jk", det, c, c) + np.einsum("i,ij,ik->jk", det, s, s))
    cov = outer / 120.0 - vol * np.outer(com, com)  # about the centre of mass
    I_B = density_kg_m3 * (np.trace(cov) * np.eye(3) - cov)
    C_BT, moments = _principal_axes(I_B)
    k1, k2 = k_from_inertia(moments)
    return MassProperties(
        volume_m3=float(vol),
        density_kg_m3=float(density_kg_m3),
        mass_kg=float(density_kg_m3 * vol),
        com_B=com,
        C_BT=C_BT,
        inertia_T=moments,
        k1=k1,
        k2=k2,
    )


def _principal_axes(I_B: np.ndarray, rtol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Principal axes of ``I_B`` labelled and signed closest to B's axes, as a rotation ``C_BT``."""
    scale = np.trace(I_B)
    off = I_B - np.diag(np.diag(I_B))
    if np.abs(off).max() <= rtol * scale:
        # Already principal (symmetric builds): keep B's axes even where moments are equal.
        return np.eye(3), np.diag(I_B).copy()
    w, E = np.linalg.eigh(I_B)
    # For each B axis pick the eigenvector most aligned with it (greedy on |cos|).
    order = [-1, -1, -1]
    used: set[int] = set()
    for i, j in sorted(((i, j) for i in range(3) for j in range(3)), key=lambda ij: -abs(E[ij[0], ij[1]])):
        if order[i] < 0 and j not in used:
            order[i] = j
            used.add(j)
    C = E[:, order]
    C = C * np.sign(np.diag(C))[None, :]
    if np.linalg.det(C) < 0:
        C[:, 2] = -C[:, 2]
    return C, w[order]


def make_target(name: str, parts_B: list[Part], density_kg_m3: float = 1.0, params: dict | None = None) -> Target:
    """Build a :class:`Target` from parts modelled in a build frame B.

    The union of the parts must be a closed surface; the parts are moved into
    T (centre of mass at the origin, principal axes; see the module docstring).
    """
    if not parts_B:
        raise ValueError("a target needs at least one part")
    names = [p.name for p in parts_B]
    if len(set(names)) != len(names):
        raise ValueError(f"part names must be unique, got {names}")
    offsets = np.cumsum([0] + [len(p.vertices_T) for p in parts_B])
    V = np.concatenate([p.vertices_T for p in parts_B])
    F = np.concatenate([p.faces + o for p, o in zip(parts_B, offsets[:-1])])
    mp = mass_properties(V, F, density_kg_m3)
    parts_T = []
    for p in parts_B:
        v_T = (p.vertices_T - mp.com_B) @ mp.C_BT  # v_T = C_BTᵀ (v_B - com)
        n_T = None if p.normals_T is None else p.normals_T @ mp.C_BT
        parts_T.append(Part(p.name, v_T, np.asarray(p.faces, dtype=np.int64), p.material, n_T))
    return Target(name=name, parts=tuple(parts_T), mass=mp, params=dict(params or {}))


# ---------------------------------------------------------------- geometry builders


def _lathe(profile_rz, n_seg: int, axis: int = 2) -> list[tuple[np.ndarray, np.ndarray]]:
    """Surface of revolution of a polyline profile ``[(r, z), ...]`` about an axis.

    Returns one ``(vertices, faces)`` band per profile segment, so consecutive
    segments can carry different materials. Rings at ``r = 0`` collapse to a
    point (their degenerate triangles are dropped). The winding makes the
    normal point to the right of the profile direction in the (r, z) plane, so
    a profile that runs counter-clockwise around the solid's cross-section
    (e.g. up the outside, down the inside) is wound outwards.
    """
    prof = np.asarray(profile_rz, dtype=float)
    phi = np.linspace(0.0, 2.0 * np.pi, n_seg, endpoint=False)
    cos, sin = np.cos(phi), np.sin(phi)
    other = [i for i in range(3) if i != axis]
    bands = []
    for (r0, z0), (r1, z1) in zip(prof[:-1], prof[1:]):
        ring = []
        for r, z in ((r0, z0), (r1, z1)):
            v = np.zeros((n_seg, 3))
            v[:, other[0]] = r * cos
            v[:, other[1]] = r * sin
            v[:, axis] = z
            ring.append(v)
        verts = np.concatenate(ring)
        i = np.arange(n_seg)
        j = (i + 1) % n_seg
        tris = np.concatenate([np.stack([i, j, n_seg + j], 1), np.stack([i, n_seg + j, n_seg + i], 1)])
        area = np.linalg.norm(np.cross(verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]]), axis=1)
        bands.append((verts, tris[area > 1e-12]))
    return bands


def _box(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned closed box, outward winding."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    # vertex index = 4 ix + 2 iy + iz
    f = np.array(
        [
            [0, 1, 3], [0, 3, 2],  # x = lo
            [4, 6, 7], [4, 7, 5],  # x = hi
            [0, 4, 5], [0, 5, 1],  # y = lo
            [2, 3, 7], [2, 7, 6],  # y = hi
            [0, 2, 6], [0, 6, 4],  # z = lo
            [1, 5, 7], [1, 7, 3],  # z = hi
        ]
    )
    return v, f


def _icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere (outward winding) with ``20·4^subdivisions`` faces."""
    t = (1.0 + 5**0.5) / 2.0
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
         [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]  # fmt: skip
    V = [np.array(p, float) / np.linalg.norm(p) for p in v]
    F = np.array(f)
    for _ in range(subdivisions):
        cache: dict[tuple[int, int], int] = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                cache[key] = len(V) - 1
            return cache[key]

        out = []
        for a, b, c in F:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        F = np.array(out)
    return np.array(V), F


# ---------------------------------------------------------------- parametric targets

#: White-painted aluminium skin (rocket-body cylinder).
WHITE_PAINT = Material("white_paint", diffuse_albedo=0.55, specular_albedo=0.25, roughness=0.25, eta=1.5)
#: Bare, brushed aluminium (bright, specular).
ALUMINIUM = Material("aluminium", diffuse_albedo=0.15, specular_albedo=0.75, roughness=0.15, eta=1.1, k=6.8)
#: Dark, sooty engine/nozzle end.
DARK_NOZZLE = Material("dark_nozzle", diffuse_albedo=0.06, specular_albedo=0.04, roughness=0.4, eta=1.5)
#: Carbon-fibre composite (payload adapter shell).
CFRP = Material("cfrp", diffuse_albedo=0.08, specular_albedo=0.12, roughness=0.2, eta=1.6)
#: Gold multi-layer insulation (satellite bus).
MLI_GOLD = Material("mli_gold", diffuse_albedo=0.25, specular_albedo=0.6, roughness=0.3, eta=0.47, k=2.8)
#: Solar-cell panel front: dark cells under cover glass.
SOLAR_CELL = Material("solar_cell", diffuse_albedo=0.05, specular_albedo=0.3, roughness=0.05, eta=1.5)
#: Solar-panel back: white thermal paint.
PANEL_BACK = Material("panel_back", diffuse_albedo=0.7, specular_albedo=0.05, roughness=0.4, eta=1.5)


def atlas_centaur(length_m: float = 12.0, diameter_m: float = 3.05, nozzle_length_m: float = 2.0, n_seg: int = 64, density_kg_m3: float = 25.0) -> Target:
    """Atlas-Centaur-like rocket body, long axis along T's y.

    A cylinder of ``diameter_m`` ending in a bright aluminium forward bulkhead
    (+y) and a dark conical aft end (nozzle side, -y) that narrows to 40 % of
    the radius: the two ends reflect differently, so a tumble about a transverse
    axis shows two unequal maxima per turn (Renis et al. §5.1, Fig. 2).
    ``density_kg_m3`` is a smeared density (≈2 t dry mass).
    """
    if not (length_m > nozzle_length_m > 0 and diameter_m > 0):
        raise ValueError(f"atlas-centaur: need length_m > nozzle_length_m > 0 and diameter_m > 0, got {length_m}, {nozzle_length_m}, {diameter_m}")
    R = diameter_m / 2.0
    top, bottom = length_m / 2.0, -length_m / 2.0
    # Profile runs from the forward pole, down the outside, to the aft pole (outward winding).
    prof = [(0.0, top), (R, top), (R, bottom + nozzle_length_m), (0.4 * R, bottom), (0.0, bottom)]
    (v0, f0), (v1, f1), (v2, f2), (v3, f3) = _lathe(prof, n_seg, axis=1)
    aft_v = np.concatenate([v2, v3])
    aft_f = np.concatenate([f2, f3 + len(v2)])
    parts = [
        Part("forward_bulkhead", v0, f0, ALUMINIUM),
        Part("body", v1, f1, WHITE_PAINT),
        Part("aft_cone", aft_v, aft_f, DARK_NOZZLE),
    ]
    return make_target("atlas-centaur", parts, density_kg_m3, dict(length_m=length_m, diameter_m=diameter_m, nozzle_length_m=nozzle_length_m))


def vespa(height_m: float = 1.9, bottom_diameter_m: float = 2.6, top_diameter_m: float = 1.6, wall_m: float = 0.04, n_seg: int = 64,
          density_kg_m3: float = 1600.0) -> Target:
    """VESPA-like payload adapter: hollow CFRP truncated cone plus an aluminium ring, axis along T's z.

    The ring (separation interface) sits around the wide lower rim, so the two
    ends differ and the shape is not symmetric fore-aft.
    """
    if not (height_m > 0 and bottom_diameter_m > top_diameter_m > 0 and 0 < wall_m < top_diameter_m / 4):
        raise ValueError(f"vespa: need height_m > 0, bottom_diameter_m > top_diameter_m > 0, 0 < wall_m < top_diameter_m/4, "
                         f"got {height_m}, {bottom_diameter_m}, {top_diameter_m}, {wall_m}")
    Rb, Rt, h, w = bottom_diameter_m / 2, top_diameter_m / 2, height_m / 2, wall_m
    # Closed wall cross-section, counter-clockwise in (r, z): up the outside, in over the top, down the inside.
    shell = [(Rb, -h), (Rt, h), (Rt - w, h), (Rb - w, -h), (Rb, -h)]
    bands = _lathe(shell, n_seg, axis=2)
    shell_v, shell_f, n = [], [], 0
    for v, f in bands:
        shell_v.append(v)
        shell_f.append(f + n)
        n += len(v)
    ring_h = 0.12
    ring = [(Rb, -h), (Rb + 0.08, -h), (Rb + 0.08, -h + ring_h), (Rb, -h + ring_h), (Rb, -h)]
    ring_bands = _lathe(ring, n_seg, axis=2)
    ring_v, ring_f, n = [], [], 0
    for v, f in ring_bands:
        ring_v.append(v)
        ring_f.append(f + n)
        n += len(v)
    parts = [
        Part("shell", np.concatenate(shell_v), np.concatenate(shell_f), CFRP),
        Part("ring", np.concatenate(ring_v), np.concatenate(ring_f), ALUMINIUM),
    ]
    return make_target("vespa", parts, density_kg_m3,
                       dict(height_m=height_m, bottom_diameter_m=bottom_diameter_m, top_diameter_m=top_diameter_m, wall_m=wall_m))


def box_wing(bus_m=(1.6, 1.6, 2.2), panel_lengths_m=(5.0, 3.5), panel_width_m: float = 1.8, panel_thickness_m: float = 0.04,
             density_kg_m3: float = 300.0) -> Target:
    """Box-wing satellite: an MLI bus and two solar wings of unequal length along ±y.

    The unequal wings, and a wing hinge offset toward +z, make the body
    asymmetric (centre of mass off the bus centre, no symmetry plane normal to y).
    Wings are thin closed boxes: cells on the +x face (``*_cells``), white
    back and edges (``*_back``), so a half turn does not look the same.
    """
    bx, by, bz = (float(v) for v in bus_m)
    L1, L2 = (float(v) for v in panel_lengths_m)
    if min(bx, by, bz, L1, L2, panel_width_m, panel_thickness_m) <= 0:
        raise ValueError("box-wing: every dimension must be positive")
    bus = _box([-bx / 2, -by / 2, -bz / 2], [bx / 2, by / 2, bz / 2])
    zc, t, w = 0.25 * bz, panel_thickness_m, panel_width_m
    gap = 0.3  # yoke between bus wall and wing
    parts = [Part("bus", *bus, MLI_GOLD)]
    for name, (lo_y, hi_y) in (("wing_plus_y", (by / 2 + gap, by / 2 + gap + L1)), ("wing_minus_y", (-by / 2 - gap - L2, -by / 2 - gap))):
        v, f = _box([-t / 2, lo_y, zc - w / 2], [t / 2, hi_y, zc + w / 2])
        front = np.zeros(len(f), bool)
        front[2:4] = True  # the two triangles of the x = +t/2 face (see _box)
        parts += [Part(f"{name}_cells", v, f[front], SOLAR_CELL), Part(f"{name}_back", v, f[~front], PANEL_BACK)]
    return make_target("box-wing", parts, density_kg_m3, dict(bus_m=(bx, by, bz), panel_lengths_m=(L1, L2), panel_width_m=panel_width_m))


def sphere(radius_m: float = 1.0, albedo: float = 0.5, subdivisions: int = 5, density_kg_m3: float = 1000.0) -> Target:
    """Lambertian sphere (validation target): icosphere with smooth vertex normals."""
    if not (radius_m > 0):
        raise ValueError(f"sphere: radius_m must be > 0, got {radius_m}")
    if not (0.0 < albedo <= 1.0):
        raise ValueError(f"sphere: albedo must be in (0, 1], got {albedo}")
    if not (0 <= int(subdivisions) <= 7):
        raise ValueError(f"sphere: subdivisions must be in 0..7, got {subdivisions}")
    u, f = _icosphere(int(subdivisions))
    mat = Material("lambertian", diffuse_albedo=float(albedo), specular_albedo=0.0)
    part = Part("sphere", radius_m * u, f, mat, normals_T=u)
    return make_target("sphere", [part], density_kg_m3, dict(radius_m=radius_m, albedo=albedo))


#: Registry of parametric targets: name -> builder(**params).
TARGETS = {
    "atlas-centaur": atlas_centaur,
    "vespa": vespa,
    "box-wing": box_wing,
    "sphere": sphere,
}


def get_target(name: str, **params) -> Target:
    """Build the named parametric target (see ``TARGETS``) with keyword parameters."""
    if name not in TARGETS:
        raise ValueError(f"unknown target {name!r}; known targets: {', '.join(sorted(TARGETS))}")
    try:
        return TARGETS[name](**params)
    except TypeError as e:
        raise ValueError(f"target {name!r}: bad parameters {sorted(params)}: {e}") from None
