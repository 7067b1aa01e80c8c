"""Pearson's chi-square test of samples against the density they claim, as Mitsuba 3's `chi2`
test does it, and the pieces it is made of (numpy; scipy only for the p-value).

Samples are counted on a grid of rectangles over a 2-D parameter domain: (x, y) for points,
(cos theta, phi) for directions (equal-area cells, where d(cos theta) d(phi) is solid
angle). A cell's expected count is N times the integral of the density over it, which
`adaptive_cell_integrals` computes to well within the cell's Poisson noise; cells expecting
fewer than MIN_EXPECTED samples are pooled before Pearson's statistic is taken.
"""
from __future__ import annotations

import math

import numpy as np

MIN_EXPECTED = 5.0
SPHERE_BOUNDS = ((-1.0, 1.0), (0.0, 2.0 * math.pi))  # (cos theta, phi)
CUBATURE_MAX_DEPTH = 10
# Each cell's integral is refined until it is within this fraction of a standard deviation
# of the cell's count (relative to N): its error then adds ~ NOISE_FRACTION^2 per cell to the
# statistic, far below the statistic's own spread.
NOISE_FRACTION = 0.1


def pearson_chi2(observed: np.ndarray, expected: np.ndarray,
                 min_expected: float = MIN_EXPECTED) -> tuple[float, int, float]:
    """(statistic, degrees of freedom, p-value) after pooling cells expecting < min_expected."""
    from scipy import stats

    observed, expected = np.asarray(observed, float).ravel(), np.asarray(expected, float).ravel()
    low = expected < min_expected
    obs = list(observed[~low])
    exp = list(expected[~low])
    pooled_obs, pooled_exp = observed[low].sum(), expected[low].sum()
    if pooled_exp >= min_expected:
        obs.append(pooled_obs)
        exp.append(pooled_exp)
    elif exp:  # too little to stand alone: merge into the smallest cell
        k = int(np.argmin(exp))
        obs[k] += pooled_obs
        exp[k] += pooled_exp
    obs, exp = np.array(obs), np.array(exp)
    statistic = float(np.sum((obs - exp) ** 2 / exp)) if len(exp) else 0.0
    dof = len(obs) - 1
    if dof < 1:
        return statistic, dof, 1.0
    return statistic, dof, float(stats.chi2.sf(statistic, dof))


def grid_rects(bounds, shape: tuple[int, int]) -> np.ndarray:
    """The cells of an na x nb grid over bounds ((a0, a1), (b0, b1)) as rectangles
    (a0, a1, b0, b1), float64 (na * nb, 4), row-major (a is the slow index)."""
    (a0, a1), (b0, b1) = bounds
    na, nb = shape
    i, j = np.meshgrid(np.arange(na), np.arange(nb), indexing="ij")
    i, j = i.ravel(), j.ravel()
    da, db = (a1 - a0) / na, (b1 - b0) / nb
    return np.stack([a0 + i * da, a0 + (i + 1) * da, b0 + j * db, b0 + (j + 1) * db], axis=1)


def grid_histogram(a: np.ndarray, b: np.ndarray, bounds, shape: tuple[int, int]) -> np.ndarray:
    """Counts (na, nb) of points (a, b) inside bounds; a point on the upper edge counts in
    the last cell."""
    (a0, a1), (b0, b1) = bounds
    na, nb = shape
    i = np.clip(((a - a0) / (a1 - a0) * na).astype(np.int64), 0, na - 1)
    j = np.clip(((b - b0) / (b1 - b0) * nb).astype(np.int64), 0, nb - 1)
    return np.bincount(i * nb + j, minlength=na * nb).reshape(na, nb).astype(np.float64)


def sphere_coordinates(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cos theta, phi in [0, 2 pi)) of directions (N, 3) about +z."""
    w = np.asarray(w, dtype=np.float64)
    return np.clip(w[:, 2], -1.0, 1.0), np.mod(np.arctan2(w[:, 1], w[:, 0]), 2.0 * math.pi)


def sphere_histogram(w: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Counts of directions on a (cos theta, phi) grid over the whole sphere."""
    return grid_histogram(*sphere_coordinates(w), SPHERE_BOUNDS, shape)


def split4(rects: np.ndarray) -> np.ndarray:
    """Each rectangle (a0, a1, b0, b1) -> its four quarters, consecutive."""
    a0, a1, b0, b1 = rects.T
    am, bm = 0.5 * (a0 + a1), 0.5 * (b0 + b1)
    quarters = [(a0, am, b0, bm), (a0, am, bm, b1), (am, a1, b0, bm), (am, a1, bm, b1)]
    return np.stack([np.stack(q, axis=1) for q in quarters], axis=1).reshape(-1, 4)


def adaptive_cell_integrals(integrate, rects: np.ndarray, count: int, max_depth: int = CUBATURE_MAX_DEPTH,
                            relative: float | None = None) -> tuple[np.ndarray, float]:
    """Integral of a density over each cell, by adaptive cubature: a rectangle is split in four
    until the quarters' sum agrees with the whole to within NOISE_FRACTION of the Poisson
    noise of the cell's count at `count` samples, like Mitsuba's adaptive Simpson (a glossy
    lobe can be far narrower than a cell). With `relative`, the estimated errors must also
    add up to at most that fraction of the total, whatever the sample count: each level
    shares what is left of that budget equally among the rectangles still open, so that a
    pdf's jump along a curve (where the open rectangles double, not quadruple, a level)
    converges.
    `integrate(rects)` returns one integral a rectangle (a fixed-order rule, e.g.
    Gauss-Legendre in a shader).

    Returns the integrals (one a cell, float64) and the sum over cells of |quarters - whole|
    at acceptance, an estimate of the total's quadrature error."""
    cell = np.arange(len(rects))
    whole = np.asarray(integrate(rects), dtype=np.float64)
    budget = None if relative is None else relative * float(np.abs(whole).sum())
    total = np.zeros(len(rects))
    error = 0.0
    for depth in range(max_depth):
        quarters = split4(rects)
        parts = np.asarray(integrate(quarters), dtype=np.float64).reshape(-1, 4)
        refined = parts.sum(axis=1)
        tolerance = NOISE_FRACTION * np.sqrt(np.maximum(refined * count, 1.0)) / count / 4.0 ** depth
        if budget is not None:
            tolerance = np.minimum(tolerance, max(budget - error, 0.0) / len(rects))
        difference = np.abs(refined - whole)
        done = (difference <= tolerance) | (depth == max_depth - 1)
        np.add.at(total, cell[done], refined[done])
        error += float(np.nansum(difference[done]))
        rects = quarters.reshape(-1, 4, 4)[~done].reshape(-1, 4)
        whole = parts[~done].ravel()
        cell = np.repeat(cell[~done], 4)
        if len(rects) == 0:
            break
    return total, error
