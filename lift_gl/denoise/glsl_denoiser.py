"""The ONNX denoiser run by the GLSL executor instead of onnxruntime: the same model file,
the same input preparation (lift_gl/denoise/model_io.py), the same result within float32
rounding, on any OpenGL 4.3 device.

    GlslDenoiser().denoise(color, albedo, normal)  # (H, W, 3) float32 each

The model is read and its shaders compiled on the first denoise() call. `ensemble` (1, 2, 4
or 8; None: the sidecar's `inference.ensemble`, as OnnxDenoiser) averages over that many
mirror images as the onnxruntime path does (lift_gl/denoise/dihedral.py); the renderer's
texture path (passes/net_denoise.py, `network()`, the viewer's real-time road) always runs
the single pass.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

MODEL_DIR = Path(__file__).resolve().parents[2] / "assets" / "denoiser"
MODEL_FILES = {"unet": "lift_unet.onnx", "rt": "lift_rt.onnx"}  # train.model's names: the shipped files
DEFAULT_MODEL = MODEL_DIR / MODEL_FILES["unet"]


def model_file(name: str) -> Path:
    """The shipped weights of the network `name` (train/model.py MODELS)."""
    return MODEL_DIR / MODEL_FILES[name]


class GlslDenoiser:
    name = "glsl"

    def __init__(self, model_path=None, ctx=None, ensemble: int | None = None, **net_options):
        """net_options: GlslNet's kernel shape (out_block, pixels)."""
        from .dihedral import ENSEMBLE_SIZES

        if ensemble is not None and ensemble not in ENSEMBLE_SIZES:
            raise ValueError(f"ensemble must be one of {ENSEMBLE_SIZES}, not {ensemble!r}")
        self.model_path = Path(model_path) if model_path is not None else DEFAULT_MODEL
        self.ensemble = ensemble
        self._ctx = ctx
        self._net_options = dict(net_options)
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

    def denoise(self, color, albedo, normal, depth=None, variance=None, previous=None, valid=None) -> np.ndarray:
        """Denoised linear radiance (H, W, 3) float32; depth and variance are not used by this
        model; previous and valid feed a temporal model as OnnxDenoiser.denoise's do."""
        from .dihedral import ensemble_mean
        # the onnxruntime path's own preparation
        from .model_io import TEMPORAL_CHANNELS, checked_color, network_input, network_output

        if self.net is None:
            self._load()
        if self.ensemble is None:
            from .onnx_denoiser import read_sidecar  # the onnxruntime path's own reading and checks

            self.ensemble = read_sidecar(self.model_path).ensemble
        color = checked_color(color, albedo, normal)
        x, exposure = network_input(color, albedo, normal, previous, valid,
                                    self.net.input_channels == TEMPORAL_CHANNELS)
        return network_output(ensemble_mean(self.net.run_numpy, x, self.ensemble), exposure, albedo)

    def release(self) -> None:
        if self.net is not None:
            self.net.release()
            self.net = None
