"""The ONNX denoiser: shapes it must accept, tiling that must not change the result, the
errors for a missing or broken model file, and that it does denoise a real render."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("onnxruntime")

from lift_gl.denoise.model_io import autoexposure, network_input, network_output  # noqa: E402
from lift_gl.denoise.onnx_denoiser import DEFAULT_MODEL, DenoiserModelError, OnnxDenoiser, best_providers  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _inputs(h, w, seed=0):
    rng = np.random.default_rng(seed)
    color = rng.gamma(0.5, 1.0, (h, w, 3)).astype(np.float32)
    albedo = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    normal = rng.normal(size=(h, w, 3)).astype(np.float32)
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    return color, albedo, normal


@pytest.fixture(scope="module")
def denoiser():
    return OnnxDenoiser()


@pytest.mark.parametrize("h, w", [(1, 1), (7, 13), (33, 65), (17, 16)])
def test_odd_sizes(denoiser, h, w):
    out = denoiser.denoise(*_inputs(h, w))
    assert out.shape == (h, w, 3) and out.dtype == np.float32
    assert np.all(np.isfinite(out)) and np.all(out >= 0)


def test_tiled_equals_untiled(denoiser):
    # 300 x 262 with 48-pixel tiles and 96 pixels of context: many tiles, each smaller than
    # the image, so the result can only match if the overlap covers the receptive field.
    args = _inputs(300, 262, seed=1)
    untiled = denoiser.denoise(*args)
    tiled = OnnxDenoiser(tile=48).denoise(*args)
    assert 300 > 48 + 2 * 96
    np.testing.assert_allclose(tiled, untiled, rtol=1e-5, atol=1e-6 * float(untiled.max()))


def test_inputs_are_sanitised(denoiser):
    color, albedo, normal = _inputs(20, 24)
    color[3, 4] = np.nan
    color[5, 6] = np.inf
    color[7, 8] = -1.0
    assert np.all(np.isfinite(denoiser.denoise(color, albedo, normal)))


def test_network_io_round_trip():
    """Feeding the network's own colour input back as its output gives the radiance back
    (demodulation, exposure and their inverses agree), and the exposure scales inversely."""
    color, albedo, normal = _inputs(40, 56, seed=2)
    albedo[:5] = 0.0  # black and background pixels: not demodulated
    x, exposure = network_input(color, albedo, normal)
    np.testing.assert_allclose(network_output(x[:, :3], exposure, albedo), color, rtol=1e-5)
    assert autoexposure(4.0 * color) == pytest.approx(autoexposure(color) / 4.0, rel=1e-5)


def test_missing_model_file_names_it(tmp_path):
    missing = tmp_path / "nowhere" / "model.onnx"
    d = OnnxDenoiser(missing)  # loading is lazy: nothing happens yet
    with pytest.raises(DenoiserModelError) as e:
        d.denoise(*_inputs(8, 8))
    assert str(missing) in str(e.value) and "not found" in str(e.value)


def test_corrupt_model_file_names_it(tmp_path):
    bad = tmp_path / "model.onnx"
    bad.write_bytes(DEFAULT_MODEL.read_bytes()[:2000])  # a truncated download
    shutil.copy(DEFAULT_MODEL.with_suffix(".json"), bad.with_suffix(".json"))
    with pytest.raises(DenoiserModelError) as e:
        OnnxDenoiser(bad).denoise(*_inputs(8, 8))
    assert str(bad) in str(e.value) and "ONNX" in str(e.value)


def test_missing_or_bad_sidecar_names_it(tmp_path):
    model = tmp_path / "model.onnx"
    shutil.copy(DEFAULT_MODEL, model)
    with pytest.raises(DenoiserModelError) as e:
        OnnxDenoiser(model).denoise(*_inputs(8, 8))
    assert str(model.with_suffix(".json")) in str(e.value)
    model.with_suffix(".json").write_text('{"multiple": 16}')
    with pytest.raises(DenoiserModelError) as e:
        OnnxDenoiser(model).denoise(*_inputs(8, 8))
    assert "receptive_radius" in str(e.value)


def test_best_providers_prefers_accelerators():
    assert best_providers(["CPUExecutionProvider", "CUDAExecutionProvider"])[0] == "CUDAExecutionProvider"
    assert best_providers(["CPUExecutionProvider", "CoreMLExecutionProvider"])[0] == "CoreMLExecutionProvider"
    assert best_providers(["CPUExecutionProvider"]) == ["CPUExecutionProvider"]


def test_denoises_a_render():
    """On the repo's Cornell box at 4 spp (48 x 48, glass and gold), denoising at least halves
    the relMSE against a 512-spp reference (2.8x measured). The reference's own noise adds
    1/128 of the input's variance to both errors, far too little to move a factor of 2."""
    from lift_gl.denoise.train.render_data import render_views
    from lift_gl.metrics import rel_mse
    from lift_gl.scene.loader import load_scene

    scene = load_scene(ROOT / "scenes" / "cornell.toml")
    (noisy,), albedo, normal, reference, _ = render_views(scene, (48, 48), (4,), 512, seed=3)
    denoised = OnnxDenoiser().denoise(noisy, albedo, normal)
    assert rel_mse(denoised, reference) < rel_mse(noisy, reference) / 2
