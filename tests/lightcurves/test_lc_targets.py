"""Target geometry and mass properties against closed-form solids."""

import numpy as np
import pytest

from estimators.dynamics import k_from_inertia
from lightcurves.targets import TARGETS, Material, Part, _box, get_target, make_target, mass_properties

MAT = Material("m", 0.5)


def test_box_mass_properties_match_closed_form():
    a, b, c, rho = 2.0, 3.0, 5.0, 7.0
    V, F = _box([1.0, -1.0, 2.0], [1.0 + a, -1.0 + b, 2.0 + c])
    mp = mass_properties(V, F, rho)
    m = rho * a * b * c
    assert mp.volume_m3 == pytest.approx(a * b * c, rel=1e-12)
    np.testing.assert_allclose(mp.com_B, [1 + a / 2, -1 + b / 2, 2 + c / 2], rtol=1e-12)
    np.testing.assert_allclose(mp.inertia_T, m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]), rtol=1e-12)
    np.testing.assert_allclose(mp.C_BT, np.eye(3), atol=1e-12)


def test_rotated_box_recovers_principal_axes_closest_to_build_axes():
    rng = np.random.default_rng(3)
    from scipy.spatial.transform import Rotation

    C = Rotation.from_rotvec([0.2, -0.1, 0.15]).as_matrix()  # small rotation: axes stay identifiable
    V, F = _box([-1, -2, -3], [1, 2, 3])
    shift = rng.normal(size=3)
    t = make_target("rot", [Part("b", V @ C.T + shift, F, MAT)], 2.0)
    np.testing.assert_allclose(t.mass.com_B, shift, atol=1e-12)
    np.testing.assert_allclose(t.mass.C_BT, C, atol=1e-9)
    # in T the box is axis-aligned and centred
    vT = t.parts[0].vertices_T
    np.testing.assert_allclose(np.abs(vT).max(axis=0), [1, 2, 3], atol=1e-9)


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_parametric_targets_are_expressed_in_their_principal_frame(name):
    t = get_target(name)
    V = np.concatenate([p.vertices_T for p in t.parts])
    off = np.cumsum([0] + [len(p.vertices_T) for p in t.parts])
    F = np.concatenate([p.faces + o for p, o in zip(t.parts, off)])
    again = mass_properties(V, F, t.mass.density_kg_m3)
    scale = np.linalg.norm(V, axis=1).max()
    np.testing.assert_allclose(again.com_B, 0.0, atol=1e-9 * scale)
    np.testing.assert_allclose(again.C_BT, np.eye(3), atol=1e-7)
    np.testing.assert_allclose(again.inertia_T, t.J_diag, rtol=1e-9)
    assert t.k == pytest.approx(k_from_inertia(t.J_diag))
    # closed surface: every directed edge appears once and its reverse once
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    # weld coincident vertices (lathe seams duplicate them)
    _, inv = np.unique(np.round(V, 9), axis=0, return_inverse=True)
    e = inv.reshape(-1)[e]
    fwd = {tuple(x) for x in e.tolist()}
    assert all((b, a) in fwd for a, b in fwd)


def test_atlas_centaur_dimensions_and_inertia_shape():
    t = get_target("atlas-centaur")
    V = np.concatenate([p.vertices_T for p in t.parts])
    ext = V.max(axis=0) - V.min(axis=0)
    assert ext[1] == pytest.approx(12.0, rel=1e-9)  # long axis along T's y
    assert ext[0] == pytest.approx(3.05, rel=1e-3) and ext[2] == pytest.approx(3.05, rel=1e-3)
    A, B, C = t.J_diag
    assert A == pytest.approx(C, rel=1e-9) and B < A / 5  # slender: small moment about the long axis
    # the two ends differ in material
    assert t.part("forward_bulkhead").material != t.part("aft_cone").material


def test_sphere_volume_and_isotropic_inertia():
    r = 1.7
    t = get_target("sphere", radius_m=r, albedo=0.3)
    assert t.mass.volume_m3 == pytest.approx(4 / 3 * np.pi * r**3, rel=3e-3)  # inscribed icosphere
    I = t.mass.mass_kg * 2 / 5 * r**2
    np.testing.assert_allclose(t.J_diag, I, rtol=5e-3)
    assert t.parts[0].material.specular_albedo == 0.0 and t.parts[0].material.diffuse_albedo == 0.3


def test_box_wing_is_asymmetric():
    t = get_target("box-wing")
    assert np.linalg.norm(t.mass.com_B) > 0.05
    assert not np.allclose(t.mass.C_BT, np.eye(3), atol=1e-6)


def test_unknown_target_and_bad_parameters_raise_value_error():
    with pytest.raises(ValueError, match="known targets: atlas-centaur, box-wing, sphere, vespa"):
        get_target("saturn-v")
    with pytest.raises(ValueError, match="albedo"):
        get_target("sphere", albedo=1.5)
    with pytest.raises(ValueError, match="bad parameters"):
        get_target("vespa", colour="red")
    with pytest.raises(ValueError, match="closed"):
        make_target("open", [Part("tri", np.eye(3), np.array([[0, 2, 1]]), MAT)])
