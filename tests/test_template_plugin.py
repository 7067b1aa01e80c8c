"""The `template` plugin (what `lift-gl new-plugin` copies): its bounce window (`only_bounce`,
`min_bounce`..`max_depth`, as pt has them) and its image textures.

Checked against analytic answers (a glowing closed box: bounce k is Le a^k; a textured
quad under a sky of radiance 1: one bounce returns exactly the texture's albedo, since
cosine sampling of a diffuse BSDF has weight albedo) and against the template itself: the
window does not change how paths are sampled, so one seed's single bounces add up to the
full image to float rounding.
"""
from __future__ import annotations

import numpy as np

from conftest import REPO
from lift_gl import load_scene
from lift_gl.passes.camera import frame_jitter
from lift_gl.renderer import Renderer
from lift_gl.scene import Environment
from test_bounces import glowing_box
from test_textures_distant import FRAMES, SIZE, camera_rays, texture_at, textured_quad_scene

CORNELL = REPO / "scenes" / "cornell.toml"


def _render(scene, spp, seed=0, size=(32, 32), **params):
    r = Renderer(scene, size=size, integrator="template", seed=seed, params=params)
    image = r.render(spp=spp)
    assert r.stats.dropped_samples == 0
    r.release()
    return image.astype(np.float64)


def test_bounce_k_inside_a_glowing_box_is_emission_times_albedo_to_the_k():
    """With BSDF sampling only, every path of bounce k meets emission Le after k diffuse
    bounces of weight a each: each sample is exactly Le a^k (no variance at all)."""
    emission, albedo = 1.0, 0.6
    scene = glowing_box(emission, albedo)
    for k in range(5):
        image = _render(scene, spp=2, seed=k, only_bounce=k)
        np.testing.assert_allclose(image, emission * albedo ** k, rtol=1e-5, err_msg=f"bounce {k}")
    window = _render(scene, spp=2, seed=9, min_bounce=2, max_depth=4)
    np.testing.assert_allclose(window, emission * (albedo ** 2 + albedo ** 3 + albedo ** 4), rtol=1e-5)


def test_single_bounce_images_of_one_seed_add_up_to_the_full_image():
    scene = load_scene(CORNELL)
    depth, spp, seed = 4, 4, 7
    full = _render(scene, spp, seed, max_depth=depth)
    bounces = [_render(scene, spp, seed, max_depth=depth, only_bounce=k) for k in range(depth + 1)]
    np.testing.assert_allclose(np.sum(bounces, axis=0), full, rtol=1e-5, atol=1e-7)
    later = _render(scene, spp, seed, max_depth=depth, min_bounce=2)
    np.testing.assert_allclose(np.sum(bounces[2:], axis=0), later, rtol=1e-5, atol=1e-7)
    assert all(b.min() >= 0 for b in bounces) and bounces[1].max() > 0
    assert not _render(scene, 1, seed, max_depth=3, only_bounce=4).any()  # beyond max_depth: black


def test_textured_quad_under_a_white_sky_returns_its_albedo():
    """Bounce 1 of a diffuse quad under a sky of radiance 1: each sample is exactly the
    albedo at its jittered hit point (the texture applied), so N frames average to the mean
    of the texture over the N jitter positions, computed here in numpy."""
    scene = textured_quad_scene(srgb=True)
    scene.distant_lights = []
    scene.environment = Environment(radiance=np.ones(3))
    image = _render(scene, FRAMES, seed=5, size=SIZE, only_bounce=1)
    cam, tex = scene.camera, scene.textures[0]
    expected = np.zeros_like(image)
    for f in range(FRAMES):
        d = camera_rays(cam, SIZE, frame_jitter(f, 5))
        p = cam.position + (-cam.position[2] / d[..., 2])[..., None] * d
        uv = np.stack([(p[..., 0] + 2) / 4 * 2, (p[..., 1] + 1.5) / 3 * 2], axis=-1)
        expected += np.array([0.9, 1.0, 0.8]) * texture_at(tex.pixels, uv, tex.srgb)
    np.testing.assert_allclose(image, expected / FRAMES, rtol=2e-4, atol=1e-6)
