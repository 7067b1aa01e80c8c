"""Albedo demodulation (lift_gl/denoise/demodulate.py): the round trip gives the image back on
a noise-free image, including black albedo, background and emitter pixels."""
import numpy as np

from lift_gl.denoise.demodulate import EPS, demodulate, remodulate, safe_albedo


def test_round_trip_is_exact_to_float_rounding():
    rng = np.random.default_rng(1)
    radiance = rng.exponential(1.0, (17, 23, 3)).astype(np.float32)
    radiance[0, 0] = [50.0, 40.0, 30.0]  # an emitter seen directly
    albedo = rng.uniform(0.0, 1.0, (17, 23, 3)).astype(np.float32)
    albedo[0, 0] = 0.0          # emitters and the background have no albedo in the G-buffer
    albedo[1, :, 1] = EPS / 2   # a channel below eps is left as it is
    back = remodulate(demodulate(radiance, albedo), albedo)
    # x / a * a in float32 is within one rounding of x (two correctly rounded operations).
    np.testing.assert_allclose(back, radiance, rtol=2 * np.finfo(np.float32).eps, atol=0)
    assert np.all(np.isfinite(demodulate(radiance, albedo)))


def test_demodulated_value_is_radiance_over_albedo():
    albedo = np.full((2, 2, 3), 0.5, np.float32)
    radiance = np.full((2, 2, 3), 0.25, np.float32)
    np.testing.assert_array_equal(demodulate(radiance, albedo), 0.5)
    np.testing.assert_array_equal(safe_albedo(np.zeros((1, 1, 3))), 1.0)
