"""Statistical checks for integrator plugins: the tests `lift-gl new-plugin` writes use these,
and so do lift-gl's own tests.

A Monte Carlo image is a random variable. Two integrators agree when their expected images
are the same; that is tested from K independent renders of each (one per seed): the mean of
a block of pixels over the K renders, its standard error from the spread of the K values,
and a Welch t test per block and channel, Bonferroni-corrected so that the whole image
fails by chance with probability `p` at most.

    images_a = render_seeds(scene, "mine", seeds=range(1, 9), spp=16, size=(32, 32))
    images_b = render_seeds(scene, "pt", seeds=range(101, 109), spp=16, size=(32, 32))
    assert_same_expectation(images_a, images_b)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
CORNELL = REPO_ROOT / "scenes" / "cornell.toml"


def furnace_scene(albedo: float = 0.8, radiance: float = 1.0, size=(32, 32)):
    """A diffuse sphere that fills the whole view, under a constant sky.

    Light that leaves a convex object never comes back to it, so every pixel of a correct
    (unbiased) integrator converges to albedo * radiance, whatever its path length >= 1.
    """
    from .scene import Camera, Environment, Material, Scene, Sphere

    # Seen from 3 radii away the sphere spans +-19.5 degrees; a 20 degree field of view sees
    # only the sphere.
    camera = Camera(position=[0.0, 0.0, 3.0], target=[0.0, 0.0, 0.0], fov_deg=20.0)
    material = Material("grey", "diffuse", base_color=[albedo] * 3)
    return Scene(camera=camera, materials=[material], spheres=[Sphere([0.0, 0.0, 0.0], 1.0, 0)],
                 environment=Environment([radiance] * 3), film_size=tuple(size))


def cornell_scene():
    """The shipped Cornell box (diffuse walls, an area light, a glass sphere, a rough gold box)."""
    from .scene.loader import load_scene

    return load_scene(CORNELL)


def render_seeds(scene, integrator: str, seeds, spp: int, size=(32, 32), params: dict | None = None,
                 plugin_dirs=(), check_dropped: bool = True) -> np.ndarray:
    """One independent render per seed: float64 (K, H, W, 3).

    One renderer (one compile) serves every seed. With `check_dropped`, a render that dropped
    a NaN/Inf sample fails: a correct estimator produces none.
    """
    from .renderer import Renderer

    renderer = Renderer(scene, size=size, integrator=integrator, params=params, plugin_dirs=plugin_dirs)
    images = []
    try:
        for seed in seeds:
            renderer.reset(seed=seed)
            images.append(renderer.render(spp=spp).astype(np.float64))
            if check_dropped:
                assert renderer.stats.dropped_samples == 0, (
                    f"{integrator} (seed {seed}) returned {renderer.stats.dropped_samples} NaN/Inf samples")
    finally:
        renderer.release()
    return np.array(images)


def block_means(images: np.ndarray, block: int) -> np.ndarray:
    """(K, H, W, C) -> (K, H // block, W // block, C): the mean of each block x block tile."""
    k, h, w, c = images.shape
    h, w = h - h % block, w - w % block
    tiles = images[:, :h, :w].reshape(k, h // block, block, w // block, block, c)
    return tiles.mean(axis=(2, 4))


def welch(a: np.ndarray, b: np.ndarray):
    """Welch's t statistic and degrees of freedom of mean(a) - mean(b) along axis 0."""
    na, nb = len(a), len(b)
    va, vb = a.var(axis=0, ddof=1) / na, b.var(axis=0, ddof=1) / nb
    se2 = va + vb
    diff = a.mean(axis=0) - b.mean(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = diff / np.sqrt(se2)
        df = se2 ** 2 / (va ** 2 / (na - 1) + vb ** 2 / (nb - 1))
    return t, df, diff, np.sqrt(se2)


def _with_whole_image(images: np.ndarray, block: int) -> np.ndarray:
    """(K, H, W, C) -> (K, B + 1, C): the B block means, then the mean of the whole image."""
    blocks = block_means(images, block)
    k, c = blocks.shape[0], blocks.shape[-1]
    return np.concatenate([blocks.reshape(k, -1, c), images.mean(axis=(1, 2)).reshape(k, 1, c)], axis=1)


def assert_same_expectation(images_a: np.ndarray, images_b: np.ndarray, block: int = 8, p: float = 1e-3) -> None:
    """Both stacks of independent renders, (K, H, W, C) each, estimate the same image.

    Per block and channel, and for the whole image: Welch's t against the t distribution's
    two-sided critical value at level p / (number of tests). The whole image is a test of its
    own because a small bias spread over every pixel (energy lost at each bounce) shows in
    the image mean long before it shows in any block. Blocks where neither estimator varies
    (only background or emitters seen) must match to float precision.
    """
    from scipy import stats

    a, b = _with_whole_image(images_a, block), _with_whole_image(images_b, block)
    t, df, diff, se = welch(a, b)
    exact = se == 0
    assert np.all(np.abs(diff[exact]) <= 1e-5 * np.maximum(1.0, np.abs(a.mean(0)[exact]))), \
        "blocks without noise differ"
    critical = stats.t.ppf(1.0 - p / (2 * t.size), np.where(exact, 1e6, df))
    ratio = np.where(exact, 0.0, np.abs(t) / critical)
    worst = np.unravel_index(int(np.argmax(ratio)), t.shape)
    if ratio[worst] <= 1.0:
        return
    per_row = images_a.shape[2] // block
    index, channel = int(worst[0]), int(worst[1])
    where = ("the whole image" if index == a.shape[1] - 1
             else f"block (row {index // per_row}, column {index % per_row}) of {block}x{block} pixels")
    raise AssertionError(
        f"{where}, channel {channel}: means {a.mean(0)[worst]:.4g} vs {b.mean(0)[worst]:.4g} differ by "
        f"{t[worst]:.2f} standard errors; the critical value for p = {p} over {t.size} tests is "
        f"{critical[worst]:.2f}")


def assert_mean_is(values: np.ndarray, expected: float, sigmas: float = 4.0) -> None:
    """Independent estimates (pixels of one render, or renders) average to `expected`
    within `sigmas` standard errors of their mean; a noiseless estimator must be exact."""
    residual = np.asarray(values, np.float64).ravel() - expected
    standard_error = residual.std(ddof=1) / np.sqrt(residual.size)
    tolerance = max(sigmas * standard_error, 1e-6 * max(1.0, abs(expected)))
    assert abs(residual.mean()) <= tolerance, (
        f"mean {residual.mean() + expected:.5g}, expected {expected:.5g}: "
        f"{abs(residual.mean()) / max(standard_error, 1e-30):.1f} standard errors off")
