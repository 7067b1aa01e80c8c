"""Image textures in every light-transport plugin. pt shades a surface with its material's
texture applied (material_at, shaders/lift/textures.glsl); drt, hybrid and bdpt must shade the
same surfaces the same way, or a textured wall renders in its base colour.

The scene (tests/data/cornell_textured.toml) is a diffuse Cornell box whose floor and back
wall carry a coarse near-white / near-black checker: ignoring the texture, or looking it up at
the wrong point, moves 8 x 8 pixel blocks by hundreds of standard errors. Each estimator renders
the image RUNS times with independent seeds and the block means are compared by Welch's t
(tests/image_stats.py, as tests/test_bdpt.py compares pt and bdpt):
  bdpt    an unbiased estimator of pt's image: light subpaths scatter off the textured walls
          too (its joins and light tracing evaluate the BSDF at stored vertices);
  drt     on a diffuse scene, emitted plus direct light (a diffuse hit ends the ray tree):
          pt with max_depth = 1 estimates the same (tests/test_drt.py);
  hybrid  direct light at full resolution is pt's to rounding with the same seed (max_depth
          1); indirect light is traced at reduced resolution, divided by the G-buffer's
          (textured) albedo where it was traced and multiplied by each pixel's own after the
          filter. The filter blurs that demodulated light, which is smooth here: at
          indirect_scale 1 its bias is far below the noise of these runs; at 4 it is checked
          where a texture makes the most difference, inside the checker's dark squares.
"""
from __future__ import annotations

import numpy as np
import pytest

from scipy.ndimage import maximum_filter, minimum_filter

from conftest import REPO
from image_stats import assert_same_image
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene
from sample_stats import welch_t
from test_bdpt import renders

SCENE = REPO / "tests" / "data" / "cornell_textured.toml"
SIZE = (64, 64)
RUNS = 16


@pytest.fixture(scope="module")
def scene():
    scene = load_scene(SCENE)
    assert [m.name for m in scene.materials if m.texture is not None] == ["checker"]
    return scene


@pytest.fixture(scope="module")
def pt_image(scene):
    return renders(scene, "pt", 16, range(1, RUNS + 1), size=SIZE)


@pytest.fixture(scope="module")
def pt_direct(scene):
    return renders(scene, "pt", 16, range(1, RUNS + 1), size=SIZE, max_depth=1)


def test_bdpt_matches_pt_on_a_textured_scene(scene, pt_image):
    bdpt = renders(scene, "bdpt", 4, range(101, RUNS + 101), size=SIZE)
    assert_same_image(pt_image, bdpt, block=8, label="textured walls: pt vs bdpt")


def test_drt_matches_pts_direct_light_on_a_textured_scene(scene, pt_direct):
    drt = renders(scene, "drt", 16, range(201, RUNS + 201), size=SIZE)
    assert_same_image(pt_direct, drt, block=8, label="textured walls: pt (max_depth 1) vs drt")


def test_hybrids_direct_light_is_pts_on_a_textured_scene(scene):
    """The full-resolution half draws pt's random numbers: the same image to rounding."""
    hybrid = renders(scene, "hybrid", 4, [5], size=SIZE, max_depth=1)
    pt = renders(scene, "pt", 4, [5], size=SIZE, max_depth=1)
    np.testing.assert_allclose(hybrid, pt, rtol=1e-6, atol=1e-7)


def test_hybrid_matches_pt_on_a_textured_scene(scene, pt_image):
    """Indirect light traced for every pixel (indirect_scale 1), still filtered over 3 x 3
    neighbours: demodulated by each neighbour's textured albedo, remodulated by the pixel's."""
    hybrid = renders(scene, "hybrid", 8, range(301, RUNS + 301), size=SIZE, indirect_scale=1)
    assert_same_image(pt_image, hybrid, block=8, label="textured walls: pt vs hybrid (indirect_scale 1)")


def dark_square_interiors(scene) -> np.ndarray:
    """(H, W) mask of the pixels inside the checker's dark squares: the G-buffer's albedo
    (pixel centres) at the dark squares' value there and in the 8 neighbouring pixels."""
    r = Renderer(scene, size=SIZE)
    albedo = r.aov("albedo").astype(np.float64)[..., 1]
    r.release()
    flat = maximum_filter(albedo, 3) - minimum_filter(albedo, 3) < 1e-3
    return flat & (albedo > 1e-3) & (albedo < 0.02)  # the dark squares: 0.85 x 0.010


def test_hybrid_keeps_the_texture_in_quarter_resolution_indirect_light(scene, pt_image, pt_direct):
    """At indirect_scale 4 a pixel's indirect light is filtered from estimates traced up to 8
    pixels away, on other squares. Demodulated by the textured albedo where each was traced and
    remodulated by the pixel's own, a dark square keeps its own share; demodulated without the
    texture, it takes its bright neighbours' (11x pt's here on main's code: t ~ 40).
    Indirect light: the image minus pt's direct light of the same seed (hybrid's full-resolution
    half draws the same numbers). The filter's own bias here is +5% of the dark squares'
    indirect light (measured over 48 runs), 0.8 standard errors of 16 runs: the bound is
    6 standard errors, far below the bleeding it is there to catch."""
    inside = dark_square_interiors(scene)
    assert inside.sum() > 50
    hybrid = renders(scene, "hybrid", 16, range(1, RUNS + 1), size=SIZE, indirect_scale=4)
    hybrid_indirect = (hybrid - pt_direct)[:, inside].mean(axis=(1, 2))
    pt_indirect = (pt_image - pt_direct)[:, inside].mean(axis=(1, 2))
    t = welch_t(hybrid_indirect, pt_indirect)
    assert abs(t) < 6.0, (f"indirect light inside the dark squares: hybrid {hybrid_indirect.mean():.3g}, "
                          f"pt {pt_indirect.mean():.3g} ({t:.1f} standard errors)")
