"""What makes pt faster on a CPU rasterizer (docs/cpu-speed.md) must not change its samples.

- Scene arrays in uniform blocks read the same data as storage buffers: the same seed renders
  the same image, bit for bit, whichever way each array travels (the reference is the
  storage-buffer path, the option uniform_blocks=off).
- The host's vertex-at-a-time loop over several samples per frame gives the image of the plain
  loop over samples.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import trimesh

from conftest import REPO
from lift_gl import load_scene
from lift_gl.options import Options
from lift_gl.passes.common import UNIFORM_ARRAYS
from lift_gl.renderer import Renderer
from lift_gl.scene.model import Mesh

CORNELL = REPO / "scenes" / "cornell.toml"  # glass, metal, diffuse, an area light


def _render(scene, uniform_blocks, spp=4, size=(32, 32), light_selection="auto", **kw):
    r = Renderer(scene, size=size, options=Options(uniform_blocks="on" if uniform_blocks else "off",
                                                   light_selection=light_selection), **kw)
    try:
        return r.render(spp=spp), set(r.buffers.in_uniform_block), dict(r.defines)
    finally:
        r.release()


def test_uniform_blocks_render_the_same_image_as_storage_buffers():
    scene = load_scene(CORNELL)
    ssbo, none_in_blocks, _ = _render(scene, False)
    ubo, in_blocks, defines = _render(scene, True)
    assert none_in_blocks == set()
    assert {"bvh_nodes", "tri_pos", "tri_info", "materials", "lights"} <= in_blocks
    assert all(UNIFORM_ARRAYS[name][0] in defines for name in in_blocks)
    assert np.isfinite(ubo).all() and ubo.mean() > 0
    np.testing.assert_array_equal(ubo, ssbo)


def test_arrays_too_big_for_a_uniform_block_stay_storage_buffers():
    """5,120 more triangles: three vec4 corners each pass 64 KiB (llvmpipe's uniform block
    limit), so the triangle arrays stay SSBOs while the materials and lights still go in
    blocks; the mix renders what the storage buffers alone render."""
    scene = load_scene(CORNELL)
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.25)
    mesh = Mesh(name="ball", positions=np.asarray(ball.vertices) + [0.0, 0.6, 0.0],
                indices=np.asarray(ball.faces, np.int32), material=0,
                normals=np.asarray(ball.vertex_normals, np.float32))
    scene = dataclasses.replace(scene, meshes=[*scene.meshes, mesh])
    ssbo, _, _ = _render(scene, False, spp=2)
    mixed, in_blocks, defines = _render(scene, True, spp=2)
    if in_blocks == set():  # a GL whose uniform blocks are larger than the scene
        return
    assert "tri_pos" not in in_blocks and "LIFT_UBO_TRI_POS" not in defines
    assert {"materials", "lights"} <= in_blocks
    np.testing.assert_array_equal(mixed, ssbo)


def test_an_edit_that_changes_array_lengths_recompiles_with_the_new_lengths():
    """Uniform blocks' lengths are compiled into the shaders, rounded up to a power of two (at
    least 64): an edit within them (a second light) keeps the shaders, one past them (every
    mesh twice) rebuilds the passes; either way the renderer then renders what a fresh
    renderer renders. Lights picked by power throughout: a second light would switch the
    light tree on (auto), a recompile of its own (test_an_edit_that_adds_a_light_switches_to_the_tree)."""
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=(24, 24), options=Options(uniform_blocks="on", light_selection="power"))
    before = dict(r.defines)
    light = next(m for m in scene.meshes if scene.materials[m.material].is_emissive)
    twin = dataclasses.replace(light, name="twin", positions=light.positions + [0.3, -0.01, 0.0])
    doubled = [dataclasses.replace(m, name=f"{m.name}_twin", positions=m.positions * 0.5) for m in scene.meshes]
    for edited, recompiles in ((dataclasses.replace(scene, meshes=[*scene.meshes, twin]), False),
                               (dataclasses.replace(scene, meshes=[*scene.meshes, *doubled]), True)):
        r.update_scene(edited)
        assert (r.defines != before) == recompiles
        edited_image = r.render(spp=2)
        fresh, _, _ = _render(edited, True, spp=2, size=(24, 24), light_selection="power")
        np.testing.assert_array_equal(edited_image, fresh)
    r.release()


def test_an_edit_that_adds_a_light_switches_to_the_tree():
    """light_selection auto after an edit chooses for the edited scene, as a fresh renderer
    does: a second light, off the first's plane, packs the light tree and compiles its code
    (the pack used to be chosen for the scene before the edit: a tree chosen, none packed)."""
    scene = load_scene(CORNELL)
    r = Renderer(scene, size=(24, 24))
    assert r.choices["light_selection"] == "power" and "LIFT_LIGHT_TREE" not in r.defines
    light = next(m for m in scene.meshes if scene.materials[m.material].is_emissive)
    twin = dataclasses.replace(light, name="twin", positions=light.positions + [0.3, -0.01, 0.0])
    edited = dataclasses.replace(scene, meshes=[*scene.meshes, twin])
    r.update_scene(edited)
    assert r.choices["light_selection"] == "tree" and r.packed.light_tree and "LIFT_LIGHT_TREE" in r.defines
    fresh, _, defines = _render(edited, False, spp=2, size=(24, 24))
    assert "LIFT_LIGHT_TREE" in defines
    np.testing.assert_array_equal(r.render(spp=2), fresh)
    r.release()


def test_vertex_at_a_time_loop_gives_the_samples_of_the_per_sample_loop(tmp_path):
    """pt defines LIFT_PATH_STEPS, so with several samples per frame the host runs all their
    vertices in one loop (lift_gl/passes/trace.py); a copy of pt without that define gets
    the plain loop over samples. Same random numbers, same paths: the same image, bit for bit."""
    source = REPO / "plugins" / "pt"
    plain = tmp_path / "pt_plain"
    plain.mkdir()
    (plain / "plugin.toml").write_text((source / "plugin.toml").read_text().replace('name = "pt"', 'name = "pt_plain"'))
    text = (source / "pt.glsl").read_text()
    assert "#define LIFT_PATH_STEPS\n" in text
    (plain / "pt.glsl").write_text(text.replace("#define LIFT_PATH_STEPS\n", ""))
    scene = load_scene(CORNELL)
    steps, _, _ = _render(scene, None, spp=12, samples_per_frame=6)
    loop, _, _ = _render(scene, None, spp=12, samples_per_frame=6, integrator=str(plain))
    assert np.isfinite(steps).all() and steps.mean() > 0
    np.testing.assert_array_equal(steps, loop)
