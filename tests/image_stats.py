"""Do two estimators converge to the same image? Statistics over independent renders.

Each estimator renders the same image K times with independent seeds; the K values of a
quantity (a block's mean luminance, the image's mean) give its standard error. For two
estimators, Welch's t = (mean_a - mean_b) / sqrt(se_a^2 + se_b^2), taken with K - 1 degrees of
freedom (Welch's own count lies between K - 1 and 2K - 2: the low end is the safe one, and
the right one when one estimator is much noisier than the other). Many runs of few samples
beat few runs of many: the same time buys more degrees of freedom. Under the hypothesis that both converge to the same image:
  - the whole image's mean differs by less than 3 standard errors;
  - no block's t exceeds the bound that a family of that many blocks exceeds by chance with
    probability FAMILY_ALPHA (Sidak), and
  - the blocks' mean t^2 stays under its own 1 - FAMILY_ALPHA bound (t^2 ~ F(1, dof), so its
    mean over m blocks has mean dof / (dof - 2) and a known variance): a small bias spread
    over many blocks shows up here even when no single block stands out.
"Every block within 3 standard errors" would fail by chance for a correct renderer in about
one run in seven at 16 blocks and 15 degrees of freedom, so the block bound is corrected for
their number; the count of blocks beyond 3 standard errors is reported alongside.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
FAMILY_ALPHA = 1e-3


def block_luminance(images: np.ndarray, block: int) -> np.ndarray:
    """(K, H, W, 3) -> (K, H/block, W/block) mean luminance of each block."""
    k, h, w, _ = images.shape
    lum = images.astype(np.float64) @ LUMINANCE
    return lum.reshape(k, h // block, block, w // block, block).mean(axis=(2, 4))


def welch_t(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """t statistics and standard errors of mean(a) - mean(b) along axis 0 (independent runs)."""
    se = np.sqrt(a.var(axis=0, ddof=1) / len(a) + b.var(axis=0, ddof=1) / len(b))
    return (a.mean(axis=0) - b.mean(axis=0)) / np.maximum(se, 1e-300), se


@dataclass
class Agreement:
    image_t: float
    block_t: np.ndarray
    dof: int

    @property
    def block_bound(self) -> float:
        m = self.block_t.size
        per_block = 1.0 - (1.0 - FAMILY_ALPHA) ** (1.0 / m)
        return float(stats.t.ppf(1.0 - per_block / 2.0, self.dof))

    @property
    def mean_t2_bound(self) -> float:
        v, m = self.dof, self.block_t.size
        mean = v / (v - 2.0)
        var = 2.0 * v * v * (v - 1.0) / ((v - 2.0) ** 2 * (v - 4.0))
        return mean + stats.norm.ppf(1.0 - FAMILY_ALPHA) * np.sqrt(var / m)

    def __str__(self) -> str:
        t = np.abs(self.block_t)
        return (f"image t = {self.image_t:.2f}; blocks: max |t| = {t.max():.2f} (bound {self.block_bound:.2f}), "
                f"mean t^2 = {np.mean(t ** 2):.2f} (bound {self.mean_t2_bound:.2f}), "
                f"{np.count_nonzero(t > 3)} of {t.size} beyond 3 standard errors; {self.dof} degrees of freedom")


def agreement(a: np.ndarray, b: np.ndarray, block: int = 8) -> Agreement:
    """a, b: (K, H, W, 3) independent renders of one image by two estimators."""
    image_t, _ = welch_t(a.astype(np.float64).reshape(len(a), -1, 3).mean(axis=1) @ LUMINANCE,
                         b.astype(np.float64).reshape(len(b), -1, 3).mean(axis=1) @ LUMINANCE)
    block_t, _ = welch_t(block_luminance(a, block), block_luminance(b, block))
    return Agreement(float(image_t), block_t.ravel(), min(len(a), len(b)) - 1)


def assert_same_image(a: np.ndarray, b: np.ndarray, block: int = 8, label: str = "") -> Agreement:
    result = agreement(a, b, block)
    message = f"{label}: {result}"
    assert abs(result.image_t) < 3.0, message
    assert np.abs(result.block_t).max() < result.block_bound, message
    assert np.mean(result.block_t ** 2) < result.mean_t2_bound, message
    return result
