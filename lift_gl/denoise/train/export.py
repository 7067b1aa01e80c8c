"""Export the trained network to ONNX with its sidecar JSON (inputs and normalisation)."""
from __future__ import annotations

import json
from pathlib import Path

import torch
from torch import nn

from .. import model_io
from .model import LOG_EPS, MULTIPLE, PASSTHROUGH_BIAS, RECEPTIVE_RADIUS, input_channels, macs_per_pixel

OPSET = 17


def sidecar(model: nn.Module, record: dict) -> dict:
    """The sidecar JSON of `model` (a train.model network): its inputs, their normalisation,
    its architecture (model.arch, which model_from_arch rebuilds) and training record."""
    if model.arch["transform"] == "log":
        color_in = (f"the graph applies log(1 + x/{LOG_EPS}) / log(1 + 1/{LOG_EPS}) itself")
        color_out = f"(the graph applies {LOG_EPS} * exp(y))"
    else:
        color_in, color_out = "the graph applies log1p itself", "(the graph applies expm1)"
    return {
        "format": "lift-gl denoiser 1",
        "input": {"name": "input", "shape": ["N", model.in_channels, "H", "W"], "dtype": "float32",
                  "channels": list(input_channels(model.temporal))},
        "output": {"name": "output", "shape": ["N", 3, "H", "W"], "dtype": "float32"},
        "normalisation": {
            "color": ("linear radiance demodulated by the first-hit albedo (lift_gl/denoise/demodulate.py: "
                      "radiance / albedo where albedo >= 1e-3, else unchanged), times `exposure`; "
                      + color_in),
            "exposure": (f"{model_io.EXPOSURE_KEY} / exp(mean(log(L))) over the {model_io.EXPOSURE_BLOCK}x"
                         f"{model_io.EXPOSURE_BLOCK} block means L of the demodulated colour's luminance "
                         "(Rec. 709 weights) that are above 1e-8, clamped to "
                         f"[{model_io.EXPOSURE_RANGE[0]}, {model_io.EXPOSURE_RANGE[1]}]"),
            "albedo": "first-hit albedo clipped to [0, 1]",
            "normal": "first-hit world-space shading normal, components in [-1, 1]",
            **({"previous": ("the previous frame's output (before `divide by exposure`) scaled to this frame's "
                             "exposure, reprojected to this frame by its motion vectors; 0 where previous.valid is 0"),
                "previous.valid": ("1 where the reprojected history holds (lift_gl/temporal.py's depth and normal "
                                   "tests), 0 where disoccluded, on the first frame and after a camera cut")}
               if model.temporal else {}),
            "output": f"denoised demodulated radiance times `exposure` {color_out}; "
                      "divide by exposure and multiply the albedo back (remodulate)",
        },
        "multiple": MULTIPLE,
        "receptive_radius": RECEPTIVE_RADIUS,
        "architecture": {**model.arch, "inputs": list(input_channels(model.temporal)),
                         "parameters": sum(p.numel() for p in model.parameters()),
                         "macs_per_pixel": macs_per_pixel(model)},
        "training": record,
        # the OnnxDenoiser's default self-ensemble (lift_gl/denoise/dihedral.py): 1, one pass;
        # 2, 4 or 8 average over mirror images at that many times the cost (docs/denoiser.md)
        "inference": {"ensemble": 1},
    }


def export(model: nn.Module, onnx_path: Path, record: dict) -> Path:
    onnx_path = Path(onnx_path)
    onnx_path.parent.mkdir(parents=True, exist_ok=True)
    model = model.float().cpu().eval().to(memory_format=torch.contiguous_format)
    dummy = torch.rand(1, model.in_channels, 64, 64)
    torch.onnx.export(model, (dummy,), str(onnx_path), input_names=["input"], output_names=["output"],
                      dynamic_axes={"input": {0: "n", 2: "h", 3: "w"}, "output": {0: "n", 2: "h", 3: "w"}},
                      opset_version=OPSET, dynamo=False)
    json_path = onnx_path.with_suffix(".json")
    json_path.write_text(json.dumps(sidecar(model, record), indent=2) + "\n")
    return json_path


def _grown(name: str, new: torch.Tensor, old) -> torch.Tensor:
    """`new`'s shape holding the old weights where they fit: extra input or output channels
    start at zero (a passthrough channel's bias at PASSTHROUGH_BIAS), a conv the old model
    lacks as the identity (after a ReLU, an identity 3x3 conv changes nothing)."""
    if old is None:
        grown = torch.zeros_like(new)
        if name.endswith(".weight") and new.dim() == 4 and new.shape[0] == new.shape[1]:
            for i in range(new.shape[0]):
                grown[i, i, new.shape[2] // 2, new.shape[3] // 2] = 1.0
        return grown
    old = torch.from_numpy(old.copy())
    if old.dim() != new.dim() or any(o > n for o, n in zip(old.shape, new.shape)):
        raise SystemExit(f"{name}: {tuple(old.shape)} does not fit in {tuple(new.shape)}")
    grown = torch.zeros_like(new)
    if name.endswith(".bias") and new.shape[0] > old.shape[0]:
        grown[old.shape[0]:] = PASSTHROUGH_BIAS
    grown[tuple(slice(0, o) for o in old.shape)] = old
    return grown


def load_onnx_weights(model: nn.Module, onnx_path: Path, grow: bool = False) -> None:
    """Set `model`'s parameters from an exported model's initializers (export() keeps the
    parameter names), refusing a file of another architecture; with `grow`, a smaller model's
    file of the same layer names (model.py's passthrough, full_res_convs), the
    model starting as the file's function (_grown)."""
    import onnx
    from onnx import numpy_helper

    onnx_path = Path(onnx_path)
    try:
        graph = onnx.load(str(onnx_path)).graph
    except Exception as exc:  # a missing or corrupt file: one message naming it
        raise SystemExit(f"{onnx_path}: cannot read the model to start from ({exc})")
    weights = {i.name: numpy_helper.to_array(i) for i in graph.initializer}
    state = model.state_dict()
    if grow:
        model.load_state_dict({k: _grown(k, v, weights.get(k)) for k, v in state.items()})
        return
    wrong = [k for k, v in state.items() if k not in weights or tuple(weights[k].shape) != tuple(v.shape)]
    if wrong:
        raise SystemExit(f"{onnx_path}: not a model of this architecture ({model.arch}): "
                         f"{len(wrong)} of {len(state)} parameters missing or of another shape, e.g. {wrong[0]}")
    model.load_state_dict({k: torch.from_numpy(weights[k].copy()) for k in state})
