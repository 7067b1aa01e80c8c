"""Scene edits (lift_gl/scene/edit.py), the .toml writer, and Renderer.update_scene.

The writer is checked by round trips (load -> save -> load is the same scene, bit for bit);
edits by geometry computed independently in numpy and by physics (emission is linear: twice
the radiance is exactly twice the image for the same paths); the GPU update by a fresh
Renderer built on the edited scene, which must render the same image with the same seed.
"""
from __future__ import annotations

import copy

import numpy as np
import pytest

from conftest import REPO, skip_without_shared
from lift_gl import load_scene
from lift_gl.errors import LiftError
from lift_gl.renderer import Renderer
from lift_gl.scene import edit
from lift_gl.scene.diff import scene_differences
from lift_gl.scene.edit import ObjectRef
from lift_gl.scene.toml_writer import save_toml

SCENES = sorted((REPO / "scenes").glob("*.toml"))
CORNELL = REPO / "scenes" / "cornell.toml"
LIGHT = ObjectRef("mesh", 5)  # cornell.toml's ceiling light (the sixth [[objects]] mesh)


def _area(mesh) -> float:
    p = mesh.positions.astype(np.float64)[mesh.indices]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()


# ---- the writer -------------------------------------------------------------------------------
@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_every_shipped_scene_reads_back_the_same_after_saving(path, tmp_path):
    skip_without_shared(path)
    scene = load_scene(path)
    out = save_toml(scene, tmp_path / "copy.toml")
    again = load_scene(out)
    assert scene_differences(scene, again) == []
    # Saving what was read back writes the same text (nothing drifts).
    assert save_toml(again, tmp_path / "copy2.toml").read_text().splitlines()[1:] == out.read_text().splitlines()[1:]


def test_scenes_without_tables_are_written_with_mesh_files(shared_dir, tmp_path):
    """pbrt meshes go to OBJ files beside the scene: positions and triangles read back
    exactly; trimesh renormalises shading normals on reading (within 1e-5)."""
    scene = load_scene(shared_dir / "scenes_lift" / "cornell-box" / "scene.pbrt")
    out = save_toml(scene, tmp_path / "sub" / "cornell.toml")
    assert sorted(p.suffix for p in (tmp_path / "sub" / "cornell.meshes").iterdir()) == [".obj"] * len(scene.meshes)
    assert scene_differences(scene, load_scene(out), normals_atol=1e-5) == []


def test_a_mesh_file_is_found_from_the_new_place(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "a" / "s.toml").write_text('[[objects]]\ntype = "mesh"\nfile = "tri.obj"\nscale = 2\n')
    scene = load_scene(tmp_path / "a" / "s.toml")
    out = save_toml(scene, tmp_path / "b" / "c" / "saved.toml")
    assert 'file = "../../a/tri.obj"' in out.read_text()
    assert scene_differences(scene, load_scene(out)) == []


# ---- edits ------------------------------------------------------------------------------------
def test_light_edits_move_resize_and_recolour_and_save(tmp_path):
    scene = load_scene(CORNELL)
    assert edit.emitters(scene) == [LIGHT] and edit.object_name(scene, LIGHT) == "light"
    light = scene.meshes[LIGHT.index]
    area, center = _area(light), edit.object_center(scene, LIGHT)
    np.testing.assert_allclose(edit.facing(scene, LIGHT), [0, -1, 0], atol=1e-7)  # a ceiling light faces down

    assert edit.scale_object(scene, LIGHT, 1.5) == edit.GEOMETRY
    assert edit.move_object(scene, LIGHT, [0.1, 0.0, 0.2]) == edit.GEOMETRY
    moved = scene.meshes[LIGHT.index]
    np.testing.assert_allclose(_area(moved), 1.5 ** 2 * area, rtol=1e-6)
    np.testing.assert_allclose(edit.object_center(scene, LIGHT), center + [0.1, 0.0, 0.2], atol=1e-6)
    assert edit.set_light(scene, LIGHT, 8.0, [1.0, 0.5, 0.25]) == edit.LIGHTS
    radiance, colour = edit.light_of(scene, LIGHT)
    assert radiance == 8.0 and colour.tolist() == [1.0, 0.5, 0.25]
    gold = scene.material_index("gold")
    assert edit.set_material_roughness(scene, gold, 0.5) == edit.MATERIALS
    assert scene.materials[gold].alpha == 0.25
    edit.set_material_colour(scene, scene.material_index("red"), [0.9, 0.1, 0.1])

    again = load_scene(save_toml(scene, tmp_path / "edited.toml"))
    assert scene_differences(scene, again) == []
    assert scene_differences(scene, load_scene(CORNELL)) != []  # the edits were real


def test_editing_one_of_several_lamps_leaves_the_others_alone():
    scene = load_scene(REPO / "scenes" / "dof.toml")
    lamps = [ref for ref in edit.emitters(scene) if scene.materials[edit.object_of(scene, ref).material].name == "lamp"]
    assert len(lamps) >= 2
    before = [edit.light_of(scene, ref) for ref in lamps]
    edit.set_light(scene, lamps[0], 1.0, [0, 0, 1])
    assert edit.light_of(scene, lamps[0])[1].tolist() == [0, 0, 1]
    for ref, (radiance, colour) in zip(lamps[1:], before[1:]):
        assert edit.light_of(scene, ref)[0] == radiance and np.array_equal(edit.light_of(scene, ref)[1], colour)


def test_bad_edits_are_clear_errors():
    scene = load_scene(CORNELL)
    with pytest.raises(LiftError, match="diffuse"):
        edit.set_material_roughness(scene, scene.material_index("white"), 0.3)
    with pytest.raises(LiftError, match="roughness"):
        edit.set_material_roughness(scene, scene.material_index("gold"), 1.5)
    with pytest.raises(LiftError, match="positive"):
        edit.scale_object(scene, LIGHT, 0.0)
    with pytest.raises(LiftError, match="radiance"):
        edit.set_light(scene, LIGHT, float("nan"), [1, 1, 1])


# ---- on the GPU -------------------------------------------------------------------------------
SIZE, SPP, SEED = (32, 32), 4, 6


def _fresh(scene):
    r = Renderer(copy.deepcopy(scene), size=SIZE, seed=SEED)
    image = r.render(spp=SPP)
    r.release()
    return image


def test_update_scene_renders_what_a_fresh_renderer_renders():
    scene = load_scene(CORNELL)
    r = Renderer(copy.deepcopy(scene), size=SIZE, seed=SEED)
    r.render(spp=2)

    edit.set_material_colour(scene, scene.material_index("red"), [0.2, 0.2, 0.9])
    r.update_scene(scene, geometry=False)
    assert r.uploaded == ["materials"] and r.stats.spp == 0
    np.testing.assert_array_equal(r.render(spp=SPP), _fresh(scene))

    program = r.trace.program
    edit.scale_object(scene, LIGHT, 0.7)
    edit.move_object(scene, LIGHT, [0.2, 0.0, 0.1])
    r.update_scene(scene, geometry=True)
    assert {"bvh_nodes", "tri_pos", "lights"} <= set(r.uploaded) and r.trace.program is program
    np.testing.assert_array_equal(r.render(spp=SPP), _fresh(scene))

    # A smooth mirror turned rough needs the rough-conductor code: recompiled.
    scene.materials[scene.material_index("gold")].alpha = 0.0
    r.update_scene(scene, geometry=False)
    assert not r.features.rough_conductor
    edit.set_material_roughness(scene, scene.material_index("gold"), 0.4)
    r.update_scene(scene, geometry=False)
    assert r.features.rough_conductor and r.trace.program is not program
    image = r.render(spp=SPP)
    np.testing.assert_array_equal(image, _fresh(scene))
    assert r.stats.dropped_samples == 0


def test_twice_the_radiance_is_twice_the_image():
    """Emission enters the estimate linearly and the paths do not depend on it (one light:
    its selection probability stays 1), so the same seed gives exactly twice the image."""
    scene = load_scene(CORNELL)
    r = Renderer(copy.deepcopy(scene), size=SIZE, seed=SEED)
    before = r.render(spp=SPP).astype(np.float64)
    radiance, colour = edit.light_of(scene, LIGHT)
    edit.set_light(scene, LIGHT, 2 * radiance, colour)
    r.update_scene(scene, geometry=False)
    after = r.render(spp=SPP).astype(np.float64)
    np.testing.assert_allclose(after, 2 * before, rtol=1e-5, atol=1e-7)


def test_a_live_geometry_edit_builds_the_bvh_once(monkeypatch):
    """The viewer waits for an edit's BVH: it is built with SAH_BINS bins, without the second
    build with finer bins at the top that a scene's load tries (bins auto)."""
    import dataclasses

    import lift_gl.renderer as renderer_mod
    import lift_gl.scene_update as scene_update_mod
    from lift_gl.accel.bvh import SAH_BINS

    asked = []
    real = renderer_mod.pack_scene

    def spy(scene, **kw):
        asked.append(kw.get("bvh_bins"))
        return real(scene, **kw)

    monkeypatch.setattr(renderer_mod, "pack_scene", spy)         # the scene's load
    monkeypatch.setattr(scene_update_mod, "pack_scene", spy)     # an edit's
    scene = load_scene(CORNELL)
    moved = dataclasses.replace(scene, meshes=[dataclasses.replace(m, positions=m.positions + [0.0, 0.01, 0.0])
                                               if k == 0 else m for k, m in enumerate(scene.meshes)])
    r = Renderer(scene, size=(16, 16), seed=1)
    try:
        assert asked == [None]   # the load: auto
        asked.clear()
        r.update_scene(moved)
        assert asked == [SAH_BINS]
    finally:
        r.release()
