"""The error estimate without a reference (even/odd half-buffers of the accumulation): the
half difference by hand, the estimator's formula by hand and its unbiasedness by simulation,
then renders whose actual error is known independently (an analytic furnace; a second,
independent render)."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO, furnace_scene, sphere_pixel_cosines
from lift_gl.error_estimate import estimate_error, variance_of_mean
from lift_gl.gl.context import create_context
from lift_gl.metrics import REL_MSE_EPS
from lift_gl.passes.accumulate import AccumulatePass, half_sign
from lift_gl.renderer import Renderer
from lift_gl.scene import Material
from lift_gl.scene.loader import load_scene

# |mean of n values| / (its standard error) below 4: two-sided p ~ 6e-5 for a normal mean.
Z_CRIT = 4.0


# ---------------------------------------------------------------- by hand
def test_half_difference_is_half_a_minus_half_b():
    ctx = create_context()
    size = (2, 1)
    acc = AccumulatePass(ctx, size)
    frame = ctx.texture(size, 4, dtype="f4")
    signs = [half_sign(k) for k in range(6)]
    # Each pair of frames sends one to each half.
    assert all(signs[k] == -signs[k + 1] for k in (0, 2, 4)) and signs[0::2] != [1.0, 1.0, 1.0]
    # Frame k: pixel 0 has radiance k + 1 from one sample; pixel 1 has 2 samples summing to
    # 10 in even frames and none (all dropped) in odd frames.
    expected = np.zeros((2, 4))
    for k in range(5):
        data = np.array([[[k + 1.0, 2.0 * (k + 1), 0.0, 1.0],
                          [10.0, 10.0, 10.0, 2.0] if k % 2 == 0 else [0.0, 0.0, 0.0, 0.0]]], np.float32)
        frame.write(data.tobytes())
        acc.run(frame)
        expected += signs[k] * data[0]
    np.testing.assert_array_equal(acc.read_half_difference()[0], expected)
    np.testing.assert_array_equal(acc.read_totals()[0, 0], [15, 30, 0, 5])
    acc.reset()
    assert acc.frames == 0 and not acc.read_half_difference().any()
    frame.write(np.array([[[7, 7, 7, 1], [0, 0, 0, 0]]], np.float32).tobytes())
    acc.run(frame)  # after a reset the sequence of halves starts again
    np.testing.assert_array_equal(acc.read_half_difference()[0, 0], np.multiply(signs[0], [7, 7, 7, 1]))


def test_variance_of_mean_by_hand():
    # Pixel 0: even samples 1 and 3 (A = 2, n_a = 2), odd sample 6 (B = 6, n_b = 1):
    #   Var(M) ~ (2 - 6)^2 * 2 * 1 / 3^2 = 32/9, M = 10/3.
    # Pixel 1: only even samples -> unknown.
    totals = np.array([[[10.0, 10.0, 10.0, 3.0], [4.0, 4.0, 4.0, 2.0]]])
    difference = np.array([[[4.0 - 6.0, -2.0, -2.0, 1.0], [4.0, 4.0, 4.0, 2.0]]])
    v = variance_of_mean(totals, difference)
    np.testing.assert_allclose(v[0, 0], [32 / 9] * 3)
    assert np.isnan(v[0, 1]).all()
    estimate = estimate_error(totals, difference)
    assert estimate.pixels == 1
    assert estimate.rel_mse == pytest.approx((32 / 9) / ((10 / 3) ** 2 + REL_MSE_EPS))
    assert estimate.rel_std_error == pytest.approx(np.sqrt(estimate.rel_mse))
    assert estimate_error(totals[:, 1:], difference[:, 1:]) is None  # one half only


@pytest.mark.parametrize("n_a, n_b", [(4, 4), (3, 2), (1, 1)])
def test_estimator_is_unbiased_for_independent_samples(n_a, n_b):
    """Simulated pixels of normal samples (sigma = 2): the estimate averages to sigma^2 / n."""
    rng = np.random.default_rng(n_a * 10 + n_b)
    pixels, sigma = 200_000, 2.0
    a = rng.normal(5.0, sigma, (pixels, n_a))
    b = rng.normal(5.0, sigma, (pixels, n_b))
    totals = np.stack([a.sum(1) + b.sum(1)] * 3 + [np.full(pixels, n_a + n_b)], -1)
    difference = np.stack([a.sum(1) - b.sum(1)] * 3 + [np.full(pixels, n_a - n_b)], -1)
    v = variance_of_mean(totals, difference)[:, 0]
    expected = sigma ** 2 / (n_a + n_b)
    z = (v.mean() - expected) / (v.std(ddof=1) / np.sqrt(pixels))
    assert abs(z) < Z_CRIT, (v.mean(), expected)


# ---------------------------------------------------------------- renders
SIZE = (48, 48)


@pytest.mark.parametrize("spp", [64, 63])  # 63: halves of unequal size (32 and 31 frames)
def test_furnace_estimate_matches_the_actual_error(spp):
    """Diffuse sphere of albedo 0.8 in a white furnace: a fully covered pixel is exactly 0.8.
    Over those pixels the squared error of the mean and the estimated variance of the mean
    have the same expectation; their per-pixel differences average to 0 within Z_CRIT
    standard errors (pixels are independent)."""
    scene = furnace_scene(Material("grey", "diffuse", base_color=[0.8] * 3), size=SIZE)
    inside = np.all(np.isfinite(sphere_pixel_cosines(scene, SIZE)), axis=-1)
    assert inside.sum() > 500
    gaps, actual = [], []
    for seed in range(1, 7):  # 6 x ~750 pixels: enough to see a 25% error (below)
        r = Renderer(scene, size=SIZE, seed=seed)
        image = r.render(spp=spp)
        assert r.stats.dropped_samples == 0
        v = variance_of_mean(r.accumulate.read_totals(), r.accumulate.read_half_difference())[::-1]
        squared_error = (image[inside, 0].astype(np.float64) - 0.8) ** 2
        gaps.append(squared_error - v[inside, 0])
        actual.append(squared_error)
        r.release()
    gaps, actual = np.concatenate(gaps), np.concatenate(actual)
    z = gaps.mean() / (gaps.std(ddof=1) / np.sqrt(gaps.size))
    assert abs(z) < Z_CRIT, f"estimate off by {gaps.mean() / actual.mean():.1%} of the actual error (z = {z:.2f})"
    # The test has power: an estimate 25% off would be 2 * Z_CRIT standard errors away.
    assert 0.25 * actual.mean() > 2 * Z_CRIT * gaps.std(ddof=1) / np.sqrt(gaps.size)


def test_cornell_estimate_matches_the_gap_between_two_independent_renders():
    """The whole image (edges, glass, gold, many bounces): two independent renders x1, x2 have
    E[(x1 - x2)^2] = Var1 + Var2 per pixel, which the estimates v1 + v2 predict."""
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    size = (32, 32)
    renders = []
    for seed in (11, 12):
        r = Renderer(scene, size=size, seed=seed)
        image = r.render(spp=48).astype(np.float64)
        assert r.stats.dropped_samples == 0
        estimate = r.estimate_error()
        assert r.stats.error is estimate and estimate.pixels == size[0] * size[1]
        v = variance_of_mean(r.accumulate.read_totals(), r.accumulate.read_half_difference())[::-1]
        renders.append((image, v))
        r.release()
    (x1, v1), (x2, v2) = renders
    gaps = ((x1 - x2) ** 2 - (v1 + v2)).sum(-1).ravel()  # per pixel, channels summed
    z = gaps.mean() / (gaps.std(ddof=1) / np.sqrt(gaps.size))
    assert abs(z) < Z_CRIT, (gaps.mean(), ((x1 - x2) ** 2).sum(-1).mean(), z)


def test_estimate_keeps_falling_at_edges():
    """A black sphere in a white furnace: no noise at all inside or outside it, only at its
    edges, from the subpixel jitter. The jitter is a Halton sequence whose base-2 coordinate
    alternates between the two halves of a pixel from frame to frame: halves split by frame
    parity would differ by a fixed amount there and the estimate would stop falling (it does:
    0.0144, 0.0127, 0.0113 at 16, 64, 256 spp). Split at random, it falls like 1/spp."""
    scene = furnace_scene(Material("black", "diffuse", base_color=[0.0] * 3), size=SIZE)
    r = Renderer(scene, size=SIZE, seed=1)
    estimates = []
    for spp in (16, 256):
        r.render(spp=spp - r.stats.spp)
        estimates.append(r.estimate_error().rel_mse)
    assert r.stats.dropped_samples == 0
    r.release()
    assert estimates[0] / estimates[1] > 8, estimates  # 16 for 1/spp, about 1.3 with parity
