"""The denoiser benchmarks' own parts: the temporal-error metric of benchmarks/denoise_temporal.py
against analytic values, and the denoiser names they read (benchmarks/denoiser_spec.py)."""
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))

import denoiser_spec  # noqa: E402
from temporal_error import frame_changes, mean_ratio, mean_split, temporal_error  # noqa: E402


def test_a_static_sequence_does_not_change():
    image = np.random.default_rng(0).gamma(0.5, 1.0, (8, 9, 3)).astype(np.float32)
    result = temporal_error([image] * 5, [image] * 5)
    assert result["per_frame"]["change"] == [0.0] * 4
    assert result["mean"]["difference"] == 0.0
    assert result["per_frame"]["relmse"] == [0.0] * 5
    assert result["per_frame"]["mean_ratio"] == [1.0] * 5


def test_stripes_shifted_one_pixel_a_frame_change_by_their_contrast():
    # columns alternating 0 and c: a shift of one column turns every pixel from 0 to c or back
    c, w = 0.75, 10
    stripes = np.zeros((4, w, 3), np.float32)
    stripes[:, 1::2] = c
    frames = [np.roll(stripes, f, axis=1) for f in range(6)]
    assert frame_changes(frames) == pytest.approx([c] * 5, abs=1e-7)


def test_a_ramp_shifted_one_pixel_a_frame():
    # I(x) = a x, rolled by one column: |change| is a in W-1 columns and a (W-1) in the wrapped one,
    # a mean of 2 a (W-1) / W
    a, w = 0.1, 16
    ramp = np.broadcast_to((a * np.arange(w, dtype=np.float32))[None, :, None], (3, w, 3))
    frames = [np.roll(ramp, f, axis=1) for f in range(4)]
    assert frame_changes(frames) == pytest.approx([2 * a * (w - 1) / w] * 3, rel=1e-6)


def test_difference_is_change_minus_the_references_change():
    ref = [np.full((2, 2, 3), v, np.float32) for v in (1.0, 1.5, 1.25)]     # changes 0.5, 0.25
    out = [np.full((2, 2, 3), v, np.float32) for v in (1.0, 2.0, 1.0)]     # changes 1.0, 1.0
    result = temporal_error(out, ref)
    assert result["per_frame"]["difference"] == pytest.approx([0.5, 0.75])
    assert result["mean"]["difference"] == pytest.approx(0.625)
    assert mean_ratio(out[1], ref[1]) == pytest.approx(2.0 / 1.5)


def test_independent_noise_changes_by_its_expected_absolute_difference():
    # frames x + N(0, s^2) independently: the difference of two is N(0, 2 s^2), E|d| = 2 s / sqrt(pi),
    # and the mean of n such |d| has standard deviation s sqrt(2 (1 - 2/pi) / n)
    s, shape, frames = 0.2, (32, 32, 3), 9
    rng = np.random.default_rng(1)
    base = rng.uniform(0.5, 1.0, shape)
    noisy = [base + rng.normal(0, s, shape) for _ in range(frames)]
    n = np.prod(shape) * (frames - 1)
    got = np.mean(frame_changes(noisy))
    assert abs(got - 2 * s / np.sqrt(np.pi)) < 5 * s * np.sqrt(2 * (1 - 2 / np.pi) / n)


def test_sequences_of_different_lengths_are_refused():
    with pytest.raises(ValueError):
        temporal_error([np.zeros((2, 2, 3))] * 3, [np.zeros((2, 2, 3))] * 2)


def test_a_network_name_carries_its_model_file_and_ensemble(tmp_path):
    model = tmp_path / "model_rt.onnx"
    model.write_bytes(b"")
    assert denoiser_spec.parse("atrous") == ("atrous", {})
    assert denoiser_spec.parse(f"glsl:{model}") == ("glsl", {"model_path": str(model)})
    assert denoiser_spec.parse(f"onnx:{model}*4") == ("onnx", {"model_path": str(model), "ensemble": 4})
    assert denoiser_spec.label(f"onnx:{model}*4") == "onnx:model_rt*4"
    with pytest.raises(SystemExit):
        denoiser_spec.parse("oidn:x.onnx")  # a model file for a denoiser that takes none
    with pytest.raises(SystemExit):
        denoiser_spec.parse(f"onnx:{tmp_path / 'absent.onnx'}")


def test_mean_split_finds_the_energy_lost_on_a_light_seen_directly():
    """A light of 0.5% of the pixels holding half the energy, dimmed by 10%: the whole image's
    mean falls 5%, the rest's not at all."""
    ref = np.full((20, 20, 3), 0.1)
    ref[0, :2] = 0.1 * 398 / 2   # two pixels hold as much as the other 398
    out = ref.copy()
    out[0, :2] *= 0.9
    got = mean_split(out, ref)
    assert got["bright"] == pytest.approx(0.9) and got["rest"] == pytest.approx(1.0)
    assert got["bright_pixels"] == pytest.approx(2 / 400) and got["bright_energy"] == pytest.approx(0.5)
    assert mean_ratio(out, ref) == pytest.approx(0.95)
    assert mean_split(np.ones((4, 4, 3)), np.ones((4, 4, 3)))["bright"] is None   # no light seen
