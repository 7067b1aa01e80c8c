"""The trace host's splat buffer (plugins with `splats = true`): sums are exact, the float
atomic and the compare-and-swap paths agree, bad values are dropped and counted, and
camera_project (shaders/lift/camera_importance.glsl) sends a point back to the pixel whose
camera ray found it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import PluginError
from lift_gl.passes import splat as splat_module
from lift_gl.plugins import load_manifest
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

CORNELL = REPO / "scenes" / "cornell.toml"
SIZE = (24, 16)  # not square, to catch a swapped width and height
SPP = 3

MANIFEST = """name = "{name}"
entry = "main.glsl"
primary = "gbuffer"
splats = true
"""

# Every sample splats (1, 2, 3) into the bottom-left pixel and returns nothing itself.
TO_ONE_PIXEL = "vec3 radiance(Ray ray, Hit hit, inout Rng rng) { splat(vec2(0.5), vec3(1.0, 2.0, 3.0)); return vec3(0.0); }\n"
# Every sample splats NaN and infinity (from a zero the compiler cannot fold): all dropped.
BAD_VALUES = """vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    float zero = float(u_frame > 0xffffffffu - 1u && u_frame < 1u);
    splat(u_resolution * 0.5, vec3(zero / zero, 1.0 / zero, 1.0));
    return vec3(0.0);
}
"""
# Each sample splats 1 where its own first hit projects: back into its own pixel.
TO_OWN_HIT = """#include "lift/camera_importance.glsl"
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec2 pixel_pos;
    if (hit.prim != NO_HIT && camera_project(ray.origin + hit.t * ray.dir, pixel_pos)) splat(pixel_pos, vec3(1.0));
    return vec3(0.0);
}
"""


def make_plugin(tmp_path: Path, name: str, shader: str) -> Path:
    folder = tmp_path / name
    folder.mkdir()
    (folder / "plugin.toml").write_text(MANIFEST.format(name=name))
    (folder / "main.glsl").write_text(shader)
    return folder


def render(folder, scene=None, size=SIZE, spp=SPP):
    r = Renderer(scene or load_scene(CORNELL), size=size, integrator=str(folder), seed=1)
    image = r.render(spp=spp)
    stats = r.stats
    r.release()
    return image, stats


@pytest.mark.parametrize("atomics", ["float", "cas"])
def test_splats_sum_exactly_into_their_pixel(tmp_path, monkeypatch, atomics):
    if atomics == "cas":  # pretend the driver lacks float atomics
        monkeypatch.setattr(splat_module, "FLOAT_ATOMICS", "GL_none_such")
    image, stats = render(make_plugin(tmp_path, "to_one", TO_ONE_PIXEL))
    w, h = SIZE
    # w * h * SPP splats of (1, 2, 3), divided by the pixel's SPP samples; integers: exact in float.
    expected = np.zeros((h, w, 3), np.float32)
    expected[h - 1, 0] = np.array([1, 2, 3]) * w * h
    assert np.array_equal(image, expected)
    assert stats.dropped_samples == 0 and stats.dropped_splats == 0


def test_bad_splats_are_dropped_and_counted(tmp_path):
    image, stats = render(make_plugin(tmp_path, "bad", BAD_VALUES))
    assert np.array_equal(image, np.zeros_like(image))
    assert stats.dropped_splats == SIZE[0] * SIZE[1] * SPP
    assert stats.dropped_samples == 0


def test_camera_project_inverts_camera_ray(tmp_path):
    # Camera inside the box, looking at the back wall: every pixel sees a surface.
    scene = load_scene(CORNELL)
    scene.camera.position = np.array([0.0, 1.0, 0.9])
    image, stats = render(make_plugin(tmp_path, "own", TO_OWN_HIT), scene=scene, spp=4)
    # Every sample's splat lands somewhere in the image (none lost or doubled)...
    assert image[..., 0].sum() == pytest.approx(SIZE[0] * SIZE[1], abs=1e-3)
    # ... and in its own pixel, unless its subpixel offset lies within float rounding of an edge.
    assert np.count_nonzero(image[..., 0] != 1.0) <= 2, np.argwhere(image[..., 0] != 1.0)


def test_splats_key_must_be_a_boolean(tmp_path):
    folder = make_plugin(tmp_path, "typo", TO_ONE_PIXEL)
    (folder / "plugin.toml").write_text(MANIFEST.format(name="typo").replace("splats = true", 'splats = "yes"'))
    with pytest.raises(PluginError) as err:
        load_manifest(folder)
    assert err.value.line == 4 and "splats" in str(err.value)


def test_plugins_without_the_key_get_no_splat_buffer():
    r = Renderer(load_scene(CORNELL), size=(8, 8), integrator="pt")
    assert r.trace.splats is None and "LIFT_SPLATS" not in r.trace.source.text.split("#line")[0]
    r.release()
