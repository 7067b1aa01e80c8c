"""Subpixel positions drawn from the scene's pixel filter (filter importance sampling).

A pixel of a render is the film's image box-averaged to the render's size: each film pixel
weighs the scene by the film's filter (pbrt's `PixelFilter`, Mitsuba's `rfilter`) around its
centre, in the film's own pixels, and a rendered pixel averages the m x m film pixels it
covers (m = film size / render size, rounded, at least 1). So a rendered pixel's kernel is
the filter, scaled to rendered pixels, summed over those m film-pixel centres. At the film's
own size that is the filter itself; at 1/8 of it, a pbrt triangle filter of radius 1 becomes
a box over the pixel with ramps 1/8 of a pixel wide at its edges, which is what a reference
rendered at the film's size and box-downsampled shows at edges.

Every filter here is separable and non-negative, so each frame's subpixel offset (a Halton
point, lift_gl/passes/camera.py) goes through the inverse cumulative distribution of the
kernel's profile along each axis: a sample's position then has the kernel's density and an
unweighted mean over samples converges to the filtered image. Samples may land outside their
pixel's square (the filter's support is wider than a pixel); the G-buffer's projection shift
and the camera rays take any offset.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..scene.model import PixelFilter

TABLE_POINTS = 4097  # the kernel is tabulated this finely
KNOTS = 129  # its CDF per axis at this many offsets, inverted linearly (shaders/lift/pixel_filter.glsl)
# Film pixels a rendered pixel sums one by one; beyond, their limit (a film of 1e12 pixels
# rendered at 8x8 costs what 256 film pixels a pixel cost).
MAX_FILM_CENTRES = 256


def filter_profile(pixel_filter: PixelFilter, axis: int, x: np.ndarray) -> np.ndarray:
    """The filter's weight along one axis at `x` film pixels from the pixel's centre."""
    radius = float(pixel_filter.radius[axis])
    x = np.abs(x)
    if pixel_filter.kind == "box":
        return (x <= radius).astype(np.float64)
    if pixel_filter.kind == "triangle":
        return np.maximum(0.0, 1.0 - x / radius)
    if pixel_filter.kind == "gaussian":
        alpha = pixel_filter.alpha
        return np.where(x <= radius, np.maximum(0.0, np.exp(-alpha * x * x) - np.exp(-alpha * radius * radius)), 0.0)
    raise ValueError(f"unknown pixel filter kind {pixel_filter.kind!r}")


def pixel_kernel(pixel_filter: PixelFilter, axis: int, film_pixels: int, render_pixels: int):
    """(x, density) of a rendered pixel's kernel along one axis, x in rendered pixels (the
    pixel spans [0, 1)); the density integrates to 1.

    The work is bounded whatever the film's size: past MAX_FILM_CENTRES film pixels a rendered
    pixel, the sum over film-pixel centres is replaced by its limit, the filter averaged over
    the whole pixel (a box convolved with the filter): at the switch, sampled positions move
    by at most 0.0025 of a rendered pixel (tests/test_pixel_filter.py measures it)."""
    per_render_pixel = film_pixels / render_pixels   # film pixels per rendered pixel
    covered = max(1, round(per_render_pixel))          # film pixels a rendered pixel averages
    film_pixel = 1.0 / per_render_pixel                # a film pixel, in rendered pixels
    radius = float(pixel_filter.radius[axis]) * film_pixel
    if covered > MAX_FILM_CENTRES:
        x = np.linspace(-radius, 1.0 + radius, TABLE_POINTS)
        density = _box_convolved(pixel_filter, axis, x, film_pixel)
    else:
        centres = (np.arange(covered) + 0.5) / covered
        x = np.linspace(centres[0] - radius, centres[-1] + radius, TABLE_POINTS)
        density = sum(filter_profile(pixel_filter, axis, (x - c) / film_pixel) for c in centres)
    total = np.sum((density[1:] + density[:-1]) * 0.5 * np.diff(x))
    if not total > 0:
        raise ValueError(f"pixel filter {pixel_filter} has no weight")
    return x, density / total


def _box_convolved(pixel_filter: PixelFilter, axis: int, x: np.ndarray, film_pixel: float) -> np.ndarray:
    """The filter (scaled to `film_pixel` rendered pixels) averaged over the centres c in
    [0, 1): F((x - 0) / film_pixel) - F((x - 1) / film_pixel), F the filter's antiderivative,
    tabulated over its support in film pixels."""
    radius = float(pixel_filter.radius[axis])
    u = np.linspace(-radius, radius, TABLE_POINTS)
    profile = filter_profile(pixel_filter, axis, u)
    antiderivative = np.concatenate([[0.0], np.cumsum((profile[1:] + profile[:-1]) * 0.5 * np.diff(u))])
    return np.interp(x / film_pixel, u, antiderivative) - np.interp((x - 1.0) / film_pixel, u, antiderivative)


@lru_cache(maxsize=16)
def cdf_knots(pixel_filter: PixelFilter, film_size: tuple[int, int], size: tuple[int, int]):
    """Per axis, the kernel's cumulative distribution at KNOTS evenly spaced offsets (rendered
    pixels) spanning its support: ((cdf, start, step), (cdf, start, step)). Host and shaders
    invert these same knots (linearly between them: a density constant over each of the
    KNOTS - 1 intervals, each holding exactly its mass), so the G-buffer's jitter and traced
    camera rays sample one distribution."""
    axes = []
    for axis in (0, 1):
        x, density = pixel_kernel(pixel_filter, axis, film_size[axis], size[axis])
        cdf = np.concatenate([[0.0], np.cumsum((density[1:] + density[:-1]) * 0.5 * np.diff(x))])
        at = np.linspace(x[0], x[-1], KNOTS)
        knots = np.interp(at, x, cdf / cdf[-1])
        knots.flags.writeable = False
        axes.append((knots, float(x[0]), float(at[1] - at[0])))
    return tuple(axes)


def filtered_jitter(jitter: tuple[float, float], pixel_filter: PixelFilter | None,
                    film_size: tuple[int, int], size: tuple[int, int]) -> tuple[float, float]:
    """A frame's subpixel offset (uniform in [0, 1)^2) moved to the pixel filter's density;
    unchanged without a filter (a box over the rendered pixel)."""
    if pixel_filter is None:
        return jitter
    out = []
    for u, (cdf, start, step) in zip(jitter, cdf_knots(pixel_filter, tuple(film_size), tuple(size))):
        out.append(float(np.interp(u, cdf, start + step * np.arange(KNOTS))))
    return tuple(out)


def filter_uniforms(pixel_filter: PixelFilter | None, film_size: tuple[int, int], size: tuple[int, int]) -> dict:
    """The knots for shaders/lift/pixel_filter.glsl (traced camera rays); none without a filter."""
    if pixel_filter is None:
        return {}
    (cx, x0, dx), (cy, y0, dy) = cdf_knots(pixel_filter, tuple(film_size), tuple(size))
    return {"u_filter_cdf_x": cx.astype(np.float32), "u_filter_cdf_y": cy.astype(np.float32),
            "u_filter_span": (x0, dx, y0, dy)}
