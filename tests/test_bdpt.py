"""The bdpt plugin against independent answers: the pt plugin (a different estimator of the
same integral) on a Cornell box with glass and rough metal and on a diffuse one with smooth
shading normals; each BDPT strategy on its own (every strategy alone is an unbiased estimator
of the paths it can make, so each must give the same image as the MIS combination); analytic
white furnaces; and Tungsten's reference of Lift's pbrt Cornell box. Tolerances are standard
errors from independent runs (tests/image_stats.py), plus, for Tungsten, the model floors
measured for pt (tests/test_render_e2e.py), which describe the scene, not the integrator.
"""
from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from conftest import REPO, furnace_scene, sphere_pixel_cosines
from image_stats import assert_same_image
from lift_gl import metrics
from lift_gl.cli import main
from lift_gl.errors import SceneError
from lift_gl.renderer import Renderer
from lift_gl.scene import Environment, Material
from lift_gl.scene.features import SceneFeatures
from lift_gl.scene.loader import load_scene

CORNELL = REPO / "scenes" / "cornell.toml"              # glass sphere, rough gold box
CORNELL_DIFFUSE = REPO / "tests" / "data" / "cornell_diffuse.toml"  # diffuse, smooth-shaded ball
SIZE = (32, 32)
RUNS = 16  # independent renders per estimator: many short runs give the standard errors


def renders(scene, integrator, spp, seeds, size=SIZE, features=None, **params):
    """(len(seeds), H, W, 3) float64 renders; no sample or splat may be dropped."""
    images = []
    for seed in seeds:
        r = Renderer(scene, size=size, integrator=integrator, seed=seed, params=params, features=features)
        images.append(r.render(spp=spp).astype(np.float64))
        assert r.stats.dropped_samples == 0 and r.stats.dropped_splats == 0, r.stats.summary()
        r.release()
    return np.array(images)


# ---------------------------------------------------------------- PT and BDPT agree
# mis_power 2 is Veach's power heuristic (the default), 1 the balance heuristic: both unbiased.
# With a sky, light subpaths start on emitters or on the sky's disk, half the time each.
@pytest.mark.parametrize("path, sky, mis_power", [(CORNELL, None, 2.0), (CORNELL_DIFFUSE, None, 2.0),
                                                  (CORNELL_DIFFUSE, (0.6, 0.7, 1.0), 1.0)],
                         ids=["cornell-glass-gold", "cornell-diffuse-smooth", "cornell-diffuse-smooth-sky-balance"])
def test_pt_and_bdpt_agree(path, sky, mis_power):
    scene = load_scene(path)
    if sky is not None:
        scene.environment = Environment(sky)  # the box's open front lets it in
    pt = renders(scene, "pt", 16, range(1, RUNS + 1))
    bdpt = renders(scene, "bdpt", 4, range(101, RUNS + 101), mis_power=mis_power)
    assert_same_image(pt, bdpt, block=8, label=f"{path.name}, sky {sky}: pt vs bdpt (mis_power {mis_power})")


# The caustic of scenes/glass_caustic.toml (a glass sphere focusing a small lamp onto the
# floor): pt reaches it only by a floor bounce aimed through the sphere at the lamp, bdpt
# mostly by light tracing. Blocks of 4x4 pixels at 16x16, so that the caustic has blocks of
# its own; pt gets more samples a run, its caustic being far noisier.
def test_pt_and_bdpt_agree_on_the_glass_caustic():
    scene = load_scene(REPO / "scenes" / "glass_caustic.toml")
    pt = renders(scene, "pt", 64, range(1, RUNS + 1), size=(16, 16))
    bdpt = renders(scene, "bdpt", 16, range(101, RUNS + 101), size=(16, 16))
    assert_same_image(pt, bdpt, block=4, label="glass_caustic.toml: pt vs bdpt")


# ---------------------------------------------------------------- each strategy alone
# Paths of one length (only_depth) made by one strategy alone (only_s, unweighted) against all
# strategies combined by MIS: s = 0 pure path tracing, s = 1 next event estimation, s = d + 1
# pure light tracing (splats, here through one and two bounces). The joins of two subpaths
# (s >= 2, t >= 2) are left out of this test, not of the renderer: alone, a join has infinite
# variance where two surfaces meet (its 1 / d^2 between two diffuse vertices), so a t test
# on its runs means nothing; MIS tames exactly that, and the pt comparisons above cover it.
@pytest.mark.parametrize("depth, strategies", [(1, (0, 1, 2)), (2, (3,))])
def test_each_strategy_alone_gives_the_mis_image(depth, strategies):
    scene = load_scene(CORNELL_DIFFUSE)
    combined = renders(scene, "bdpt", 4, range(201, RUNS + 201), only_depth=depth)
    for s in strategies:
        alone = renders(scene, "bdpt", 4, range(301 + 100 * s, RUNS + 301 + 100 * s), only_depth=depth, only_s=s)
        assert_same_image(combined, alone, block=8, label=f"depth {depth}, s = {s} alone vs MIS")


# ---------------------------------------------------------------- white furnaces
FURNACE_SIZE = (48, 48)
# Both furnaces compile the same shader (one compile: they are slow on a loaded machine).
FURNACE_FEATURES = SceneFeatures(dielectric=True, spheres=True, environment=True)


def furnace_pixels(material, spp=16):
    """The render, and masks of the pixels fully on the sphere and of those at least one
    pixel away from it (a splat may land anywhere on a pixel the sphere touches)."""
    scene = furnace_scene(material, size=FURNACE_SIZE)
    image = renders(scene, "bdpt", spp, [1], size=FURNACE_SIZE, features=FURNACE_FEATURES)[0]
    cos = sphere_pixel_cosines(scene, FURNACE_SIZE, subpixels=8)
    inside = np.all(np.isfinite(cos), axis=-1)
    touched = np.pad(np.any(np.isfinite(cos), axis=-1), 1)
    near = np.zeros_like(inside)
    for dy in range(3):
        for dx in range(3):
            near |= touched[dy:dy + FURNACE_SIZE[1], dx:dx + FURNACE_SIZE[0]]
    return image, inside, ~near


@pytest.mark.parametrize("albedo", [0.8, 1.0])
def test_furnace_diffuse_sphere_shows_its_albedo(albedo):
    """A convex diffuse sphere under a sky of radiance 1 shows its albedo: light subpaths
    start on the sky's disk, and every strategy but s = 0 joins through the sphere."""
    image, inside, outside = furnace_pixels(Material("grey", base_color=[albedo] * 3))
    values = image[inside].ravel()
    se = values.std(ddof=1) / math.sqrt(values.size)  # pixels are independent estimates
    assert abs(values.mean() - albedo) < 3 * se, (values.mean(), se)
    assert np.allclose(image[outside], 1.0, atol=1e-6)  # the sky itself, seen directly


def test_furnace_clear_glass_sphere_vanishes():
    """Smooth glass loses nothing: radiance 1 everywhere. Only delta vertices on the sphere,
    so no strategy may join there; refraction's eta^2 must cancel on the way in and out."""
    image, inside, _ = furnace_pixels(Material("glass", "dielectric", base_color=[1.0] * 3, ior=1.5))
    values = image[inside].ravel()
    se = values.std(ddof=1) / math.sqrt(values.size)
    assert abs(values.mean() - 1.0) < 3 * se + 1e-6, (values.mean(), se)


# ---------------------------------------------------------------- Tungsten's Cornell box
SIZE_REF = 64
SPP_REF = 128  # the frames' shared subpixel jitter correlates errors along the light's edge: fewer frames leave it under-sampled


@pytest.fixture(scope="module")
def pbrt_cornell_bdpt():
    from conftest import SHARED
    from lift_gl.image_io import read_image
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent (the course's shared data folder with the pbrt scene and reference)")
    shared_dir = SHARED
    scene = load_scene(shared_dir / "scenes_lift" / "cornell-box" / "scene.pbrt")
    a, b = renders(scene, "bdpt", SPP_REF, (1, 2), size=(SIZE_REF, SIZE_REF))
    ref = metrics.resize_to(read_image(shared_dir / "refs" / "lift" / "cornell-box.exr"), (SIZE_REF, SIZE_REF))
    return a, b, ref.astype(np.float64)


def test_bdpt_converges_to_tungsten_on_the_pbrt_cornell_box(pbrt_cornell_bdpt):
    """As tests/test_render_e2e.py checks pt: mean radiance within standard errors and relMSE
    within our own noise, each plus the model floor measured there (lift-gl's scene model
    against Tungsten's, the same whichever lift-gl integrator renders it)."""
    from test_render_e2e import MEAN_REL_FLOOR, RELMSE_FLOOR
    a, b, ref = pbrt_cornell_bdpt
    mean = (a + b) / 2
    n = SIZE_REF * SIZE_REF
    se = np.sqrt(((a - b) ** 2 / 4).reshape(-1, 3).mean(axis=0) / n)
    got, want = mean.reshape(-1, 3).mean(axis=0), ref.reshape(-1, 3).mean(axis=0)
    assert np.all(np.abs(got - want) <= 4.0 * se + MEAN_REL_FLOOR * want), (got, want, se)
    # relMSE beyond our own noise: per pixel, (mean - ref)^2 / w minus the noise (a - b)^2 / 4w
    # that the two halves predict. Its mean over pixels is the bias^2 (plus the reference's
    # noise); its standard error comes from the spread over pixels (bdpt's fireflies make
    # a fixed allowance such as 1.5x the noise too tight or too loose).
    w = ref ** 2 + metrics.REL_MSE_EPS
    excess = ((mean - ref) ** 2 / w - (a - b) ** 2 / (4 * w)).ravel()
    se_excess = excess.std() / np.sqrt(excess.size)
    assert excess.mean() <= 4.0 * se_excess + RELMSE_FLOOR, (excess.mean(), se_excess, metrics.rel_mse(mean, ref))
    assert metrics.ssim(mean, ref) >= metrics.ssim(a, b)


# ---------------------------------------------------------------- repeatability
def test_same_seed_repeats_to_float_rounding():
    """Splats are float atomics, summed in whatever order the threads run: a seed fixes every
    random number, and the image to a few ulps (bit for bit where no splat lands)."""
    scene = load_scene(CORNELL)
    a, b = renders(scene, "bdpt", 2, [7, 7])
    c = renders(scene, "bdpt", 2, [8])[0]
    assert np.all(np.abs(a - b) <= 1e-5 * np.abs(a) + 1e-7)
    assert np.mean(np.any(a != c, axis=-1)) > 0.5


# ---------------------------------------------------------------- command line and scenes
def test_cli_renders_with_bdpt_and_lists_it(tmp_path, capsys):
    out = tmp_path / "bdpt.npy"
    assert main(["render", str(CORNELL), "--integrator", "bdpt", "--spp", "2", "--size", "16x16",
                 "--set", "bdpt.mis_power=1", "--out", str(out), "--explain"]) == 0
    image = np.load(out)
    assert image.shape == (16, 16, 3) and np.isfinite(image).all() and image.mean() > 0
    printed = capsys.readouterr().out
    assert "integrator: bdpt" in printed and "with splats" in printed
    assert main(["plugins"]) == 0
    listing = capsys.readouterr().out
    for name in ("bdpt", "mis_power", "only_s", "only_depth", "rr_depth"):
        assert name in listing


def test_covered_dragon_scene_names_its_missing_mesh(tmp_path):
    copy = tmp_path / "scenes" / "covered_dragon.toml"
    copy.parent.mkdir()
    shutil.copy(REPO / "scenes" / "covered_dragon.toml", copy)  # ../../shared is not beside it
    text = copy.read_text().splitlines()
    line = next(i for i, t in enumerate(text, start=1) if t.startswith("file = "))
    with pytest.raises(SceneError) as err:
        load_scene(copy)
    assert err.value.path == str(copy) and err.value.line == line
    assert "dragon_100k.ply" in str(err.value)


def test_covered_dragon_scene_loads(shared_dir):
    scene = load_scene(REPO / "scenes" / "covered_dragon.toml")
    dragon = next(m for m in scene.meshes if m.name == "dragon")
    assert len(dragon.indices) == 100_000
    lo, hi = dragon.positions.min(axis=0), dragon.positions.max(axis=0)
    assert abs(lo[1]) < 1e-3  # stands on the floor
    assert np.all(lo > [0, -1e-3, -1]) and np.all(hi < [1, 0.898, 0])  # inside the box, under the cover
    light = next(m for m in scene.meshes if m.name == "light")
    assert scene.materials[light.material].emission.tolist() == [70, 70, 70]


# ---------------------------------------------------------------- arrays sized by max_depth
# The subpath arrays follow max_depth at compile time (BDPT_MAX_DEPTH, `define` in plugin.toml);
# the walk and every strategy are the same as with the old fixed size of 64, so every camera-side
# estimate must be bit for bit the same. Light tracing's splats are summed by float atomics in
# an order the threads decide (the same program twice differs there in the last bit), so the
# full images agree to float rounding. Glass and rough gold: delta vertices take part.
def _bdpt_pair(depth, splats):
    from lift_gl.passes.trace import TracePass

    scene = load_scene(CORNELL)
    sized = Renderer(scene, size=(24, 24), integrator="bdpt", seed=7, params={"max_depth": depth})
    fixed = Renderer(scene, size=(24, 24), integrator="bdpt", seed=7, params={"max_depth": depth})
    fixed.trace.release()
    fixed.trace = TracePass(fixed.ctx, fixed.size, fixed.plugin, dict(fixed.trace.defines, BDPT_MAX_DEPTH=64))
    if not splats:
        for r in (sized, fixed):
            r.trace.splats.add_to = lambda frame: None
    return sized, fixed


@pytest.mark.parametrize("depth", [0, 1, 3, 6])
def test_array_size_changes_no_pixel(depth):
    sized, fixed = _bdpt_pair(depth, splats=False)
    assert f"#define BDPT_MAX_DEPTH {depth}\n" in sized.trace.source.text
    a, b = sized.render(spp=3), fixed.render(spp=3)
    assert a.max() > 0.0 and np.array_equal(a, b)
    sized.set_params(max_depth=depth + 2)  # recompiled for the new depth
    assert f"#define BDPT_MAX_DEPTH {depth + 2}\n" in sized.trace.source.text
    sized.release()
    fixed.release()
    sized, fixed = _bdpt_pair(depth, splats=True)
    a, b = sized.render(spp=3), fixed.render(spp=3)
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=0)  # a few float roundings of a sum
    sized.release()
    fixed.release()
