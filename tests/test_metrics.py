"""Error metrics on tiny arrays with values worked out by hand."""
import numpy as np
import pytest

from lift_gl.metrics import (
    box_downsample,
    dssim,
    finite_fraction,
    mse,
    rel_mse,
    resize_to,
    rmse,
    ssim,
)
from lift_gl.tonemap import srgb_encode

# A 2x2 grey reference: pixel values 0, 1, 2, 0.5 (all three channels equal).
REF = np.repeat(np.array([[0.0, 1.0], [2.0, 0.5]], dtype=np.float32)[..., None], 3, axis=2)


def test_identity_gives_zero_error():
    assert mse(REF, REF) == 0.0
    assert rmse(REF, REF) == 0.0
    assert rel_mse(REF, REF) == 0.0


def test_known_offset():
    img = REF + np.float32(0.1)
    assert mse(img, REF) == pytest.approx(0.01, rel=1e-5)
    assert rmse(img, REF) == pytest.approx(0.1, rel=1e-5)
    # (x - ref)^2 = 0.01 everywhere; denominators ref^2 + 0.01 = 0.01, 1.01, 4.01, 0.26
    expected = (0.01 / 0.01 + 0.01 / 1.01 + 0.01 / 4.01 + 0.01 / 0.26) / 4
    assert rel_mse(img, REF) == pytest.approx(expected, rel=1e-5)
    assert expected == pytest.approx(0.26271407, rel=1e-6)


def test_rel_mse_eps_and_single_pixel():
    assert rel_mse([[[2.0, 2.0, 2.0]]], [[[1.0, 1.0, 1.0]]]) == pytest.approx(1 / 1.01)
    assert rel_mse([[[2.0, 2.0, 2.0]]], [[[1.0, 1.0, 1.0]]], eps=1.0) == pytest.approx(0.5)
    # Only one channel off by 3 on a black reference: mean over channels of (9/0.01, 0, 0).
    assert rel_mse([[[3.0, 0.0, 0.0]]], [[[0.0, 0.0, 0.0]]]) == pytest.approx(300.0)


def test_shape_mismatch_is_an_error():
    with pytest.raises(ValueError, match="shape"):
        mse(np.zeros((2, 2, 3)), np.zeros((4, 4, 3)))


def _noise(seed, shape=(16, 16, 3)):
    return np.random.default_rng(seed).random(shape, dtype=np.float32)


def test_ssim_identity_is_one():
    img = _noise(0)
    assert ssim(img, img) == pytest.approx(1.0)
    assert dssim(img, img) == pytest.approx(0.0, abs=1e-12)


def test_ssim_matches_skimage_on_srgb_clipped_values():
    from skimage.metrics import structural_similarity

    img, ref = _noise(1) * 1.5, _noise(2)
    enc = lambda a: np.clip(srgb_encode(a).astype(np.float64), 0, 1)  # noqa: E731
    expected = structural_similarity(enc(img), enc(ref), channel_axis=-1, data_range=1.0)
    assert ssim(img, ref) == pytest.approx(expected)
    assert ssim(img, ref) < 0.9
    assert dssim(img, ref) == pytest.approx(1 / expected - 1)


def test_ssim_clips_above_one():
    # Both images are above 1 everywhere, so both clip to white: identical for SSIM.
    assert ssim(_noise(3) + 1.0, _noise(4) + 2.0) == pytest.approx(1.0)


def test_finite_fraction():
    assert finite_fraction([1.0, np.nan, np.inf, 2.0]) == 0.5
    assert finite_fraction(REF) == 1.0
    assert finite_fraction(np.full((2, 2, 3), -np.inf)) == 0.0


def test_box_downsample_by_hand():
    img = np.arange(16, dtype=np.float32).reshape(4, 4)
    # Blocks {0,1,4,5}, {2,3,6,7}, {8,9,12,13}, {10,11,14,15}
    np.testing.assert_array_equal(box_downsample(img, 2), [[2.5, 4.5], [10.5, 12.5]])
    np.testing.assert_array_equal(box_downsample(img, 4), [[7.5]])
    np.testing.assert_array_equal(box_downsample(img, 1), img)
    rgb = np.repeat(img[..., None], 3, axis=2)
    out = box_downsample(rgb, 2)
    assert out.shape == (2, 2, 3) and out.dtype == np.float32
    np.testing.assert_array_equal(out[..., 2], [[2.5, 4.5], [10.5, 12.5]])


def test_box_downsample_keeps_the_mean():
    img = _noise(5, (12, 8, 3))
    assert box_downsample(img, 4).mean() == pytest.approx(img.mean(), rel=1e-6)


@pytest.mark.parametrize("factor", [1.5, 0, -2, 2.0])
def test_box_downsample_rejects_non_integer_factors(factor):
    with pytest.raises(ValueError, match="positive integer"):
        box_downsample(np.zeros((4, 4, 3)), factor)


def test_box_downsample_rejects_indivisible_sizes():
    with pytest.raises(ValueError, match="3x4"):
        box_downsample(np.zeros((3, 4, 3)), 2)


def test_resize_to():
    img = np.arange(24, dtype=np.float32).reshape(4, 6)
    np.testing.assert_array_equal(resize_to(img, (2, 3)), box_downsample(img, 2))
    np.testing.assert_array_equal(resize_to(img, (4, 6)), img)
    with pytest.raises(ValueError, match="4x6 to 3x3"):
        resize_to(img, (3, 3))
    with pytest.raises(ValueError, match="same integer factor"):
        resize_to(img, (2, 6))  # factors 2 and 1 differ


def test_dssim_from_ssim_by_hand():
    from lift_gl.metrics import dssim_from_ssim

    assert dssim_from_ssim(1.0) == 0.0
    assert dssim_from_ssim(0.5) == 1.0   # 1/0.5 - 1
    assert dssim_from_ssim(0.8) == pytest.approx(0.25)
    assert dssim_from_ssim(0.0) == float("inf") and dssim_from_ssim(-0.2) == float("inf")


def test_flip_is_zero_for_identical_images_and_grows_with_the_error():
    from lift_gl.metrics import flip

    ref = _noise(6, (32, 32, 3)) * 2.0  # linear HDR values up to 2
    assert flip(ref, ref) == 0.0
    rng = np.random.default_rng(7)
    errors = [flip(np.maximum(ref + s * rng.standard_normal(ref.shape).astype(np.float32), 0), ref)
              for s in (0.02, 0.1, 0.5)]
    assert 0 < errors[0] < errors[1] < errors[2] <= 1
    # The same as NVIDIA's evaluator called directly on the (non-negative) linear images.
    import flip_evaluator

    test = np.maximum(ref + 0.1, 0).astype(np.float32)
    assert flip(test, ref) == pytest.approx(flip_evaluator.evaluate(ref, test, "HDR", applyMagma=False)[1])
