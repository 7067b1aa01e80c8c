"""A temporal denoiser model (13 input channels: the previous frame's output and its validity)
on arrays: lift_gl/denoise/model_io.py's input and both executors' `previous`/`valid`."""
from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("onnxruntime")

from lift_gl.denoise.model_io import network_input  # noqa: E402


@pytest.fixture(scope="module")
def temporal_model(tmp_path_factory):
    from lift_gl.denoise.train.export import export
    from lift_gl.denoise.train.model import build_model

    torch.manual_seed(3)
    path = tmp_path_factory.mktemp("temporal") / "rt_temporal.onnx"
    export(build_model("rt", temporal=True).eval(), path, {"steps": 0})
    return path


def _frame(seed, h=21, w=35):
    rng = np.random.default_rng(seed)
    albedo = rng.uniform(0.05, 1.0, (h, w, 3)).astype(np.float32)
    color = (albedo * rng.exponential(1.0, (h, w, 1))).astype(np.float32)
    normal = rng.standard_normal((h, w, 3)).astype(np.float32)
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    previous = (albedo * rng.uniform(0.5, 1.5, (h, w, 1))).astype(np.float32)
    return color, albedo, normal, previous


def test_network_input_holds_the_history_where_valid_and_zeros_elsewhere():
    color, albedo, normal, previous = _frame(0)
    valid = np.zeros(color.shape[:2], np.float32)
    valid[:, ::2] = 1.0
    x, exposure = network_input(color, albedo, normal, previous, valid, temporal=True)
    assert x.shape == (1, 13) + color.shape[:2]
    plain, same_exposure = network_input(color, albedo, normal)
    assert exposure == same_exposure and np.array_equal(x[:, :9], plain)  # this frame's exposure, guides as before
    history = x[0, 9:12].transpose(1, 2, 0)
    np.testing.assert_allclose(history[:, ::2], (previous / albedo * np.float32(exposure))[:, ::2], rtol=1e-6)
    assert not history[:, 1::2].any() and np.array_equal(x[0, 12], valid)


@pytest.mark.parametrize("name", ["onnx", "glsl"])
def test_valid_zero_is_the_network_run_with_zeros(temporal_model, name):
    """No history (valid 0 everywhere, or previous and valid absent) is bit for bit the network
    run on zeros in those channels, whatever `previous` holds; a valid history changes it."""
    from lift_gl.denoise import get_denoiser
    from lift_gl.denoise.model_io import network_output

    options = {"providers": ["CPUExecutionProvider"]} if name == "onnx" else {}
    denoiser = get_denoiser(name, model_path=temporal_model, ensemble=1, **options)
    color, albedo, normal, previous = _frame(1)
    zeros = np.zeros(color.shape[:2], np.float32)
    absent = denoiser.denoise(color, albedo, normal)
    ignored = denoiser.denoise(color, albedo, normal, previous=previous, valid=zeros)
    assert np.array_equal(absent, ignored)
    x, exposure = network_input(color, albedo, normal)  # 9 channels, then the 4 zeros by hand
    x = np.concatenate([x, np.zeros((1, 4) + x.shape[2:], np.float32)], axis=1)
    run = denoiser._run_padded if name == "onnx" else denoiser.net.run_numpy
    assert np.array_equal(absent, network_output(run(x), exposure, albedo))
    held = denoiser.denoise(color, albedo, normal, previous=previous, valid=np.ones_like(zeros))
    assert np.abs(held - absent).max() > 1e-4 * np.abs(absent).max()
    if name == "glsl":
        denoiser.release()
