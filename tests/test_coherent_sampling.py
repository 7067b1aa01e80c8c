"""Coherent sampling (pt's `coherent_sampling`; lift_gl/passes/common.py rng_key_function): the
pixels of a work group's tile draw the same random numbers, so that a GPU warp's rays stay
together. Each pixel's estimate keeps its distribution: the same expectation (checked against
the independent sampler per block and over the whole image, and against the furnace's
analytic value) and the same variance per pixel; what changes is that the noise of a tile's
pixels is correlated, and only inside the tile. The pixel queue and the wavefront give the
plain megakernel's image with it as without it."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from conftest import REPO
from lift_gl.passes.common import COHERENT_PARAM, rng_key_function
from lift_gl.passes.trace import PIXEL_QUEUE_ENV_VAR
from lift_gl.passes.wavefront import WAVEFRONT_ENV_VAR
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene
from lift_gl.testing import assert_mean_is, assert_same_expectation, cornell_scene, furnace_scene, render_seeds

ON = {COHERENT_PARAM: True}
ALBEDO = 0.8  # the furnace's every pixel converges to albedo x sky radiance (1)


def _tile(size=(32, 32)) -> tuple[int, int]:
    """The trace pass's work-group shape on this machine: the tile whose pixels share numbers."""
    r = Renderer(furnace_scene(size=size), size=size, integrator="pt", params=ON)
    try:
        return tuple(r.trace.local_size)
    finally:
        r.release()


def test_coherent_sampling_keeps_each_pixels_expectation():
    # independent renders (seeds) of the Cornell box, coherent against independent sampling:
    # Welch's t per 8x8 block and for the whole image (a tile's correlation only makes a
    # block's mean noisier from render to render, which the test measures)
    coherent = render_seeds(cornell_scene(), "pt", range(16), spp=4, params=ON)
    independent = render_seeds(cornell_scene(), "pt", range(100, 116), spp=4)
    assert not np.array_equal(coherent[0], independent[0])
    assert_same_expectation(coherent, independent, block=8)


def test_coherent_furnace_converges_to_the_albedo():
    # each render's image mean is one estimate; renders are independent, pixels are not
    images = render_seeds(furnace_scene(ALBEDO), "pt", range(24), spp=2, params=ON)
    assert_mean_is(images.mean(axis=(1, 2, 3)), ALBEDO)


def _residuals(coherent: bool, seeds, size=(64, 64)) -> np.ndarray:
    """(K, H, W) the furnace's 1-spp luminance error (its exact value is known)."""
    images = render_seeds(furnace_scene(ALBEDO, size=size), "pt", seeds, spp=1, size=size,
                          params={COHERENT_PARAM: coherent})
    return images.mean(axis=-1) - ALBEDO


def _neighbour_correlation(residual: np.ndarray, tile_w: int) -> tuple[float, float, int, int]:
    """Correlation of horizontally adjacent pixels' errors, for pairs inside a tile and pairs
    across a tile's edge, and how many independent pairs each has (for its standard error)."""
    a, b = residual[:, :, :-1], residual[:, :, 1:]
    inside = (np.arange(a.shape[2]) % tile_w) != tile_w - 1
    variance = float((residual ** 2).mean())
    corr_in = float((a[:, :, inside] * b[:, :, inside]).mean()) / variance
    corr_across = float((a[:, :, ~inside] * b[:, :, ~inside]).mean()) / variance
    return corr_in, corr_across, int(a[:, :, inside].size), int(a[:, :, ~inside].size)


def test_noise_is_correlated_inside_a_tile_and_nowhere_else():
    tile_w, tile_h = _tile()
    seeds = range(8)
    # independent sampling: no correlation anywhere (standard error 1 / sqrt(pairs))
    corr_in, corr_across, n_in, n_across = _neighbour_correlation(_residuals(False, seeds), tile_w)
    assert abs(corr_in) < 5 / np.sqrt(n_in) and abs(corr_across) < 5 / np.sqrt(n_across)
    # coherent: a tile's pixels see the same numbers on a smooth sphere, so their errors
    # nearly agree; pairs across a tile's edge are independent, but each tile pair counts
    # once (its rows repeat the same numbers): standard error 1 / sqrt(tile pairs)
    residual = _residuals(True, seeds)
    corr_in, corr_across, _, n_across = _neighbour_correlation(residual, tile_w)
    tile_pairs = n_across // tile_h
    assert corr_in > 0.9, corr_in
    assert abs(corr_across) < 5 / np.sqrt(tile_pairs), (corr_across, tile_pairs)


def test_each_pixels_variance_is_unchanged():
    # the variance of a pixel's 1-spp estimate over independent renders, averaged per tile,
    # paired tile by tile (tiles are independent of each other either way); a t test on the
    # tiles' differences at p = 1e-3
    tile_w, tile_h = _tile()
    seeds = range(48)
    size = (64, 64)

    def per_tile_variance(coherent, first_seed):
        residual = _residuals(coherent, [first_seed + s for s in seeds], size)
        var = residual.var(axis=0, ddof=1)
        h, w = var.shape
        return var.reshape(h // tile_h, tile_h, w // tile_w, tile_w).mean(axis=(1, 3)).ravel()

    coherent, independent = per_tile_variance(True, 0), per_tile_variance(False, 1000)
    difference = coherent - independent
    t = difference.mean() / (difference.std(ddof=1) / np.sqrt(difference.size))
    critical = stats.t.ppf(1 - 1e-3 / 2, difference.size - 1)
    assert abs(t) < critical, (coherent.mean(), independent.mean(), t)
    assert 0.8 < coherent.mean() / independent.mean() < 1.25


def _render(monkeypatch, scene_name, queue="off", wavefront="off", spp=3):
    monkeypatch.setenv(PIXEL_QUEUE_ENV_VAR, queue)
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, wavefront)
    r = Renderer(load_scene(REPO / "scenes" / scene_name), size=(37, 29), integrator="pt", seed=3, params=ON)
    try:
        image = r.render(spp=spp)
        return image, r.trace.pixel_queue is not None, r.trace.wavefront is not None
    finally:
        r.release()


@pytest.mark.parametrize("scene_name", ["cornell.toml", "showcase.toml"])
def test_pixel_queue_and_wavefront_keep_the_coherent_image(monkeypatch, scene_name):
    plain, had_queue, had_wave = _render(monkeypatch, scene_name)
    queued, has_queue, _ = _render(monkeypatch, scene_name, queue="on")
    wave, _, has_wave = _render(monkeypatch, scene_name, wavefront="on")
    assert (had_queue, had_wave, has_queue, has_wave) == (False, False, True, True)
    assert np.isfinite(plain).all() and plain.max() > 0
    np.testing.assert_array_equal(queued, plain)
    np.testing.assert_array_equal(wave, plain)


def test_only_a_bool_parameter_of_that_name_turns_it_on():
    def plugin(params):
        return SimpleNamespace(params={name: SimpleNamespace(type=t) for name, t in params.items()})

    assert "pixel / uvec2(8u, 4u)" in rng_key_function(plugin({COHERENT_PARAM: "bool"}), (8, 4))
    for params in ({}, {COHERENT_PARAM: "int"}, {"coherent_other": "bool"}):
        assert rng_key_function(plugin(params), (8, 4)) == "uvec2 lift_rng_key(uvec2 pixel) { return pixel; }"
