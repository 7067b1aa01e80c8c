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

Image assertions (the second half of this module) for tests: screenshot regression tests and grading plugins headless.

A pytest plugin (registered by lift-gl's `pytest11` entry point; or write
`pytest_plugins = ["lift_gl.testing"]` in a root conftest.py):

    from lift_gl import load_scene, Renderer
    from lift_gl.testing import assert_image_close

    def test_my_plugin_on_the_cornell_box(golden):
        image = Renderer(load_scene("scenes/cornell.toml"), size=(64, 64), integrator="mine").render(spp=64)
        assert_image_close(image, golden("cornell.exr"), relmse=0.02, ssim=0.9, flip=0.1)

- `golden(name)` is the path `golden/NAME` beside the test file.
- `pytest --update-golden` writes the image as the new golden (and passes); a missing golden
  fails with a message saying so.
- On failure, beside the golden: `NAME.actual.exr` (the image, linear), `NAME.actual.png`
  (tone-mapped) and `NAME.diff.png` (`NAME.LABEL.*` with label=) (FLIP's error map when flip= was asked for, else the
  per-pixel relative squared error); the message gives every metric and those paths.

Thresholds (any of them; relmse=0.01 when none is given): `relmse` the largest relMSE on
linear RGB (lift_gl.metrics.rel_mse), `ssim` the smallest SSIM and `flip` the largest mean
FLIP (NVIDIA's flip-evaluator, LDR), both on sRGB-encoded images clipped to [0, 1] as
lift_gl.metrics.ssim compares them. A golden of a higher resolution (an integer multiple) is
box-filtered down first. docs/grading.md says how to choose thresholds from render noise.
This module imports no GL and nothing heavy until a metric needs it.
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
                 plugin_dirs=(), check_dropped: bool = True, options=None) -> np.ndarray:
    """One independent render per seed: float64 (K, H, W, 3).

    One renderer (one compile) serves every seed. With `check_dropped`, a render that dropped
    a NaN/Inf sample fails: a correct estimator produces none. `options`: the renderer's
    (lift_gl/options.py Options; None: the defaults).
    """
    from .renderer import Renderer

    renderer = Renderer(scene, size=size, integrator=integrator, params=params, plugin_dirs=plugin_dirs,
                        options=options)
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


# ---- Image assertions: screenshot regression tests and grading ----
import pytest

from . import metrics
from .image_io import read_image, write_image

DEFAULT_RELMSE = 0.01
GOLDEN_DIR = "golden"
_state = {"update": False}  # set from the command line by pytest_configure


# ---- pytest plugin ----------------------------------------------------------------------------
def pytest_addoption(parser):
    try:
        parser.addoption("--update-golden", action="store_true", default=False,
                         help="lift_gl.testing: write rendered images as the new golden images")
    except ValueError:  # registered twice (entry point and pytest_plugins): the option exists
        pass


def pytest_configure(config):
    _state["update"] = bool(config.getoption("--update-golden", default=False))


@pytest.fixture
def golden(request):
    """golden(name) -> the path golden/NAME beside the test file."""
    folder = Path(request.path).parent / GOLDEN_DIR

    def path(name: str) -> Path:
        return folder / name
    return path


# ---- metrics ----------------------------------------------------------------------------------
def _display(image: np.ndarray) -> np.ndarray:
    from .tonemap import srgb_encode

    return np.clip(srgb_encode(image), 0.0, 1.0).astype(np.float32)


def flip_error(image, reference) -> tuple[float, np.ndarray]:
    """Mean LDR-FLIP error and its error map (magma, uint8 H x W x 3) on sRGB-encoded images."""
    try:
        import flip_evaluator
    except ImportError:
        raise ImportError("assert_image_close(flip=...) needs NVIDIA's FLIP: pip install flip-evaluator") from None
    error_map, mean, _ = flip_evaluator.evaluate(_display(reference), _display(image), "LDR", applyMagma=True)
    return float(mean), (np.clip(np.asarray(error_map), 0, 1) * 255).astype(np.uint8)


def image_metrics(image, reference, ssim: bool = True, flip: bool = False) -> dict:
    """relMSE (always), SSIM and mean FLIP (when asked) of image against reference."""
    out = {"relmse": metrics.rel_mse(image, reference)}
    if ssim:
        out["ssim"] = metrics.ssim(image, reference)
    if flip:
        out["flip"] = flip_error(image, reference)[0]
    return out


def _relative_error_map(image, reference) -> np.ndarray:
    """Per-pixel relMSE as a heat map: black 0, white at 0.1 or more (sqrt scale)."""
    err = ((image - reference) ** 2 / (reference ** 2 + metrics.REL_MSE_EPS)).mean(axis=-1)
    level = np.sqrt(np.clip(err / 0.1, 0.0, 1.0))
    return (np.stack([level, level ** 2, level ** 4], axis=-1) * 255).astype(np.uint8)


# ---- the assertion ----------------------------------------------------------------------------
def _as_image(value, what: str) -> np.ndarray:
    __tracebackhide__ = True
    image = read_image(value) if isinstance(value, (str, Path)) else np.asarray(value, dtype=np.float64)
    if image.ndim != 3 or image.shape[2] != 3:
        raise AssertionError(f"{what} must be an H x W x 3 image, not shape {image.shape}")
    return image.astype(np.float64)


def assert_image_close(image, golden, ssim: float | None = None, flip: float | None = None,
                       relmse: float | None = None, *, update: bool | None = None, label: str | None = None) -> dict:
    """Assert that `image` (H x W x 3 linear RGB, or a file) is close to the `golden` image
    file (or array: then nothing is written on failure or update). Returns the metrics.

    `update`: write `image` as the golden instead of comparing; None follows pytest's
    --update-golden. A grading test of students' images passes update=False, so that only
    the reference solution's test makes goldens. `label` goes into the names of the images
    saved on failure (NAME.LABEL.actual.png...), so that several submissions compared with
    one golden keep their own."""
    __tracebackhide__ = True  # pytest shows the caller's line, not this function's body
    image = _as_image(image, "the image")
    golden_path = Path(golden) if isinstance(golden, (str, Path)) else None
    if golden_path is not None and (_state["update"] if update is None else update):
        golden_path.parent.mkdir(parents=True, exist_ok=True)
        write_image(golden_path, image.astype(np.float32))
        return {}
    if golden_path is not None and not golden_path.is_file():
        raise AssertionError(f"golden image {golden_path} does not exist: run pytest with --update-golden "
                             "to write it from this image")
    reference = _as_image(golden if golden_path is None else golden_path, "the golden image")
    if reference.shape != image.shape:
        try:
            reference = metrics.resize_to(reference, image.shape[:2])
        except ValueError as exc:
            raise AssertionError(f"image {image.shape[:2]} and golden {reference.shape[:2]} differ in size: {exc}") from None
    if not np.isfinite(image).all():
        bad = int((~np.isfinite(image)).any(axis=-1).sum())
        failures = [f"{bad} pixels are NaN or infinite"]
        values = {}
    else:
        if ssim is None and flip is None and relmse is None:
            relmse = DEFAULT_RELMSE
        values = image_metrics(image, reference, ssim=ssim is not None, flip=flip is not None)
        failures = []
        if relmse is not None and not values["relmse"] <= relmse:
            failures.append(f"relMSE {values['relmse']:.5g} > {relmse:g}")
        if ssim is not None and not values["ssim"] >= ssim:
            failures.append(f"SSIM {values['ssim']:.5g} < {ssim:g}")
        if flip is not None and not values["flip"] <= flip:
            failures.append(f"FLIP {values['flip']:.5g} > {flip:g}")
    if not failures:
        return values
    message = "image differs from the golden image: " + "; ".join(failures)
    if golden_path is not None:
        saved = _save_failure(golden_path, image, reference, with_flip=flip is not None and values != {}, label=label)
        message += "\n  saved: " + ", ".join(str(p) for p in saved)
    message += "\n  metrics: " + ", ".join(f"{k} {v:.5g}" for k, v in values.items())
    raise AssertionError(message)


def _save_failure(golden_path: Path, image, reference, with_flip: bool, label: str | None) -> list[Path]:
    from .image_io import write_srgb8
    from .tonemap import to_srgb8

    stem = golden_path.parent / (golden_path.stem + (f".{label}" if label else ""))
    actual_exr, actual_png, diff_png = (Path(f"{stem}.actual.exr"), Path(f"{stem}.actual.png"), Path(f"{stem}.diff.png"))
    safe = np.nan_to_num(image, nan=0.0, posinf=0.0, neginf=0.0)
    write_image(actual_exr, image.astype(np.float32))
    write_srgb8(actual_png, to_srgb8(safe))
    diff = flip_error(safe, reference)[1] if with_flip else _relative_error_map(safe, reference)
    write_srgb8(diff_png, diff)
    return [actual_exr, actual_png, diff_png]


def require_opencl(module: bool = False) -> None:
    """Skip the calling test, with the reason, where OpenCL cannot run kernels (pyopencl missing,
    no device, or a PoCL whose LLVM does not know this CPU); `module`: at a test file's top."""
    import pytest

    pytest.importorskip("pyopencl", reason="OpenCL needs pip install 'lift-gl[opencl]'")
    from .opencl import unusable_reason

    reason = unusable_reason()
    if reason:
        pytest.skip(reason, allow_module_level=module)

