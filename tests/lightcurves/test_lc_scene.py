"""Mitsuba scene pieces: the Cook-Torrance BSDF against its closed form, posing, user meshes."""

import numpy as np
import pytest

from lightcurves import scene as S
from lightcurves.scene import load_mesh_target
from lightcurves.targets import Material, Part, _box, get_target, make_target


def _ortho(M, res=8, spp=1):
    import mitsuba as mi

    return {
        "type": "orthographic",
        "to_world": mi.ScalarTransform4f(M),
        "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": spp},
    }


def _dir(theta, phi):
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


# (θ_i, θ_o, φ_o): near-specular (mirror φ = π), off-specular, normal, grazing-ish where G < 1
GEOMETRIES = [(0.3, 0.3, np.pi), (0.5, 0.2, np.pi), (0.2, 0.7, 0.5), (0.0, 0.0, 0.0), (1.0, 0.4, 2.0), (1.2, 1.1, np.pi), (1.3, 0.2, 0.0)]


@pytest.mark.parametrize("material",
                         [Material("diffuse", 0.6), Material("paint", 0.3, 0.6, roughness=0.2, eta=1.5),
                          Material("metal", 0.1, 0.85, roughness=0.5, eta=1.1, k=6.8)], ids=lambda m: m.name)
def test_flat_cook_torrance_plate_matches_closed_form(variant, material):
    """Radiance of a sunlit plate = E cos θ_i f(ω_i, ω_o): within 2 % for diffuse and specular geometries."""
    import mitsuba as mi

    plate = make_target("plate", [Part("top", *_box([-5, -5, -0.01], [5, 5, 0.0]), material)])
    top = np.array([0.0, 0.0, plate.parts[0].vertices_T[:, 2].max()])
    film = np.diag([0.5, 0.5, 1.0, 1.0])  # 1 m × 1 m film entirely on the plate's top face
    sc = mi.load_dict(S.scene_dict(plate, _dir(0.3, 0.0), sensors={"cam": _ortho(S.look_at_matrix(top + [0, 0, 10], top, [0, 1, 0]) @ film)}))
    poser = S.ScenePoser(sc, plate)
    for ti, to, ph in GEOMETRIES:
        wi, wo = _dir(ti, 0.0), _dir(to, ph)
        poser.set_sun(wi)
        poser.set_sensor("cam", S.look_at_matrix(top + 10 * wo, top, [0, 0, 1] if to > 0 else [0, 1, 0]) @ film)
        L = float(np.array(mi.render(sc, seed=0))[..., 0].mean())
        expected = S.SUN_IRRADIANCE_W_M2 * np.cos(ti) * S.cook_torrance_brdf(material, [0, 0, 1], wi, wo)
        assert L == pytest.approx(expected, rel=0.02), (ti, to, ph)


def test_closed_form_brdf_is_reciprocal_and_energy_bounded():
    m = Material("paint", 0.3, 0.6, roughness=0.3, eta=1.5)
    rng = np.random.default_rng(0)
    wi = rng.normal(size=(200, 3))
    wo = rng.normal(size=(200, 3))
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    n = np.array([0, 0, 1.0])
    np.testing.assert_allclose(S.cook_torrance_brdf(m, n, wi, wo), S.cook_torrance_brdf(m, n, wo, wi), rtol=1e-12)
    # directional albedo ∫ f cos θ_o dω_o <= 1 at normal incidence (Monte Carlo, cosine-weighted)
    u = rng.random((200000, 2))
    r, phi = np.sqrt(u[:, 0]), 2 * np.pi * u[:, 1]
    w = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u[:, 0])], 1)
    albedo = np.pi * S.cook_torrance_brdf(m, n, n, w).mean()
    assert 0.3 < albedo <= 1.0


def test_posing_rewrites_vertices_without_reloading(variant):
    """Turning the rocket body end-on changes the rendered flux; turning it back restores it exactly."""
    import mitsuba as mi

    t = get_target("atlas-centaur", n_seg=24)
    sc = mi.load_dict(S.scene_dict(t, [0, 0, 1],
                                   sensors={"cam": _ortho(S.look_at_matrix([0, 0, 20], [0, 0, 0], [0, 1, 0]) @ np.diag([7, 7, 1, 1]), res=16, spp=2)}))
    poser = S.ScenePoser(sc, t)
    broadside = float(np.array(mi.render(sc, seed=1)).mean())
    poser.set_target_pose(np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]]), [0, 0, 0])  # long axis y -> z
    end_on = float(np.array(mi.render(sc, seed=1)).mean())
    poser.set_target_pose(np.eye(3), [0, 0, 0])
    again = float(np.array(mi.render(sc, seed=1)).mean())
    assert abs(end_on / broadside - 1) > 0.2
    assert again == pytest.approx(broadside, rel=1e-6)


def test_user_obj_mesh_loads_with_part_materials(tmp_path, variant):
    V, F = _box([0, 0, 0], [2, 1, 1])
    obj = tmp_path / "box.obj"
    obj.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in V) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F))
    t = load_mesh_target({"hull": (obj, Material("grey", 0.4))}, name="crate", density_kg_m3=3.0)
    assert t.mass.mass_kg == pytest.approx(6.0, rel=1e-6)
    np.testing.assert_allclose(t.J_diag, 6.0 / 12 * np.array([2, 5, 5]), rtol=1e-6)
    ply = tmp_path / "fin.ply"
    V2, F2 = _box([2, 0, 0], [2.5, 1, 1])  # a second closed solid beside the first
    header = (f"ply\nformat ascii 1.0\nelement vertex {len(V2)}\nproperty float x\nproperty float y\nproperty float z\n"
              f"element face {len(F2)}\nproperty list uchar int vertex_indices\nend_header\n")
    ply.write_text(header + "".join(f"{x} {y} {z}\n" for x, y, z in V2) + "".join(f"3 {a} {b} {c}\n" for a, b, c in F2))
    two = load_mesh_target({"hull": (obj, Material("grey", 0.4)), "fin": (ply, Material("white", 0.8))}, density_kg_m3=1.0)
    assert [p.name for p in two.parts] == ["hull", "fin"] and two.part("fin").material.diffuse_albedo == 0.8
    assert two.mass.mass_kg == pytest.approx(2.5, rel=1e-6)
    np.testing.assert_allclose(two.mass.com_B, [(2.0 * 1.0 + 0.5 * 2.25) / 2.5, 0.5, 0.5], rtol=1e-6)
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(ValueError):
        load_mesh_target({"x": (bad, Material("grey", 0.4))})
    with pytest.raises(FileNotFoundError):
        load_mesh_target({"x": (tmp_path / "none.ply", Material("grey", 0.4))})


def test_variant_request_is_validated():
    with pytest.raises(ValueError, match="variant must be one of"):
        S.select_variant("cuda_ad_rgb")
