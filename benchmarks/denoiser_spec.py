"""Denoiser names as the denoiser benchmarks take them: a name of lift_gl.denoise (atrous,
onnx, oidn, glsl), with a model file and a self-ensemble for the networks:

    onnx:PATH      the ONNX denoiser (onnxruntime) with the model at PATH
    glsl:PATH      the same model run by the GLSL compute shaders
    onnx*4         a self-ensemble of 4 mirror images (1, 2, 4 or 8), with or without :PATH

so that a second model (a real-time or temporal one) is a column beside the shipped one.
"""
from __future__ import annotations

from pathlib import Path

NETWORKS = ("onnx", "glsl")


def parse(spec: str) -> tuple[str, dict]:
    """(the lift_gl.denoise name, its get_denoiser / DenoiseSettings options)."""
    head, _, ensemble = spec.partition("*")
    name, _, path = head.partition(":")
    options = {}
    if path or ensemble:
        if name not in NETWORKS:
            raise SystemExit(f"{spec!r}: a model path and an ensemble are for the networks ({', '.join(NETWORKS)})")
        if path:
            if not Path(path).is_file():
                raise SystemExit(f"{spec!r}: no model file at {path}")
            options["model_path"] = path
        if ensemble:
            options["ensemble"] = int(ensemble)
    return name, options


def label(spec: str) -> str:
    """A short column name: onnx:dir/model_rt.onnx*2 -> onnx:model_rt*2."""
    head, star, ensemble = spec.partition("*")
    name, colon, path = head.partition(":")
    return name + (f":{Path(path).stem}" if colon else "") + (f"*{ensemble}" if star else "")
