"""Scene loading: the shipped scenes, the pbrt Cornell box, and clear errors on bad input."""
from pathlib import Path

import numpy as np
import pytest

from lift_gl.errors import SceneError
from lift_gl.scene.loader import SceneWarning, load_scene
from lift_gl.scene.primitives import box, geometric_normals, quad

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
PBRT_CORNELL = Path(__file__).resolve().parent.parent.parent / "shared" / "scenes_lift" / "cornell-box" / "scene.pbrt"


def _project_x(scene, point):
    right, _, _ = scene.camera.basis()
    return float(np.dot(np.asarray(point) - scene.camera.position, right))


def test_cornell_toml():
    s = load_scene(ROOT / "scenes" / "cornell.toml")
    assert s.path == ROOT / "scenes" / "cornell.toml"
    assert len(s.meshes) == 7 and len(s.spheres) == 1
    assert s.triangle_count == 6 * 2 + 12
    types = {m.name: m.type for m in s.materials}
    assert types["glass"] == "dielectric" and types["gold"] == "conductor"
    assert s.materials[s.material_index("gold")].alpha == pytest.approx(0.09)
    light = next(m for m in s.meshes if m.name == "light")
    np.testing.assert_allclose(s.materials[light.material].emission, [4.25, 3, 1])
    # The light faces down, the walls face into the box.
    assert geometric_normals(light.positions, light.indices)[0][1] < 0
    assert s.camera.fov_deg == 19.5
    left = next(m for m in s.meshes if m.name == "left wall")
    assert _project_x(s, left.positions.mean(axis=0)) < 0


def test_furnace_toml():
    s = load_scene(ROOT / "scenes" / "furnace.toml")
    assert len(s.meshes) == 0 and len(s.spheres) == 1
    np.testing.assert_allclose(s.environment.radiance, [1, 1, 1])
    np.testing.assert_allclose(s.materials[s.spheres[0].material].base_color, [0.8] * 3)
    # The sphere must not fill the view: some background is visible.
    distance = np.linalg.norm(s.camera.position - s.spheres[0].center)
    assert np.tan(np.radians(s.camera.fov_deg / 2)) * distance > s.spheres[0].radius


@pytest.mark.skipif(not PBRT_CORNELL.exists(), reason="shared pbrt scenes not present")
def test_pbrt_cornell_box():
    s = load_scene(PBRT_CORNELL)
    assert len(s.meshes) == 8
    assert s.film_size == (1024, 1024) and s.max_depth == 65
    assert s.camera.fov_deg == pytest.approx(19.5)
    np.testing.assert_allclose(s.camera.position, [0, 1, 6.8], atol=1e-6)
    emitters = [m for m in s.meshes if s.materials[m.material].is_emissive]
    assert len(emitters) == 1
    np.testing.assert_allclose(s.materials[emitters[0].material].emission, [17, 12, 4])
    # The light's front (geometric normal) faces down into the room.
    assert (geometric_normals(emitters[0].positions, emitters[0].indices)[:, 1] < 0).all()
    # Only the light's copy of "Light" emits; the red wall is on the image's left.
    red = [m for m in s.meshes
           if np.allclose(s.materials[m.material].base_color, [0.63, 0.065, 0.05])]
    assert len(red) == 1
    assert _project_x(s, red[0].positions.mean(axis=0)) < 0


def test_pbrt_fov_is_for_the_shorter_axis_and_unknown_directive_warns():
    with pytest.warns(SceneWarning, match=r"unknown_directive\.pbrt:8: .*FancyFog"):
        s = load_scene(DATA / "unknown_directive.pbrt")
    # 200x400 film, fov 30 on the (horizontal) shorter axis -> vertical fov.
    expected = np.degrees(2 * np.arctan(np.tan(np.radians(15)) * 2))
    assert s.camera.fov_deg == pytest.approx(expected)
    assert len(s.meshes) == 1 and len(s.spheres) == 1
    np.testing.assert_allclose(s.spheres[0].radius, 0.25)
    gold = s.materials[s.spheres[0].material]
    assert gold.type == "conductor" and 0.8 < gold.alpha < 0.9  # pbrt-v3 remapped 0.3
    # pbrt's LookAt puts camera +x = cross(up, dir) on the image's right: here world -x, so
    # the wall at x = -1 appears on the RIGHT in pbrt, and must here too.
    assert _project_x(s, s.meshes[0].positions.mean(axis=0)) > 0


@pytest.mark.parametrize("name, line, text", [
    ("malformed.toml", 4, "TOML syntax error"),
    ("missing_mesh.toml", 11, "no_such_mesh.ply"),
    ("bad_material_type.toml", 6, "unknown material type 'plastik'"),
    ("unknown_material.toml", 11, "unknown material 'gray'"),
    ("bad_value.toml", 6, "'color'"),
])
def test_bad_toml_names_file_and_line(name, line, text):
    with pytest.raises(SceneError) as info:
        load_scene(DATA / name)
    err = info.value
    assert Path(err.path).name == name and err.line == line
    assert text in err.message
    assert str(err).startswith(f"{err.path}:{line}: ")


def test_unknown_key_warns_with_line(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[materials.a]\ncolour = 0.5\n\n[[objects]]\ntype = "sphere"\nmaterial = "a"\n')
    with pytest.warns(SceneWarning, match=r"s\.toml:2: unknown key 'colour'"):
        load_scene(f)


def test_missing_scene_and_empty_mitsuba(tmp_path):
    with pytest.raises(SceneError, match="nope.toml"):
        load_scene(tmp_path / "nope.toml")
    xml = tmp_path / "scene.xml"
    xml.write_text("<scene/>")
    # An empty Mitsuba scene loads (nothing to render), saying that it has no camera.
    with pytest.warns(SceneWarning, match=r"scene\.xml:1: the scene has no <sensor>"):
        s = load_scene(xml)
    assert not s.meshes and not s.spheres


def test_mesh_file_is_cleaned_and_framed():
    with pytest.warns(SceneWarning) as record:
        s = load_scene(DATA / "dirty.ply")
    messages = " ".join(str(w.message) for w in record)
    assert "NaN/Inf" in messages and "degenerate" in messages
    assert s.triangle_count == 1 and np.isfinite(s.meshes[0].positions).all()
    assert s.meshes[0].normals is None  # the file has none
    np.testing.assert_allclose(s.environment.radiance, [1, 1, 1])
    np.testing.assert_allclose(s.camera.target, [0.5, 0.5, 0])


def test_primitive_orientation():
    q = quad([0, 0, 0], [1, 0, 0], [0, 0, -1])
    n = geometric_normals(q.positions, q.indices)
    assert (n[:, 1] > 0).all()  # cross(u, v) = +y
    b = box([1, 2, 3], [2, 2, 2])
    outward = np.einsum("ij,ij->i", geometric_normals(b.positions, b.indices),
                        b.positions[b.indices].mean(axis=1) - [1, 2, 3])
    assert (outward > 0).all()
