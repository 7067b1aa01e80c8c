"""The ONNX denoiser's test-time self-ensemble: one pass is the plain network, N passes are the
mean of the network run on the N mirror images (flipped here with numpy, independently of
lift_gl/denoise/dihedral.py) and turned back; tiling and odd sizes change nothing."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

pytest.importorskip("onnxruntime")

from lift_gl.denoise.model_io import network_input, network_output  # noqa: E402
from lift_gl.denoise.onnx_denoiser import DEFAULT_MODEL, DenoiserModelError, OnnxDenoiser  # noqa: E402
from lift_gl.denoise.tiling import pad_to_multiple  # noqa: E402

# (forward, inverse) on (H, W, C) images, in the order of the ensemble's sizes 2, 4, 8
IDENTITY = (lambda a: a, lambda a: a)
FLIP_W = (lambda a: a[:, ::-1], lambda a: a[:, ::-1])
FLIP_H = (lambda a: a[::-1], lambda a: a[::-1])
ROT180 = (lambda a: a[::-1, ::-1], lambda a: a[::-1, ::-1])
TRANSPOSES = [(lambda a, k=k: np.rot90(a, k), lambda a, k=k: np.rot90(a, -k)) for k in (1, 3)] + [
    (lambda a: a.transpose(1, 0, 2), lambda a: a.transpose(1, 0, 2)),
    (lambda a: a[::-1, ::-1].transpose(1, 0, 2), lambda a: a.transpose(1, 0, 2)[::-1, ::-1])]
SYMMETRIES = {2: [IDENTITY, FLIP_W], 4: [IDENTITY, FLIP_W, FLIP_H, ROT180],
              8: [IDENTITY, FLIP_W, FLIP_H, ROT180] + TRANSPOSES}


def _inputs(h, w, seed=0):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w] / max(h, w)
    color = (rng.gamma(0.5, 1.0, (h, w, 3)) * (0.2 + xx + 2 * yy ** 2)[..., None]).astype(np.float32)  # not symmetric
    albedo = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    normal = rng.normal(size=(h, w, 3)).astype(np.float32)
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    return color, albedo, normal


@pytest.fixture(scope="module")
def single():
    return OnnxDenoiser(ensemble=1)


def test_one_pass_is_the_plain_network(single):
    color, albedo, normal = _inputs(37, 53)
    out = single.denoise(color, albedo, normal)
    x, exposure = network_input(color, albedo, normal)
    y = single._session.run(None, {"input": pad_to_multiple(x, 16)})[0][:, :, :37, :53]
    np.testing.assert_array_equal(out, network_output(y, exposure, albedo))


@pytest.mark.parametrize("n", [2, 4, 8])
def test_ensemble_is_the_mean_of_mirrored_runs(single, n):
    # 48 x 80: the exposure's 16x16 blocks map onto themselves under every symmetry, so each
    # mirrored single run sees the exposure the ensemble uses (up to summation order)
    args = _inputs(48, 80, seed=n)
    runs = [inv(single.denoise(*[np.ascontiguousarray(fwd(a)) for a in args])) for fwd, inv in SYMMETRIES[n]]
    expected = np.mean(runs, axis=0)
    out = OnnxDenoiser(ensemble=n).denoise(*args)
    np.testing.assert_allclose(out, expected, rtol=1e-4, atol=1e-6 * float(expected.max()))
    assert np.abs(out - runs[0]).max() > 1e-3 * float(expected.max())  # the mirror images do differ


@pytest.mark.parametrize("h, w", [(1, 1), (7, 13), (33, 18)])
def test_ensemble_on_odd_sizes(h, w):
    out = OnnxDenoiser(ensemble=8).denoise(*_inputs(h, w))
    assert out.shape == (h, w, 3) and out.dtype == np.float32
    assert np.all(np.isfinite(out)) and np.all(out >= 0)


def test_ensemble_tiled_equals_untiled():
    # 276 x 83: taller than a 48-pixel tile plus 96 pixels of context either side, and the
    # transposed passes run on a wide image
    args = _inputs(276, 83, seed=5)
    untiled = OnnxDenoiser(ensemble=8).denoise(*args)
    tiled = OnnxDenoiser(ensemble=8, tile=48).denoise(*args)
    assert 276 > 48 + 2 * 96
    np.testing.assert_allclose(tiled, untiled, rtol=1e-5, atol=1e-6 * float(untiled.max()))


def test_sidecar_sets_the_default(tmp_path):
    model = tmp_path / "model.onnx"
    shutil.copy(DEFAULT_MODEL, model)
    meta = json.loads(DEFAULT_MODEL.with_suffix(".json").read_text())
    meta["inference"] = {"ensemble": 4}
    model.with_suffix(".json").write_text(json.dumps(meta))
    args = _inputs(16, 32)
    d = OnnxDenoiser(model)
    np.testing.assert_array_equal(d.denoise(*args), OnnxDenoiser(ensemble=4).denoise(*args))
    assert d.ensemble == 4  # an explicit argument wins over the sidecar
    np.testing.assert_array_equal(OnnxDenoiser(model, ensemble=1).denoise(*args), OnnxDenoiser(ensemble=1).denoise(*args))
    meta["inference"] = {"ensemble": 3}
    model.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(DenoiserModelError) as e:
        OnnxDenoiser(model).denoise(*args)
    assert str(model.with_suffix(".json")) in str(e.value) and "ensemble" in str(e.value)


def test_bad_ensemble_size():
    with pytest.raises(ValueError, match="ensemble"):
        OnnxDenoiser(ensemble=3)
