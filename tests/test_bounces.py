"""pt's bounce window (`only_bounce`, `min_bounce`..`max_depth`): each bounce on its own.

Checked against an analytic answer (inside a closed box whose walls all emit Le and reflect
with albedo a, bounce k is exactly Le a^k everywhere) and against pt itself: the window
does not change how paths are sampled, so with one seed the single-bounce images add up to
the full image to float rounding.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl import load_scene
from lift_gl.cli import main
from lift_gl.renderer import Renderer
from lift_gl.scene import Camera, Material, Scene
from lift_gl.scene.primitives import box

CORNELL = REPO / "scenes" / "cornell.toml"
SIZE = (32, 32)


def _render(scene, spp, seed=0, **params):
    r = Renderer(scene, size=SIZE, seed=seed, params=params)
    image = r.render(spp=spp)
    assert r.stats.dropped_samples == 0
    r.release()
    return image.astype(np.float64)


def glowing_box(emission: float, albedo: float) -> Scene:
    """A closed box seen from inside: every wall emits `emission` and reflects `albedo`."""
    walls = box(center=(0, 0, 0), size=(2, 1.5, 3), material=0)
    walls.indices = np.ascontiguousarray(walls.indices[:, ::-1])  # fronts (and emission) face in
    walls.normals = None
    camera = Camera(position=[0.3, 0.1, 1.0], target=[-0.2, -0.1, -1.5], fov_deg=60.0)
    return Scene(camera=camera, materials=[Material("wall", base_color=[albedo] * 3, emission=[emission] * 3)],
                 meshes=[walls], max_depth=16)


def test_bounce_k_inside_a_glowing_box_is_emission_times_albedo_to_the_k():
    """L = Le / (1 - a) splits into bounces Le a^k. Every pixel has that expectation and the
    pixels are independent, so their spread gives the standard error of the image mean."""
    emission, albedo = 1.0, 0.6
    scene = glowing_box(emission, albedo)
    for k in range(5):
        image = _render(scene, spp=4, seed=k, only_bounce=k).mean(axis=-1)
        expected = emission * albedo ** k
        if k == 0:  # the walls seen directly: no randomness at all
            np.testing.assert_array_equal(image, np.float32(emission))
            continue
        standard_error = image.std(ddof=1) / np.sqrt(image.size)
        z = (image.mean() - expected) / standard_error
        assert abs(z) < 4.5, f"bounce {k}: mean {image.mean():.5f}, expected {expected:.5f} (z = {z:.1f})"
    # The window min_bounce..max_depth holds bounces 2, 3, 4: a^2 + a^3 + a^4.
    window = _render(scene, spp=4, seed=9, min_bounce=2, max_depth=4).mean(axis=-1)
    expected = emission * (albedo ** 2 + albedo ** 3 + albedo ** 4)
    z = (window.mean() - expected) / (window.std(ddof=1) / np.sqrt(window.size))
    assert abs(z) < 4.5, f"bounces 2..4: mean {window.mean():.5f}, expected {expected:.5f} (z = {z:.1f})"


def test_single_bounce_images_of_one_seed_add_up_to_the_full_image():
    """Cornell box (glass, rough gold, diffuse walls) with max_depth 5: bounce 0 + ... + 5 is
    the full image, and min_bounce 2 (bounces 2..5) is the sum of bounces 2..5. The same
    seed draws the same paths, so only float rounding of the sums differs (measured: 1e-7
    relative); 1e-5 allows for another driver's operation order."""
    scene = load_scene(CORNELL)
    depth, spp, seed = 5, 4, 11
    full = _render(scene, spp, seed, max_depth=depth)
    bounces = [_render(scene, spp, seed, max_depth=depth, only_bounce=k) for k in range(depth + 1)]
    np.testing.assert_allclose(np.sum(bounces, axis=0), full, rtol=1e-5, atol=1e-7)
    later = _render(scene, spp, seed, max_depth=depth, min_bounce=2)
    np.testing.assert_allclose(np.sum(bounces[2:], axis=0), later, rtol=1e-5, atol=1e-7)
    # Bounce 0 is what max_depth 0 shows (the same code path: bit-identical).
    np.testing.assert_array_equal(bounces[0], _render(scene, spp, seed, max_depth=0))
    # Every bounce adds light somewhere; none is negative.
    assert all(b.min() >= 0 and b.max() > 0 for b in bounces)
    # A bounce beyond max_depth is not rendered: black.
    assert not _render(scene, 1, seed, max_depth=3, only_bounce=4).any()


def test_only_bounce_from_the_command_line(tmp_path):
    out = tmp_path / "bounce2.npy"
    assert main(["render", str(CORNELL), "--spp", "2", "--size", "24x16", "--seed", "4",
                 "--set", "pt.only_bounce=2", "--out", str(out)]) == 0
    r = Renderer(load_scene(CORNELL), size=(24, 16), seed=4, params={"only_bounce": 2})
    np.testing.assert_array_equal(np.load(out), r.render(spp=2))


@pytest.mark.parametrize("setting", ["pt.only_bounce=-2", "pt.only_bounce=two", "pt.min_bounce=-1"])
def test_bad_bounce_settings_are_one_clear_error(tmp_path, capsys, setting):
    assert main(["render", str(CORNELL), "--spp", "1", "--size", "8x8", "--set", setting,
                 "--out", str(tmp_path / "x.npy")]) == 2
    err = capsys.readouterr().err
    assert setting.split("=")[0].split(".")[1] in err and "Traceback" not in err
