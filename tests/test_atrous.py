"""The à-trous filter (shaders/passes/atrous*.comp through lift_gl/denoise/atrous.py):
edge-stopping cannot invent structure, the variance of flat noise falls by the factor the
kernel weights give, and a depth or normal edge is not blurred across."""
import numpy as np
import pytest
from scipy.signal import fftconvolve

from lift_gl.denoise import get_denoiser
from lift_gl.passes.atrous import B3_SPLINE, AtrousSettings



def flat_guides(h, w):
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = 1.0
    return normal, np.ones((h, w), np.float32)


def atrous(**settings):
    return get_denoiser("atrous", settings=AtrousSettings(**settings))


def test_constant_irradiance_comes_back_unchanged_over_texture_and_edges():
    """A noise-free image of constant irradiance under a random albedo texture, with a depth
    and a normal edge: every weighted mean of equal values is that value, so the output is
    the input to float rounding, whatever the weights."""
    rng = np.random.default_rng(3)
    h, w = 48, 40
    albedo = rng.uniform(0.05, 0.95, (h, w, 3)).astype(np.float32)
    color = (albedo * np.float32(0.7)).astype(np.float32)
    normal, depth = flat_guides(h, w)
    normal[:, w // 2:] = [1.0, 0.0, 0.0]
    depth[h // 2:] = 3.0
    denoiser = atrous()
    for variance in (np.zeros((h, w), np.float32), None):  # given, or estimated spatially
        out = denoiser.denoise(color, albedo, normal, depth, variance)
        np.testing.assert_allclose(out, color, rtol=1e-6, atol=0)


def equivalent_kernel(iterations: int) -> np.ndarray:
    """The linear filter the iterations make on flat guides without luminance stopping: the
    B3 kernel with holes of 2^i - 1 pixels, convolved over the iterations (2D, separable)."""
    kernel = np.array([1.0])
    for i in range(iterations):
        spread = np.zeros(4 * 2 ** i + 1)
        spread[:: 2 ** i] = B3_SPLINE
        kernel = np.convolve(kernel, spread)
    return np.outer(kernel, kernel)


def test_flat_noise_variance_falls_by_the_kernel_factor():
    """White noise of variance s^2 through the linear filter K has variance s^2 sum(K^2).
    The tolerance is the sampling error of a variance measured over correlated pixels:
    Var(s^2_hat) = 2 s^4 sum_lag rho(lag)^2 / N, rho the normalised autocorrelation of K."""
    iterations = 4
    kernel = equivalent_kernel(iterations)
    radius = kernel.shape[0] // 2
    factor = float((kernel ** 2).sum())
    rho = fftconvolve(kernel, kernel[::-1, ::-1]) / factor
    h = w = 2 * radius + 100  # an interior of 100 x 100 pixels that no border reaches
    sigma = 0.1
    rng = np.random.default_rng(7)
    denoiser = atrous(iterations=iterations, sigma_luminance=0.0)
    normal, depth = flat_guides(h, w)
    albedo = np.ones((h, w, 3), np.float32)
    ratios = []
    images = 4
    for _ in range(images):
        color = (0.5 + sigma * rng.standard_normal((h, w, 3))).astype(np.float32)
        out = denoiser.denoise(color, albedo, normal, depth)
        interior = out[radius:h - radius, radius:w - radius] - 0.5
        ratios.append(float((interior ** 2).mean()) / sigma ** 2)
    measured = float(np.mean(ratios))
    n = images * 3 * 100 * 100  # channels are independent
    std = factor * np.sqrt(2.0 * float((rho ** 2).sum()) / n)
    assert abs(measured - factor) < 4 * std, (measured, factor, std)
    assert factor < 1 / 400  # what 4 iterations buy: more than 400x less variance


def test_luminance_stopping_still_lowers_flat_noise():
    """With SVGF's luminance stopping on the (spatially estimated) variance the filter is no
    longer linear; it must still lower the variance of flat noise, by less than the linear
    filter (it gives up some smoothing to keep edges)."""
    h = w = 96
    rng = np.random.default_rng(11)
    color = (0.5 + 0.1 * rng.standard_normal((h, w, 3))).astype(np.float32)
    normal, depth = flat_guides(h, w)
    out = atrous(iterations=4).denoise(color, np.ones_like(color), normal, depth)
    ratio = float(((out - 0.5) ** 2).mean() / ((color - 0.5) ** 2).mean())
    assert equivalent_kernel(4).__pow__(2).sum() * 0.5 < ratio < 0.2, ratio


def edge_image(jump: str):
    """Left half irradiance 0.2, right half 1.0, noisy; the halves differ in normal or depth."""
    h, w = 64, 64
    rng = np.random.default_rng(5)
    truth = np.where(np.arange(w)[None, :, None] < w // 2, 0.2, 1.0) * np.ones((h, w, 3))
    color = (truth + 0.05 * rng.standard_normal((h, w, 3))).astype(np.float32)
    normal, depth = flat_guides(h, w)
    if jump == "normal":
        normal[:, w // 2:] = [1.0, 0.0, 0.0]
    else:
        depth[:, w // 2:] = 2.0
    return color, normal, depth


def leak(out) -> float:
    """Fraction of the right half's value found in the 4 columns left of the edge."""
    return float((out[:, 28:32].mean() - 0.2) / 0.8)


@pytest.mark.parametrize("jump", ["normal", "depth"])
def test_no_blur_across_a_geometric_edge(jump):
    """Each geometric guide alone (luminance stopping off) keeps the edge; without the guides
    the same filter spreads the right half over the left (the test can see blur)."""
    color, normal, depth = edge_image(jump)
    albedo = np.ones_like(color)
    guided = atrous(sigma_luminance=0.0, sigma_normal=128.0 if jump == "normal" else 0.0,
                    sigma_depth=1.0 if jump == "depth" else 0.0).denoise(color, albedo, normal, depth)
    blind = atrous(sigma_luminance=0.0, sigma_normal=0.0, sigma_depth=0.0).denoise(color, albedo, normal, depth)
    assert leak(blind) > 0.15, leak(blind)
    # Noise alone: the 4 x 64 x 3 pixels' mean has std 0.05 / sqrt(768) / 0.8 before filtering.
    assert abs(leak(guided)) < 0.01, leak(guided)
    assert abs(leak(atrous().denoise(color, albedo, normal, depth))) < 0.01  # SVGF's defaults


def test_denoiser_inputs_are_checked():
    h, w = 8, 8
    good = np.ones((h, w, 3), np.float32)
    with pytest.raises(ValueError, match="albedo"):
        get_denoiser("atrous").denoise(good, np.ones((h, w + 1, 3)), good)
    with pytest.raises(ValueError, match="iterations"):
        AtrousSettings(iterations=0)


def test_normals_shorter_than_one_give_the_unit_normals_image():
    """Another renderer's normal AOV (Mitsuba's, averaged over a pixel's samples) is shorter
    than 1 at edges: (0.7^2)^128 underflowed every tap's weight to 0, and 0 / 0 made the
    whole image NaN in five iterations. The filter takes the guides' directions."""
    rng = np.random.default_rng(5)
    h, w = 32, 32
    albedo = np.full((h, w, 3), 0.5, np.float32)
    color = (albedo * rng.gamma(2.0, 0.5, (h, w, 1))).astype(np.float32)
    normal, depth = flat_guides(h, w)
    normal[:, w // 2:] = [1.0, 0.0, 0.0]
    normal[0, 0] = 0.0  # no surface: stays none
    short = normal * np.float32(0.7)
    denoiser = atrous()
    want = denoiser.denoise(color, albedo, normal, depth)
    got = denoiser.denoise(color, albedo, short, depth)
    assert np.isfinite(got).all() and np.abs(want - color).max() > 0.05  # it did filter
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)
