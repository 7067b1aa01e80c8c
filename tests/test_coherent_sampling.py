"""Coherent sampling (the option coherent_sampling; shaders/lift/host_tiles.glsl): the
pixels of a work group's tile draw the same random numbers, so that a GPU warp's rays stay
together. Each pixel's estimate keeps its distribution: the same expectation (checked against
the independent sampler per block and over the whole image, and against the furnace's
analytic value) and the same variance per pixel; what changes is that the noise of a tile's
pixels is correlated, and only inside the tile; the tiles move from frame to frame, so no grid
stays in the accumulated noise. The pixel queue gives the plain megakernel's image with it as
without it."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from conftest import REPO
from lift_gl.options import Options
from lift_gl.passes.common import COHERENT_DEFINE, INTERLEAVE_DEFINE, coherent_defines, tile_dispatch_size
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene
from lift_gl.testing import assert_mean_is, assert_same_expectation, cornell_scene, furnace_scene, render_seeds

ON = Options(coherent_sampling="on")
ALBEDO = 0.8  # the furnace's every pixel converges to albedo x sky radiance (1)


def _tile(size=(32, 32)) -> tuple[int, int]:
    """The trace pass's work-group shape on this machine: the tile whose pixels share numbers."""
    r = Renderer(furnace_scene(size=size), size=size, integrator="pt", options=ON)
    try:
        return tuple(r.trace.local_size)
    finally:
        r.release()


@pytest.mark.parametrize("integrator", ["pt", "bdpt"])   # bdpt's tile shares its camera subpaths
def test_coherent_sampling_keeps_each_pixels_expectation(integrator):
    # independent renders (seeds) of the Cornell box, coherent against independent sampling:
    # Welch's t per 8x8 block and for the whole image (a tile's correlation only makes a
    # block's mean noisier from render to render, which the test measures)
    coherent = render_seeds(cornell_scene(), integrator, range(16), spp=4, options=ON)
    independent = render_seeds(cornell_scene(), integrator, range(100, 116), spp=4)
    assert not np.array_equal(coherent[0], independent[0])
    assert_same_expectation(coherent, independent, block=8)


def test_coherent_furnace_converges_to_the_albedo():
    # each render's image mean is one estimate; renders are independent, pixels are not
    images = render_seeds(furnace_scene(ALBEDO), "pt", range(24), spp=2, options=ON)
    assert_mean_is(images.mean(axis=(1, 2, 3)), ALBEDO)


def _residuals(coherent: bool, seeds, size=(64, 64), spp=1, interleave=1) -> np.ndarray:
    """(K, H, W) the furnace's luminance error (its exact value is known) after spp frames."""
    images = render_seeds(furnace_scene(ALBEDO, size=size), "pt", seeds, spp=spp, size=size,
                          options=Options(coherent_sampling="on" if coherent else "off",
                                          coherent_interleave=interleave))
    return images.mean(axis=-1) - ALBEDO


def _lag_correlation(residual: np.ndarray, lag: int) -> float:
    """Correlation of the errors of pixels `lag` apart in a row, pooled over rows and the stack."""
    return float((residual[..., :-lag] * residual[..., lag:]).mean() / (residual ** 2).mean())


def _column_correlations(residual: np.ndarray, tile_w: int) -> np.ndarray:
    """(tile_w,) the correlation of horizontally adjacent pixels' errors for the pairs (x, x + 1)
    with x % tile_w == c, c = 0 .. tile_w - 1, pooled over rows and the stack."""
    a, b = residual[..., :-1], residual[..., 1:]
    variance = float((residual ** 2).mean())
    column = np.arange(a.shape[-1]) % tile_w
    return np.array([float((a[..., column == c] * b[..., column == c]).mean()) / variance for c in range(tile_w)])


def test_noise_is_correlated_inside_a_frames_tiles_which_move():
    tile_w, _ = _tile()
    seeds = range(8)
    # independent sampling: no correlation anywhere (standard error about 1 / sqrt(pairs))
    residual = _residuals(False, seeds)
    pairs = residual[..., :-1].size / tile_w
    assert np.all(np.abs(_column_correlations(residual, tile_w)) < 5 / np.sqrt(pairs))
    # coherent, one frame each: a smooth sphere under the same numbers, so the errors of a
    # tile's pixels nearly agree; one column of pairs straddles the tiles' edges and is
    # independent. Which column that is depends on the frame (and seed): the grid moves.
    edges = []
    for per_seed in _residuals(True, seeds):
        corr = _column_correlations(per_seed, tile_w)
        edge = int(np.argmin(corr))
        assert corr[edge] < 0.5 and np.delete(corr, edge).min() > 0.9, corr
        edges.append(edge)
    assert len(set(edges)) > 1, edges
    # after several frames every column has shared a tile in most of them (7 in 8 on average):
    # no fixed grid is left. With a fixed grid one column's correlation would stay at 0, give
    # or take 1 / sqrt(16 renders x 8 rows of tiles) = 0.09.
    corr = _column_correlations(_residuals(True, range(100, 116), spp=8), tile_w)
    assert corr.min() > 0.3, corr


def test_interleaved_tiles_keep_neighbours_independent():
    # interleave 2: a tile is every other pixel of a block twice its size, so a pixel's
    # neighbour belongs to another tile (independent numbers) and the pixel two apart to its
    # own (in 14 of 16 columns of a 16-wide block)
    residual = _residuals(True, range(8), interleave=2)
    assert abs(_lag_correlation(residual, 1)) < 0.15, _lag_correlation(residual, 1)
    assert _lag_correlation(residual, 2) > 0.7, _lag_correlation(residual, 2)
    # and the expectation is unchanged (the Cornell box, against independent sampling)
    coherent = render_seeds(cornell_scene(), "pt", range(200, 216), spp=4,
                            options=Options(coherent_sampling="on", coherent_interleave=2))
    independent = render_seeds(cornell_scene(), "pt", range(300, 316), spp=4)
    assert_same_expectation(coherent, independent, block=8)


def _assert_same_variance_per_tile(coherent: np.ndarray, independent: np.ndarray) -> None:
    """(K, H, W) stacks of independent renders' luminance: the variance of a pixel's estimate
    over the renders, averaged per tile, paired tile by tile (tiles are independent of each
    other either way); a t test on the tiles' differences at p = 1e-3."""
    tile_w, tile_h = _tile()

    def per_tile(stack):
        var = stack.var(axis=0, ddof=1)
        h, w = var.shape
        return var.reshape(h // tile_h, tile_h, w // tile_w, tile_w).mean(axis=(1, 3)).ravel()

    a, b = per_tile(coherent), per_tile(independent)
    difference = a - b
    t = difference.mean() / (difference.std(ddof=1) / np.sqrt(difference.size))
    critical = stats.t.ppf(1 - 1e-3 / 2, difference.size - 1)
    assert abs(t) < critical, (a.mean(), b.mean(), t)
    assert 0.8 < a.mean() / b.mean() < 1.25, (a.mean(), b.mean())


def test_each_pixels_variance_is_unchanged():
    # the furnace's 1-spp estimates, 48 renders each way
    seeds = range(48)
    _assert_same_variance_per_tile(_residuals(True, seeds), _residuals(False, [1000 + s for s in seeds]))


def test_bdpt_keeps_each_pixels_variance_with_its_own_light_subpaths():
    # bdpt shares its camera subpaths by tile but draws each pixel's light subpath from the
    # pixel's own numbers (lift_own_rng): light tracing's splats stay independent. (Sharing the
    # light subpath too made this variance 2.6x here, and the H100's error at equal time 3.9x.)
    size, seeds = (48, 48), range(48)

    def luminance(coherent, first):
        return render_seeds(cornell_scene(), "bdpt", [first + s for s in seeds], spp=1, size=size,
                            options=Options(coherent_sampling="on" if coherent else "off")).mean(axis=-1)

    _assert_same_variance_per_tile(luminance(True, 0), luminance(False, 1000))


def test_drt_coherent_sampling_keeps_each_pixels_expectation_and_variance():
    # drt traces its own camera rays (primary = "camera"): the tile shares subpixel and lens
    # positions too; everything it draws is the pixel's (tile's) own, so the estimate per pixel
    # keeps its distribution
    size = (48, 48)
    coherent = render_seeds(cornell_scene(), "drt", range(48), spp=1, size=size, options=ON)
    independent = render_seeds(cornell_scene(), "drt", range(1000, 1048), spp=1, size=size)
    assert not np.array_equal(coherent[0], independent[0])
    assert_same_expectation(coherent, independent, block=8)
    _assert_same_variance_per_tile(coherent.mean(axis=-1), independent.mean(axis=-1))


def _render(scene_name, queue="off", spp=4, spf=1, interleave=1):
    r = Renderer(load_scene(REPO / "scenes" / scene_name), size=(37, 29), integrator="pt", seed=3,
                 options=Options(coherent_sampling="on", coherent_interleave=interleave, pixel_queue=queue),
                 samples_per_frame=spf)
    try:
        image = r.render(spp=spp)
        return image, r.trace.pixel_queue is not None
    finally:
        r.release()


@pytest.mark.parametrize("scene_name, spf, interleave", [
    ("cornell.toml", 1, 1), ("showcase.toml", 1, 1), ("cornell.toml", 2, 1), ("cornell.toml", 1, 2),
    ("showcase.toml", 2, 3)])
def test_pixel_queue_keeps_the_coherent_image(scene_name, spf, interleave):
    # 37x29: the moving tiles (and blocks of interleaved tiles) overhang the image on every side
    kw = {"spf": spf, "interleave": interleave}
    plain, had_queue = _render(scene_name, **kw)
    queued, has_queue = _render(scene_name, queue="on", **kw)
    assert (had_queue, has_queue) == (False, True)
    assert np.isfinite(plain).all() and plain.max() > 0
    np.testing.assert_array_equal(queued, plain)


def test_the_options_compile_it_in_only_when_on():
    assert coherent_defines("on", 1) == {COHERENT_DEFINE: 1, INTERLEAVE_DEFINE: 1}
    assert coherent_defines("on", 4) == {COHERENT_DEFINE: 1, INTERLEAVE_DEFINE: 4}
    assert coherent_defines("off", 4) == {}
    # whole blocks over the image moved by up to a block less a pixel: 9 x 13 tiles of 8x4,
    # interleaved by 2 five by seven blocks of 2 x 2 tiles
    assert tile_dispatch_size({COHERENT_DEFINE: 1}, (64, 48), (8, 4)) == (72, 52)
    assert tile_dispatch_size({COHERENT_DEFINE: 1, INTERLEAVE_DEFINE: 2}, (64, 48), (8, 4)) == (80, 56)
    assert tile_dispatch_size({}, (64, 48), (8, 4)) == (64, 48)


def test_a_manifest_of_an_older_version_loads_with_a_warning(tmp_path):
    """A plugin whose manifest still declares coherent_sampling (and bvh_stack) loads: the
    parameter is a plain uniform, which no longer switches the host's coherent sampling."""
    import shutil

    from lift_gl.plugins import PluginWarning, load_manifest

    folder = tmp_path / "old_pt"
    shutil.copytree(REPO / "plugins" / "pt", folder)
    manifest = folder / "plugin.toml"
    manifest.write_text(manifest.read_text().replace('primary = "gbuffer"', 'primary = "gbuffer"\nbvh_stack = "children"')
                        + '\n[params.coherent_sampling]\ntype = "bool"\ndefault = true\n')
    with pytest.warns(PluginWarning) as caught:
        plugin = load_manifest(folder)
    messages = [str(w.message) for w in caught]
    assert any("bvh_stack is ignored" in m and f"{manifest}:" in m for m in messages), messages
    assert any("parameter coherent_sampling no longer switches anything" in m for m in messages), messages
    r = Renderer(cornell_scene(), size=(16, 16), integrator=str(folder))
    try:
        assert COHERENT_DEFINE not in r.trace.defines and r.params["coherent_sampling"] is True
    finally:
        r.release()


def _source_with(options: Options, scene) -> tuple:
    r = Renderer(scene, size=(32, 32), integrator="pt", seed=4, options=options)
    try:
        return r.trace.source.text, r.trace.defines, r.explain(), r.render(spp=2)
    finally:
        r.release()


def test_off_is_the_program_without_it():
    scene = cornell_scene()
    off_source, off_defines, off_explain, off = _source_with(Options(), scene)
    on_source, on_defines, on_explain, on = _source_with(ON, scene)
    assert "coherent sampling: the pixels" not in off_explain and COHERENT_DEFINE not in off_defines
    assert COHERENT_DEFINE in on_defines and on_source != off_source
    assert "coherent sampling: the pixels of each" in on_explain
    _, defines, explain, _ = _source_with(Options(coherent_sampling="on", coherent_interleave=2), scene)
    assert "its pixels 2 apart in a" in explain and defines[INTERLEAVE_DEFINE] == 2
    assert not np.array_equal(on, off)
