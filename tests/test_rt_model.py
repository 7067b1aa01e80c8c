"""The denoiser's models by name (lift_gl/denoise/train/model.py): the real-time "rt" U-Net
and the quality "unet", plain and temporal; their cost, reach, export and sidecar."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lift_gl.denoise.train.model import (MULTIPLE, RECEPTIVE_RADIUS, build_model, input_channels,  # noqa: E402
                                         macs_per_pixel, model_from_arch)

REPO = Path(__file__).resolve().parents[1]
CASES = [(name, temporal) for name in ("unet", "rt") for temporal in (False, True)]


def _counted_macs(model, size=64) -> float:
    """Multiply-adds per pixel counted on a forward pass: each conv's output elements times
    its weights per output element (independent of macs_per_pixel's per-level bookkeeping)."""
    total = [0]

    def hook(module, inputs, output):
        if isinstance(module, torch.nn.ConvTranspose2d):  # each input element meets every weight of its channel
            total[0] += inputs[0].numel() * module.weight.numel() // module.in_channels
        else:
            total[0] += output.numel() * module.weight.numel() // module.out_channels
    handles = [m.register_forward_hook(hook) for m in model.modules()
               if isinstance(m, (torch.nn.Conv2d, torch.nn.ConvTranspose2d))]
    with torch.no_grad():
        model(torch.rand(1, model.in_channels, size, size))
    for h in handles:
        h.remove()
    return total[0] / size ** 2


@pytest.mark.parametrize("name,temporal", CASES)
def test_shapes_channels_and_cost(name, temporal):
    model = build_model(name, temporal).eval()
    assert model.in_channels == len(input_channels(temporal)) == (13 if temporal else 9)
    y = model(torch.rand(1, model.in_channels, 2 * MULTIPLE, 3 * MULTIPLE))
    assert y.shape == (1, 3, 2 * MULTIPLE, 3 * MULTIPLE) and bool(torch.all(y > 0))
    assert macs_per_pixel(model) == pytest.approx(_counted_macs(model), rel=1e-12)


def test_rt_costs_at_most_a_sixth_of_the_unet():
    # the real-time budget: 3 ms at 1080p on the H200 where the unet takes 10.9 (docs/denoiser.md)
    rt, unet = macs_per_pixel(build_model("rt")), macs_per_pixel(build_model("unet"))
    assert unet == 51930  # the shipped network's figure (docs/denoiser.md)
    assert rt / unet < 1 / 6


@pytest.mark.parametrize("name,temporal", CASES)
def test_arch_rebuilds_the_same_model(name, temporal):
    model = build_model(name, temporal)
    again = model_from_arch(json.loads(json.dumps(model.arch)))  # through JSON, as the sidecar stores it
    assert type(again) is type(model) and again.arch == model.arch
    again.load_state_dict(model.state_dict())  # the same parameter names and shapes


def test_an_arch_without_a_name_is_the_unet():
    """The shipped sidecar's and old checkpoints' architecture carries no name."""
    assert model_from_arch({"encoder": [16, 32, 48, 64], "bottleneck": 80, "transform": "log1p"}).arch["name"] == "unet"
    with pytest.raises(ValueError, match="unknown denoiser model"):
        build_model("resnet")


def test_rt_reach_is_within_the_receptive_radius():
    """An impulse's effect on a random rt network's output stays within RECEPTIVE_RADIUS (the
    tiling overlap): the gradient of one output pixel against the input is zero beyond it."""
    torch.manual_seed(0)
    model = build_model("rt").eval()
    size = 2 * RECEPTIVE_RADIUS + 2 * MULTIPLE  # 224: room around the centre on every side
    x = torch.rand(1, model.in_channels, size, size, requires_grad=True)
    for c in (size // 2 - 1, size // 2):  # both ends of a 2x2 block
        x.grad = None
        model(x)[0, :, c, c].sum().backward()
        rows, cols = np.nonzero(x.grad.abs().sum(dim=(0, 1)).numpy())
        reach = max(abs(rows - c).max(), abs(cols - c).max())
        assert 32 < reach <= RECEPTIVE_RADIUS


def test_temporal_colour_goes_through_the_colour_transform():
    """The previous colour channels take the colour's curve; previous.valid passes as is."""
    model = build_model("rt", temporal=True)
    x = torch.rand(1, 13, 4, 4) * 3
    t = model.transformed_input(x)
    torch.testing.assert_close(t[:, 9:12], model._color_in(x[:, 9:12]))
    torch.testing.assert_close(t[:, 12], x[:, 12])
    torch.testing.assert_close(t[:, :3], model._color_in(x[:, :3]))


@pytest.mark.parametrize("name,temporal,passthrough", [("rt", False, False), ("rt", True, False), ("rt", True, True)])
def test_export_matches_torch_and_names_the_inputs(name, temporal, passthrough, tmp_path):
    ort = pytest.importorskip("onnxruntime")
    from lift_gl.denoise.train.export import export
    torch.manual_seed(1)
    model = build_model(name, temporal, passthrough=passthrough).eval()
    if passthrough:  # a share of about a half, so that both sides of the blend count
        with torch.no_grad():
            model.up.bias[3] = 0.0
    side = json.loads(export(model, tmp_path / "m.onnx", {"steps": 0}).read_text())
    assert side["input"]["shape"][1] == model.in_channels
    assert side["input"]["channels"] == list(input_channels(temporal))
    assert side["architecture"]["name"] == name and side["architecture"]["temporal"] == temporal
    assert side["architecture"]["macs_per_pixel"] == macs_per_pixel(model)
    assert side["architecture"]["inputs"] == list(input_channels(temporal))
    assert model_from_arch(side["architecture"]).arch == model.arch  # the sidecar rebuilds the model
    x = np.random.default_rng(0).random((1, model.in_channels, 32, 48), dtype=np.float32)
    y = ort.InferenceSession(str(tmp_path / "m.onnx")).run(None, {"input": x})[0]
    with torch.no_grad():
        expect = model(torch.from_numpy(x)).numpy()
    # two float32 evaluations of the same graph: a few roundings of the largest value apart
    np.testing.assert_allclose(y, expect, rtol=1e-4, atol=1e-4 * float(np.abs(expect).max()))


def test_the_default_rt_is_the_shipped_one_with_its_chroma_correction():
    from lift_gl.denoise.train.model import CHROMA_BLOCK
    shipped = json.loads((REPO / "assets" / "denoiser" / "lift_rt.json").read_text())["architecture"]
    assert build_model("rt").arch["chroma_block"] == CHROMA_BLOCK == shipped["chroma_block"]


def test_an_rt_arch_of_the_first_rt_model_rebuilds_it():
    first = {"name": "rt", "encoder": [24, 32, 48], "bottleneck": 48, "transform": "log", "temporal": True}
    model = model_from_arch({**first, "colour_skip": 0})
    assert not model.arch["passthrough"] and model.arch["chroma_block"] == 0 and "colour_skip" not in model.arch
    with pytest.raises(ValueError, match="colour skip"):
        model_from_arch({**first, "colour_skip": 4})


@pytest.mark.parametrize("name", ["unet", "rt"])
def test_a_new_passthrough_starts_as_the_network_alone(name):
    """A passthrough model from random weights starts at a share of sigmoid(-8) everywhere
    (started at 1/2, training handed the whole input back and stayed there)."""
    torch.manual_seed(2)
    plain_output = {"chroma_block": 0} if name == "rt" else {}  # the blend is the last step
    model = build_model(name, passthrough=True, **plain_output).eval()
    plain = build_model(name, **plain_output).eval()
    plain.load_state_dict({k: v[:3] if v.shape[0] == 4 else (v[:, :3] if v.dim() == 4 and v.shape[1] == 4 else v)
                           for k, v in model.state_dict().items()})
    x = torch.rand(1, model.in_channels, 32, 48) * 2
    with torch.no_grad():
        got, net = model(x), plain(x)
    share = 1 / (1 + np.exp(8.0))
    torch.testing.assert_close(got, net * (1 - share) + torch.relu(x[:, :3]) * share, rtol=1e-5, atol=1e-6)


def test_rt_passthrough_returns_the_input_where_its_share_is_one():
    """With the share's channel driven to 1 the output is the input colour (relu'd), exactly
    what DenoiseUNet's passthrough gives back where the input is already exact."""
    model = build_model("rt", temporal=True, passthrough=True).eval()
    assert model.up.out_channels == 4
    with torch.no_grad():
        model.up.bias[3] = 60.0  # sigmoid(60) is 1 in float32
        x = torch.rand(1, 13, 32, 48) * 3 - 0.5
        y = model(x)
    torch.testing.assert_close(y, torch.relu(x[:, :3]))


def test_rt_chroma_correction_gives_the_output_the_inputs_colour_balance():
    """An output of one colour a over a pattern f, an input of colour b over another pattern:
    every block's ratio is then (b / mean b) / (a / mean a), so the result is f * mean(a) *
    b / mean(b): the network's brightness pattern (channel mean kept) in the input's colour."""
    model = build_model("rt", temporal=True).eval()
    assert model.arch["chroma_block"] == 8
    rng = np.random.default_rng(3)
    f = torch.from_numpy(rng.uniform(0.2, 1.0, (1, 1, 32, 48)).astype(np.float32))
    g = torch.from_numpy(rng.uniform(0.1, 3.0, (1, 1, 32, 48)).astype(np.float32))
    a, b = torch.tensor([0.8, 0.6, 0.7]), torch.tensor([0.5, 0.9, 0.6])  # ratios within CHROMA_RANGE
    out = f * a[None, :, None, None]
    colour = g * b[None, :, None, None]
    got = model._keep_chroma(out, colour, 8)
    want = f * a.mean() * (b / b.mean())[None, :, None, None]
    torch.testing.assert_close(got, want, rtol=2e-3, atol=0)  # CHROMA_EPS against values of 0.1 and more
    torch.testing.assert_close(model._keep_chroma(out, out, 8), out)  # an input of the output's balance: unchanged


def test_rt_chroma_correction_is_bounded():
    """A block whose input is one saturated firefly scales a channel by at most CHROMA_RANGE."""
    from lift_gl.denoise.train.model import CHROMA_RANGE
    model = build_model("rt").eval()
    out = torch.full((1, 3, 16, 16), 0.5)
    colour = torch.zeros(1, 3, 16, 16)
    colour[0, 0, 3, 3] = 500.0  # a red firefly
    got = model._keep_chroma(out, colour, 8)
    assert float(got.max()) <= 0.5 * CHROMA_RANGE * (1 + 1e-6) and float(got.min()) >= 0.5 / CHROMA_RANGE * (1 - 1e-6)



def test_the_graph_builder_of_the_glsl_tests_has_the_models_constants():
    from lift_gl.denoise import random_unet
    from lift_gl.denoise.train import model
    for name in ("LOG_EPS", "LOG_CLAMP", "CHROMA_EPS", "CHROMA_RANGE"):
        assert getattr(random_unet, name) == getattr(model, name), name
