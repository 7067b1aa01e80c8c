"""The ONNX denoiser run by the GLSL executor instead of onnxruntime: the same model file,
the same input preparation (lift_gl/denoise/model_io.py), the same result within float32
rounding, on any OpenGL 4.3 device.

    GlslDenoiser().denoise(color, albedo, normal)  # (H, W, 3) float32 each

The model is read and its shaders compiled on the first denoise() call.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

DEFAULT_MODEL = Path(__file__).resolve().parents[2] / "assets" / "denoiser" / "lift_unet.onnx"


class GlslDenoiser:
    name = "glsl"

    def __init__(self, model_path=None, ctx=None, **net_options):
        self.model_path = Path(model_path) if model_path is not None else DEFAULT_MODEL
        self._ctx = ctx
        self._net_options = net_options
        self.net = None

    def _load(self) -> None:
        from ..gl.context import create_context
        from .glsl_net import GlslNet

        self.net = GlslNet(self._ctx or create_context(), self.model_path, **self._net_options)

    def network(self):
        """The GlslNet (loaded on first use): passes/net_denoise.py feeds it from textures."""
        if self.net is None:
            self._load()
        return self.net

    def denoise(self, color, albedo, normal, depth=None, variance=None) -> np.ndarray:
        """Denoised linear radiance (H, W, 3) float32; depth and variance are not used by this model."""
        from .model_io import checked_color, network_input, network_output  # the onnxruntime path's own preparation

        if self.net is None:
            self._load()
        color = checked_color(color, albedo, normal)
        x, exposure = network_input(color, albedo, normal)
        return network_output(self.net.run_numpy(x), exposure, albedo)

    def release(self) -> None:
        if self.net is not None:
            self.net.release()
            self.net = None
