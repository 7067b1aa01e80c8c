"""lift_gl/consistency.py: the bias test of grade and compare, on images whose truth is known.

Synthetic estimators (numpy, no GL) with a known expectation: Gaussian noise, and a rare-event
estimator whose samples are 0 or truth / p (the shape of a path tracer's fireflies). A test at
level alpha must reject a correct estimator with probability at most alpha, checked over many
trials against a binomial bound, and must reject a biased one.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from lift_gl.consistency import Blocks, Estimate, compare_estimates

H = W = 32
BLOCKS = Blocks.grid(H, W, 8)


def truth(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).random((H, W, 3)) + 0.2


def gaussian(rng, image, seeds, spp, sigma=1.0, bias=1.0):
    return bias * image + sigma * image * rng.standard_normal((seeds, *image.shape)) / math.sqrt(spp)


def rare(rng, image, seeds, spp, p=0.05, bias=1.0):
    """Each sample is image / p with probability p, else 0: unbiased, skewed, variance (1/p - 1) image^2."""
    hits = rng.binomial(spp, p, (seeds, *image.shape[:2], 1))
    return bias * hits / (spp * p) * image


def binomial_bound(trials: int, alpha: float, confidence: float = 1e-4) -> int:
    """Rejections that `trials` tests at level alpha exceed with probability below `confidence`."""
    return int(stats.binom.isf(confidence, trials, alpha))


@pytest.mark.parametrize("noise", ["gaussian", "rare"])
def test_correct_estimators_rejected_at_most_alpha(noise):
    rng = np.random.default_rng(1)
    image = truth()
    alpha, trials = 0.05, 300
    rejected = 0
    for _ in range(trials):
        make = gaussian if noise == "gaussian" else rare
        estimate = Estimate.from_seeds(make(rng, image, 16, 16), BLOCKS, 16)
        reference = Estimate.from_seeds(make(rng, image, 32, 16), BLOCKS, 16)
        # tolerance 0: the pure statistical test, whose level is exactly alpha
        rejected += not compare_estimates(estimate, reference, alpha, tolerance=0.0, block_tolerance=None).consistent
    assert rejected <= binomial_bound(trials, alpha), f"{rejected} of {trials} correct estimators rejected"


def test_against_an_exact_image_rejected_at_most_alpha():
    rng = np.random.default_rng(2)
    image = truth()
    exact = Estimate.exact(image, BLOCKS)
    alpha, trials = 0.05, 300
    rejected = sum(not compare_estimates(Estimate.from_seeds(gaussian(rng, image, 16, 8), BLOCKS, 8), exact, alpha,
                                         tolerance=0.0, block_tolerance=None).consistent for _ in range(trials))
    assert rejected <= binomial_bound(trials, alpha)


def test_a_three_percent_bias_is_found_and_signed():
    rng = np.random.default_rng(3)
    image = truth()
    reference = Estimate.from_seeds(gaussian(rng, image, 32, 64, sigma=0.5), BLOCKS, 64)
    for factor, sign in ((0.97, -1), (1.03, +1)):
        c = compare_estimates(Estimate.from_seeds(gaussian(rng, image, 32, 16, sigma=0.5, bias=factor), BLOCKS, 16),
                              reference, 1e-3)
        assert not c.consistent and c.where == "image"
        assert np.sign(c.z) == sign and c.direction == ("too bright" if sign > 0 else "too dark")
        assert c.bias == pytest.approx(factor - 1, abs=0.005)


def test_a_local_bias_is_found_where_it_is():
    rng = np.random.default_rng(4)
    image = truth()
    wrong = image.copy()
    wrong[8:16, 16:24] *= 1.3  # one block 30% too bright
    reference = Estimate.from_seeds(gaussian(rng, image, 32, 64), BLOCKS, 64)
    c = compare_estimates(Estimate.from_seeds(gaussian(rng, wrong, 32, 16), BLOCKS, 16), reference, 1e-3)
    assert not c.consistent
    assert c.worst_block == (1, 2)
    assert np.nanargmax(c.block_z) == 1 * 4 + 2 and c.block_bias[1, 2] == pytest.approx(0.3, abs=0.05)


def test_noisy_but_correct_passes_and_reports_its_variance():
    rng = np.random.default_rng(5)
    image = truth()
    reference = Estimate.from_seeds(gaussian(rng, image, 64, 16), BLOCKS, 16)
    noisy = Estimate.from_seeds(gaussian(rng, image, 32, 16, sigma=math.sqrt(300)), BLOCKS, 16)
    c = compare_estimates(noisy, reference, 1e-3)
    assert c.consistent
    assert 200 < c.variance_ratio < 450
    assert c.resolution > 0.01  # too noisy to see a bias of a few percent: it says so


def test_tolerance_allows_a_small_difference_only():
    rng = np.random.default_rng(6)
    image = truth()
    reference = Estimate.from_seeds(gaussian(rng, image, 64, 256, sigma=0.2), BLOCKS, 256)
    slightly = Estimate.from_seeds(gaussian(rng, image, 64, 256, sigma=0.2, bias=1.005), BLOCKS, 256)
    assert not compare_estimates(slightly, reference, 1e-3, tolerance=0.0, block_tolerance=None).consistent
    assert compare_estimates(slightly, reference, 1e-3, tolerance=0.01).consistent


def test_blocks_without_variance_must_agree_exactly():
    image = np.ones((H, W, 3))
    renders = np.repeat(image[None], 4, axis=0)
    reference = Estimate.from_seeds(renders, BLOCKS, 4)
    assert compare_estimates(Estimate.from_seeds(renders, BLOCKS, 4), reference).consistent
    brighter = renders.copy()
    brighter[:, :8, :8] *= 1.10
    c = compare_estimates(Estimate.from_seeds(brighter, BLOCKS, 4), reference)
    assert not c.consistent and c.z > 0


def test_pixel_variance_estimates_pool_their_degrees_of_freedom():
    """One render's per-pixel variances (one degree of freedom each) give a block variance with
    Satterthwaite's dof; the test keeps its level."""
    rng = np.random.default_rng(7)
    image = truth()
    alpha, trials, rejected = 0.05, 200, 0
    for _ in range(trials):
        def render(spp):
            a, b = gaussian(rng, image, 2, spp // 2)
            mean = (a + b) / 2
            var = (a - b) ** 2 / 4  # unbiased estimate of the variance of the mean, one dof
            mean4 = np.concatenate([mean, (mean @ [0.2126, 0.7152, 0.0722])[..., None]], -1)
            d = (a - b) @ [0.2126, 0.7152, 0.0722]
            var4 = np.concatenate([var, (d * d / 4)[..., None]], -1)
            return Estimate.from_pixel_variance(mean4, var4, BLOCKS, spp)
        rejected += not compare_estimates(render(32), render(128), alpha, tolerance=0.0, block_tolerance=None).consistent
    assert rejected <= binomial_bound(trials, alpha)


def test_estimates_on_different_pixels_are_refused():
    image = truth()
    masked = Blocks.grid(H, W, 8, mask=np.arange(H * W).reshape(H, W) % 2 == 0)
    with pytest.raises(ValueError):
        compare_estimates(Estimate.exact(image, BLOCKS), Estimate.exact(image, masked))


def test_rare_large_samples_missed_in_a_block_do_not_fail_a_correct_estimator():
    """A tenth of the light comes in rare samples (3 in 10,000 samples carry it): a block's
    seeds often miss them, and its mean and spread are both low. Alone, its t is far in a tail
    the t distribution does not have (a quarter of such trials rejected at alpha = 0.05); the
    moderated block variance keeps the test at its level."""
    rng = np.random.default_rng(8)
    image = truth()

    def render(seeds):
        hits = rng.binomial(16, 3e-4, (seeds, H, W, 1))
        return 0.9 * gaussian(rng, image, seeds, 16, sigma=0.3) + 0.1 * hits / (16 * 3e-4) * image

    alpha, trials = 0.05, 200
    rejected = sum(not compare_estimates(Estimate.from_seeds(render(16), BLOCKS, 16),
                                         Estimate.from_seeds(render(64), BLOCKS, 16), alpha, tolerance=0.0,
                                         block_tolerance=None).consistent for _ in range(trials))
    assert rejected <= binomial_bound(trials, alpha), f"{rejected} of {trials}"
