"""Tone mapping and the sRGB transfer function: known points and inverses."""
import numpy as np
import pytest

from lift_gl.tonemap import (
    aces_narkowicz,
    reinhard,
    srgb_decode,
    srgb_encode,
    to_srgb8,
    tonemap,
)


def test_srgb_known_points():
    # The switch point: 12.92 * 0.0031308 on the linear branch.
    assert srgb_encode(0.0031308) == pytest.approx(0.040449936, abs=1e-7)
    assert srgb_encode(0.0) == 0.0
    assert srgb_encode(1.0) == pytest.approx(1.0, abs=1e-6)
    assert srgb_encode(0.5) == pytest.approx(1.055 * 0.5 ** (1 / 2.4) - 0.055, abs=1e-6)
    assert srgb_encode(0.5) == pytest.approx(0.735357, abs=1e-5)
    assert srgb_encode(0.001) == pytest.approx(0.01292, abs=1e-7)
    assert srgb_decode(0.04045) == pytest.approx(0.04045 / 12.92, abs=1e-8)
    assert srgb_decode(128 / 255) == pytest.approx(0.215861, abs=1e-5)


def test_srgb_curve_is_continuous_at_the_switch():
    below = srgb_encode(np.float32(0.0031308) * (1 - 1e-6))
    above = srgb_encode(np.float32(0.0031308) * (1 + 1e-6))
    assert abs(float(above) - float(below)) < 1e-6


def test_srgb_encode_decode_are_inverse():
    x = np.linspace(0.0, 1.0, 10001, dtype=np.float32)
    np.testing.assert_allclose(srgb_decode(srgb_encode(x)), x, atol=2e-6)
    np.testing.assert_allclose(srgb_encode(srgb_decode(x)), x, atol=2e-6)


def test_srgb_encode_negative_is_zero():
    assert srgb_encode(-0.5) == 0.0


def test_operator_known_points():
    assert aces_narkowicz(0.0) == 0.0
    assert aces_narkowicz(1.0) == pytest.approx(2.54 / 3.16, abs=1e-6)
    assert aces_narkowicz(1e4) == 1.0  # the fit's limit, 2.51/2.43, is clamped to 1
    assert reinhard(1.0) == pytest.approx(0.5)
    assert tonemap(0.7, operator="clamp") == pytest.approx(0.7)
    assert tonemap(3.0, operator="clamp") == 1.0


def test_exposure_is_in_stops():
    assert tonemap(0.5, exposure=1.0, operator="reinhard") == pytest.approx(0.5)
    assert tonemap(4.0, exposure=-2.0, operator="clamp") == pytest.approx(1.0)
    assert tonemap(0.2, exposure=-1.0, operator="clamp") == pytest.approx(0.1)


@pytest.mark.parametrize("operator", ["aces", "reinhard", "clamp"])
def test_tonemap_output_in_unit_range_and_monotonic(operator):
    x = np.concatenate([np.linspace(0, 2, 500), np.geomspace(2, 1e6, 500)]).astype(np.float32)
    y = tonemap(x, operator=operator)
    assert y.dtype == np.float32
    assert np.all((y >= 0) & (y <= 1))
    assert np.all(np.diff(y) >= 0)


@pytest.mark.parametrize("operator", ["aces", "reinhard", "clamp"])
def test_tonemap_sanitises_bad_values(operator):
    y = tonemap(np.array([np.nan, np.inf, -np.inf, -1.0, 1e30], dtype=np.float32), operator=operator)
    assert np.all(np.isfinite(y))
    assert y[0] == 0 and y[2] == 0 and y[3] == 0
    assert y[1] == pytest.approx(1.0, abs=1e-3) and y[4] == pytest.approx(1.0, abs=1e-3)


def test_unknown_operator():
    with pytest.raises(ValueError, match="reinhard"):
        tonemap(1.0, operator="filmic")


def test_to_srgb8():
    img = np.array([[[0.0, 0.5, 1.0], [0.0031308, 2.0, 0.215861]]], dtype=np.float32)
    out = to_srgb8(img, operator="clamp")
    assert out.dtype == np.uint8 and out.shape == (1, 2, 3)
    # 0.5 -> 0.735357 * 255 = 187.52 -> 188; 0.0031308 -> 10.31 -> 10; 0.215861 = decode(128/255)
    np.testing.assert_array_equal(out, [[[0, 188, 255], [10, 255, 128]]])
