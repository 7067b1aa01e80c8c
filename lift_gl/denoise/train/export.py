"""Export the trained network to ONNX with its sidecar JSON (inputs and normalisation)."""
from __future__ import annotations

import json
from pathlib import Path

import torch

from .. import model_io
from .model import IN_CHANNELS, LOG_EPS, MULTIPLE, RECEPTIVE_RADIUS, DenoiseUNet, macs_per_pixel

OPSET = 17


def sidecar(model: DenoiseUNet, record: dict) -> dict:
    if model.arch["transform"] == "log":
        color_in = (f"the graph applies log(1 + x/{LOG_EPS}) / log(1 + 1/{LOG_EPS}) itself")
        color_out = f"(the graph applies {LOG_EPS} * exp(y))"
    else:
        color_in, color_out = "the graph applies log1p itself", "(the graph applies expm1)"
    return {
        "format": "lift-gl denoiser 1",
        "input": {"name": "input", "shape": ["N", IN_CHANNELS, "H", "W"], "dtype": "float32", "channels": [
            "color.r", "color.g", "color.b", "albedo.r", "albedo.g", "albedo.b", "normal.x", "normal.y", "normal.z"]},
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
            "output": f"denoised demodulated radiance times `exposure` {color_out}; "
                      "divide by exposure and multiply the albedo back (remodulate)",
        },
        "multiple": MULTIPLE,
        "receptive_radius": RECEPTIVE_RADIUS,
        "architecture": {**model.arch,
                         "parameters": sum(p.numel() for p in model.parameters()),
                         "macs_per_pixel": macs_per_pixel(model)},
        "training": record,
        # the OnnxDenoiser's default self-ensemble (lift_gl/denoise/dihedral.py): 1, one pass;
        # 2, 4 or 8 average over mirror images at that many times the cost (docs/denoiser.md)
        "inference": {"ensemble": 1},
    }


def export(model: DenoiseUNet, onnx_path: Path, record: dict) -> Path:
    onnx_path = Path(onnx_path)
    onnx_path.parent.mkdir(parents=True, exist_ok=True)
    model = model.float().cpu().eval().to(memory_format=torch.contiguous_format)
    dummy = torch.rand(1, IN_CHANNELS, 64, 64)
    torch.onnx.export(model, (dummy,), str(onnx_path), input_names=["input"], output_names=["output"],
                      dynamic_axes={"input": {0: "n", 2: "h", 3: "w"}, "output": {0: "n", 2: "h", 3: "w"}},
                      opset_version=OPSET, dynamo=False)
    json_path = onnx_path.with_suffix(".json")
    json_path.write_text(json.dumps(sidecar(model, record), indent=2) + "\n")
    return json_path
