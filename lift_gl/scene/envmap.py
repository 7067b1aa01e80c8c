"""Latitude-longitude environment maps: the direction <-> image mapping and the piecewise
constant 2D distribution that importance-samples them (shaders/lift/lights.glsl).

Mapping (Mitsuba's; pbrt's maps are converted by their loader): a unit direction d in the
map's frame has u = atan2(d.x, -d.z) / 2pi in [0, 1) and v = acos(d.y) / pi; the image's
row 0 is v = 0 (the +y pole). Radiance is the bilinear interpolation of texel centres at
((x + .5) / W, (y + .5) / H), repeating in u and clamped in v.

Sampling: the image's cells (texels) get probabilities proportional to their mean
luminance over the cell (the bilinear function integrated over the texel, i.e. the
luminance blurred by [1/8, 3/4, 1/8] along each axis, so a cell is never 0 where the
radiance is not) times sin(theta) at the cell's centre (cells shrink towards the poles).
A row is chosen from the marginal distribution, a column from that row's conditional one,
then a point uniformly in the cell: the solid-angle pdf is
    pdf(u, v) / (2 pi^2 sin(theta)),   pdf(u, v) = marginal_pdf[y] * conditional_pdf[y, x].

Search guides: a row or column is found by a binary search of its cdf, started from a guide
table (the cutpoint method, Chen and Asau 1974): for each of n equal buckets of u, the first and
last cell any u in the bucket can land in (search_guides). The search between them finds the
same cell as one over the whole cdf, in a step or two instead of log2(n) dependent reads (the
dining room's and classroom's 512x256 sky: 9 and 8), so the samples, and the images, are the same.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..limits import MAX_ENVIRONMENT_SIDE

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def direction_to_uv(d: np.ndarray) -> np.ndarray:
    """(..., 3) directions in the map's frame -> (..., 2) texture coordinates (u, v)."""
    d = np.asarray(d, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    u = np.mod(np.arctan2(d[..., 0], -d[..., 2]) / (2 * np.pi), 1.0)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return np.stack([u, v], axis=-1)


def uv_to_direction(uv: np.ndarray) -> np.ndarray:
    """Inverse of direction_to_uv: (..., 2) -> (..., 3) unit directions in the map's frame."""
    uv = np.asarray(uv, dtype=np.float64)
    phi, theta = 2 * np.pi * uv[..., 0], np.pi * uv[..., 1]
    s = np.sin(theta)
    return np.stack([s * np.sin(phi), np.cos(theta), -s * np.cos(phi)], axis=-1)


def bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """The radiance the shader returns at (..., 2) texture coordinates: bilinear between
    texel centres, repeating in u, clamped in v."""
    h, w = image.shape[:2]
    x = np.asarray(uv[..., 0], dtype=np.float64) * w - 0.5
    y = np.asarray(uv[..., 1], dtype=np.float64) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)
    xa, xb = np.mod(x0, w), np.mod(x0 + 1, w)
    ya, yb = np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)
    img = image.astype(np.float64)
    top = img[ya, xa] * (1 - fx) + img[ya, xb] * fx
    bottom = img[yb, xa] * (1 - fx) + img[yb, xb] * fx
    return top * (1 - fy) + bottom * fy


def cell_weights(image: np.ndarray) -> np.ndarray:
    """(H, W) unnormalised probabilities of the cells, as the module docstring says."""
    lum = np.maximum(image.astype(np.float64) @ LUMINANCE, 0.0)
    h, w = lum.shape
    # The mean of the bilinear function over a texel: [1/8, 3/4, 1/8] along each axis.
    lum = 0.75 * lum + 0.125 * (np.roll(lum, 1, axis=1) + np.roll(lum, -1, axis=1))
    up = np.concatenate([lum[:1], lum[:-1]])
    down = np.concatenate([lum[1:], lum[-1:]])
    lum = 0.75 * lum + 0.125 * (up + down)
    sin_theta = np.sin(np.pi * (np.arange(h) + 0.5) / h)
    return lum * sin_theta[:, None]


@dataclass
class EnvDistribution:
    """Densities over [0, 1] (mean 1) and their cumulative sums, as the shader reads them."""

    marginal_pdf: np.ndarray  # (H,)  density of v, constant over each row
    marginal_cdf: np.ndarray  # (H + 1,), 0 ... 1
    conditional_pdf: np.ndarray  # (H, W) density of u given the row
    conditional_cdf: np.ndarray  # (H, W + 1)

    def pdf_uv(self, uv: np.ndarray) -> np.ndarray:
        h, w = self.conditional_pdf.shape
        x = np.clip((uv[..., 0] * w).astype(np.int64), 0, w - 1)
        y = np.clip((uv[..., 1] * h).astype(np.int64), 0, h - 1)
        return self.marginal_pdf[y] * self.conditional_pdf[y, x]

    def cell_probabilities(self) -> np.ndarray:
        h, w = self.conditional_pdf.shape
        return self.marginal_pdf[:, None] * self.conditional_pdf / (h * w)


def _density_and_cdf(weights: np.ndarray):
    """Along the last axis: density (mean 1 over [0, 1]) and cdf (first 0, last exactly 1).
    An all-zero row becomes uniform, so that every row can be sampled safely."""
    n = weights.shape[-1]
    total = weights.sum(axis=-1, keepdims=True)
    uniform = np.full_like(weights, 1.0 / n)
    p = np.divide(weights, total, out=uniform, where=total > 0)
    cdf = np.concatenate([np.zeros(p.shape[:-1] + (1,)), np.cumsum(p, axis=-1)], axis=-1)
    cdf[..., -1] = 1.0
    return p * n, cdf


# A guide word packs its bucket's first cell (low 16 bits) and how many more it may need.
GUIDE_MAX_CELLS = MAX_ENVIRONMENT_SIDE  # a guide word holds two 16-bit cell numbers


def search_cdf(cdf: np.ndarray, u) -> np.ndarray:
    """The shader's search (lights.glsl env_search_cdf) of one cdf (n + 1 values, float32 as
    stored): the last i in [0, n - 1] with cdf[i] <= u."""
    cdf = np.asarray(cdf, dtype=np.float32).astype(np.float64)
    return np.clip(np.searchsorted(cdf[:-1], np.asarray(u, dtype=np.float64), side="right") - 1, 0, len(cdf) - 2)


def search_guides(cdfs: np.ndarray) -> np.ndarray:
    """Guide words for cdfs of shape (..., n + 1) (float32 as stored): (..., n) uint32, word k for
    the u whose bucket min(uint(u * n), n - 1) (float32, as the shader computes it) is k: its
    first possible cell lo | (last - lo) << 16. The bucket's edges are widened by 1e-6 of
    themselves, over the 6e-8 by which float32's u * n can round across them, so every u of the
    bucket finds its cell between the two."""
    cdfs = np.asarray(cdfs, dtype=np.float32)
    n = cdfs.shape[-1] - 1
    if n > GUIDE_MAX_CELLS:
        raise ValueError(f"environment map side of {n} texels: at most {GUIDE_MAX_CELLS} (16-bit guide words)")
    k = np.arange(n, dtype=np.float64)
    u_low = np.maximum(k / n * (1 - 1e-6), 0.0)
    u_high = np.minimum((k + 1) / n * (1 + 1e-6), 1.0)
    rows = cdfs.reshape(-1, n + 1)
    lo = np.empty((len(rows), n), np.int64)
    hi = np.empty((len(rows), n), np.int64)
    for r, cdf in enumerate(rows):   # one searchsorted per row: H calls, vectorised within a row
        lo[r] = search_cdf(cdf, u_low)
        hi[r] = search_cdf(cdf, u_high)
    return (lo | ((hi - lo) << 16)).astype(np.uint32).reshape(cdfs.shape[:-1] + (n,))


def build_distribution(image: np.ndarray) -> EnvDistribution:
    weights = cell_weights(image)
    conditional_pdf, conditional_cdf = _density_and_cdf(weights)
    marginal_pdf, marginal_cdf = _density_and_cdf(weights.sum(axis=1))
    return EnvDistribution(marginal_pdf, marginal_cdf, conditional_pdf, conditional_cdf)


def solid_angle_pdf(dist: EnvDistribution, d_map: np.ndarray) -> np.ndarray:
    """Solid-angle density of the sampler at directions in the map's frame."""
    d = np.asarray(d_map, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    sin_theta = np.sqrt(np.maximum(0.0, 1.0 - d[..., 1] ** 2))
    pdf = dist.pdf_uv(direction_to_uv(d))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sin_theta > 0, pdf / (2 * np.pi ** 2 * sin_theta), 0.0)


def mean_radiance(env_image: np.ndarray) -> np.ndarray:
    """Solid-angle average of the map's texels (rows weighted by their solid angle)."""
    h = env_image.shape[0]
    theta0 = np.pi * np.arange(h) / h
    row_solid_angle = np.cos(theta0) - np.cos(theta0 + np.pi / h)
    rows = env_image.astype(np.float64).mean(axis=1)
    return (rows * row_solid_angle[:, None]).sum(axis=0) / row_solid_angle.sum()
