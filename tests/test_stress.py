"""The stress suite (issue 7): every scene of scenes/stress/ rendered by the path tracer and
checked against an independent answer — an analytic image (tests/stress_reference.py), the
same scene at unit scale, the smooth BSDF, the clean mesh, or a light tracer — with
tolerances from the estimator's own variance. No test here expects a dropped sample.

The statistic (zero_mean_z): two independent estimates d1, d2 of something whose expectation
is zero (a render minus its expected image, or one scene's render minus another's with the
same seed) give a per-pixel variance (d1 - d2)^2 / 4 of their mean, an estimate with one
degree of freedom. Pixels are independent (each has its own random numbers), so a block's or
the image's sum has the summed variance, and its z follows Student's t with the Welch-
Satterthwaite degrees of freedom of that sum: many noisy pixels give ~normal z, a block whose
noise sits in one pixel gives ~1 degree of freedom and a much wider critical value. The
expected images are computed for exactly the subpixel positions the renders used
(render_offsets), so the jitter the pixels share adds no correlated error. Every pixel gets
a float32 allowance of 1e-6 of its value (a known, not estimated, variance).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from conftest import REPO
from lift_gl.renderer import Renderer
from lift_gl.scene.features import SceneFeatures
from lift_gl.scene.loader import SceneWarning, load_scene
from stress_reference import (caustic_light_tracer, floor_under_quad_light, furnace_box,
                              ground_and_sky, render_offsets, tilted_normals, tir_cube)

STRESS = REPO / "scenes" / "stress"
SEEDS = (1, 2)
FLOAT_ALLOWANCE = 1e-6
# Two-sided false-alarm probabilities: per image (and channel), and per 8x8 block (with ~200
# blocks and channels a test, ~2e-4 for the whole test). With many degrees of freedom the
# critical |z| is 3.9 and 4.9; a light leak or a bias of a few standard errors fails it.
P_IMAGE = 1e-4
P_BLOCK = 1e-6
IMAGE_Z = 4.0  # for a single mean with many independent pixels (the glowing box, the caustic)


def load(name: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        return load_scene(STRESS / f"{name}.toml")


def render(scene, seed, spp, size=None, **kwargs) -> np.ndarray:
    r = Renderer(scene, size=size, seed=seed, **kwargs)
    image = r.render(spp=spp).astype(np.float64)
    dropped = r.stats.dropped_samples
    r.release()
    assert dropped == 0, f"{dropped} NaN/Inf samples dropped"
    assert np.isfinite(image).all()
    return image


def critical_z(p, dof):
    """|t| exceeded with probability p (two-sided) at `dof` degrees of freedom."""
    from scipy.stats import t
    return t.ppf(1 - p / 2, np.maximum(dof, 1.0))


def zero_mean_z(d1, d2, scale, block=8):
    """z and Welch-Satterthwaite degrees of freedom of the image sum (per channel) and of each
    block x block sum of (d1 + d2) / 2."""
    mean = (d1 + d2) / 2
    estimated = (d1 - d2) ** 2 / 4  # one degree of freedom per pixel
    var = estimated + (FLOAT_ALLOWANCE * np.abs(scale)) ** 2 + 1e-300
    h, w, c = mean.shape
    bh, bw = h // block, w // block

    def blocks(x):
        return x[:bh * block, :bw * block].reshape(bh, block, bw, block, c).sum(axis=(1, 3))

    def z_and_dof(total, variance, estimated_sq):
        return total / np.sqrt(variance), variance ** 2 / np.maximum(estimated_sq, 1e-300)

    image = z_and_dof(mean.sum(axis=(0, 1)), var.sum(axis=(0, 1)), (estimated ** 2).sum(axis=(0, 1)))
    return image, z_and_dof(blocks(mean), blocks(var), blocks(estimated ** 2))


def assert_zero_mean(d1, d2, scale, what=""):
    (image_z, image_dof), (block_z, block_dof) = zero_mean_z(d1, d2, scale)
    assert np.all(np.abs(image_z) < critical_z(P_IMAGE, image_dof)), f"{what}: image z = {image_z} ({image_dof} dof)"
    excess = np.abs(block_z) / critical_z(P_BLOCK, block_dof)
    worst = np.unravel_index(np.argmax(excess), excess.shape)
    assert excess.max() < 1, (f"{what}: block {worst[:2]} z = {block_z[worst]:.2f} "
                              f"with {block_dof[worst]:.1f} degrees of freedom")


def assert_matches_analytic(name, expected_image, spp, **kwargs):
    """Two renders (seeds 1, 2) against the analytic image for their own subpixel positions."""
    scene = load(name)
    size = scene.film_size
    residuals, expected = [], []
    for seed in SEEDS:
        e = expected_image(scene, size, render_offsets(spp, seed))
        residuals.append(render(scene, seed, spp, **kwargs) - e)
        expected.append(e)
    assert_zero_mean(*residuals, scale=expected[0], what=name)
    return expected[0]


# ---------------------------------------------------------------- 1. lights: tiny, huge, grazing
@pytest.mark.parametrize("name", ["tiny_bright_light", "huge_dim_light", "grazing_light", "close_light"])
def test_direct_light_matches_lamberts_polygon_formula(name):
    expected = assert_matches_analytic(name, floor_under_quad_light, spp=16)
    assert expected.max() > 0


def test_grazing_camera_sees_the_floor_at_its_albedo_at_every_angle():
    expected = assert_matches_analytic("grazing_camera", ground_and_sky, spp=16)
    assert (expected == 0.5).any() and (expected == 1.0).any()


# ---------------------------------------------------------------- 2. shading normals
def test_tilted_and_backfacing_shading_normals_are_neither_black_nor_brighter():
    expected = assert_matches_analytic("tilted_normals", tilted_normals, spp=16)
    # Both cases occur: the tilted lobe (0.8 (1 + cos 80) / 2 = 0.47, 0.8 (1 + cos 60) / 2 =
    # 0.6) and the geometric normal where the viewer is below the shading hemisphere (0.8).
    for value in (0.8 * (1 + math.cos(math.radians(80))) / 2, 0.6, 0.8):
        assert np.isclose(expected, value).any(), value


# ---------------------------------------------------------------- 3. glass: IOR 1, TIR, alpha 1e-4
def test_index_matched_glass_is_invisible_smooth_or_rough():
    assert_matches_analytic("ior_one", ground_and_sky, spp=32)


def test_total_internal_reflection_traps_exactly_the_predicted_directions():
    expected = assert_matches_analytic("tir_cube", tir_cube, spp=4)
    assert (expected == 0).any() and np.isclose(expected, 2.25).any()


def test_near_specular_alpha_1e4_converges_to_the_smooth_bsdfs():
    rough = load("near_specular")
    assert {m.alpha for m in rough.materials if m.type != "diffuse"} == {1e-4}
    smooth = load("near_specular")
    for m in smooth.materials:
        m.alpha = 0.0
    assert SceneFeatures.of(rough).rough_conductor and not SceneFeatures.of(smooth).rough_conductor
    d = [render(rough, seed, 32) - render(smooth, seed, 32) for seed in SEEDS]
    assert_zero_mean(*d, scale=0.0, what="alpha 1e-4 minus smooth")


# ---------------------------------------------------------------- 4. depth, energy, roulette
# The closed box of glowing walls: every pixel has the same expectation, so the pixels of one
# render are independent draws and their spread gives the standard error of their mean.
@pytest.mark.parametrize("albedo, max_depth, params", [
    (1.0, 1000, {}),                                        # energy must not grow: exactly 1001
    (0.5, 1000, {}),                                        # Russian roulette from bounce 4
    (0.8, 5, {"rr_depth": 10000}),                          # no roulette: the truncated series
    (0.05, 1000, {"rr_depth": 0, "rr_min_survival": 0.01}),  # survival 0.05 at every bounce
    (0.7, 1000, {"rr_depth": 1, "rr_min_survival": 0.0}),    # Lift's roulette (docs/gpu.md)
])
def test_glowing_box_is_the_geometric_series(albedo, max_depth, params):
    scene = load("furnace_box")
    scene.materials[0].base_color[:] = albedo
    scene.max_depth = max_depth
    spp = 4 if albedo == 1.0 else 16
    image = render(scene, 1, spp, params=params)[..., 0].ravel()
    expected = furnace_box(albedo, 1.0, max_depth)
    standard_error = image.std(ddof=1) / math.sqrt(image.size)
    assert abs(image.mean() - expected) < IMAGE_Z * standard_error + FLOAT_ALLOWANCE * expected, \
        (image.mean(), expected, standard_error)


# ---------------------------------------------------------------- 5. scale and distance
@pytest.fixture(scope="module")
def unit_room():
    scene = load("scale_unit")
    return [render(scene, seed, 16) for seed in SEEDS]


@pytest.mark.parametrize("name", ["scale_1e-3", "scale_1e4", "offset_1e5"])
def test_scaled_and_distant_rooms_render_the_unit_room(unit_room, name):
    """Radiance does not depend on the unit of length: the same seed gives the same paths up
    to rounding, so the per-seed differences are compared (a paired test, far more sensitive
    than comparing two noisy images). Light leaks and self-intersection would show."""
    scene = load(name)
    d = [render(scene, seed, 16) - unit for seed, unit in zip(SEEDS, unit_room)]
    assert_zero_mean(*d, scale=unit_room[0], what=name)


# ---------------------------------------------------------------- 6. bad geometry, nothing at all
def test_degenerate_mesh_renders_as_the_clean_one():
    with pytest.warns(SceneWarning) as record:
        dirty = load_scene(STRESS / "degenerate_mesh.toml")
    messages = " ".join(str(w.message) for w in record)
    assert "NaN/Inf" in messages and "repeated vertex index" in messages
    clean = load("degenerate_mesh_clean")
    assert dirty.triangle_count == clean.triangle_count + 2  # the two zero-area ones stay
    a, b = render(dirty, 1, 8), render(clean, 1, 8)
    # Zero-area triangles are never hit, so every path is the same: the images are identical.
    assert np.array_equal(a, b), np.abs(a - b).max()


@pytest.mark.parametrize("everything", [False, True])
def test_empty_scene_shows_the_sky_and_a_dark_scene_is_black(everything):
    features = SceneFeatures.everything() if everything else None
    empty = load("empty")
    image = render(empty, 1, 4, features=features)
    assert np.array_equal(image, np.broadcast_to([0.25, 0.5, 1.0], image.shape))
    dark = load("no_lights")
    assert render(dark, 1, 4, features=features).max() == 0.0


# ---------------------------------------------------------------- 7. a caustic from a small light
def test_caustic_mean_agrees_with_a_light_tracer():
    """The footprint lies in the sphere's shadow: all its light comes through the glass. The
    path tracer (2 x 64 spp) and a light tracer (4e5 photons, numpy) estimate the mean over the
    image and over the caustic's core; pixels are independent in the render, batches in the
    light tracer, so their variances add."""
    scene = load("caustic")
    size = scene.film_size
    a, b = (render(scene, seed, 64)[..., 0] for seed in SEEDS)
    traced, traced_var = caustic_light_tracer(scene, size, photons=400_000, batches=8, seed=5)
    pixel_var = (a - b) ** 2 / 4
    core = traced > 0.25 * traced.max()
    assert 4 <= core.sum() <= 64, core.sum()
    for region in (np.ones_like(core), core):
        got, want = ((a + b) / 2)[region].sum(), traced[region].sum()
        se = math.sqrt(pixel_var[region].sum() + traced_var[region].sum())
        assert abs(got - want) < IMAGE_Z * se, (region.sum(), got, want, se)
