"""The albedo-demodulated U-Net denoiser, run with onnxruntime (the `denoise` extra).

    OnnxDenoiser().denoise(color, albedo, normal)  # (H, W, 3) float32 each

The model (assets/denoiser/lift_unet.onnx, trained by lift_gl/denoise/train) and its sidecar
JSON are read on the first denoise() call, with the best execution provider onnxruntime
offers here (CUDA, DirectML, CoreML, else CPU). Inputs are padded to the network's multiple;
images larger than `tile` a side are denoised in overlapping tiles (lift_gl/denoise/tiling.py).

`ensemble` (1, 2, 4 or 8) averages the network's outputs over that many mirror images of the
input (test-time self-ensemble, lift_gl/denoise/dihedral.py): each pass sees the image flipped
or rotated, its output is turned back, and the outputs are averaged. It costs that many passes.
None takes the sidecar's `inference.ensemble` (1 where absent).
"""
from __future__ import annotations

import json
from collections import namedtuple
from pathlib import Path

import numpy as np

from ..errors import LiftError
from .dihedral import ENSEMBLE_SIZES, ensemble_mean, sidecar_ensemble
from .model_io import TEMPORAL_CHANNELS, checked_color, network_input, network_output
from .tiling import pad_to_multiple, run_tiled

DEFAULT_MODEL = Path(__file__).resolve().parents[2] / "assets" / "denoiser" / "lift_unet.onnx"
PREFERRED_PROVIDERS = ("CUDAExecutionProvider", "DmlExecutionProvider", "CoreMLExecutionProvider",
                       "CPUExecutionProvider")
DEFAULT_TILE = 2048  # a 1080p frame runs in one pass; larger images in tiles (memory)


class DenoiserModelError(LiftError):
    """A denoiser model file (or its sidecar JSON) that is missing or cannot be loaded."""


Sidecar = namedtuple("Sidecar", "meta multiple receptive_radius ensemble")


def read_sidecar(model_path: Path) -> Sidecar:
    """The model's sidecar JSON (beside it, .json) with the fields inference needs checked:
    the size multiple, the receptive radius and the default self-ensemble. A missing or
    invalid file raises DenoiserModelError naming it."""
    json_path = Path(model_path).with_suffix(".json")
    try:
        meta = json.loads(json_path.read_text())
        return Sidecar(meta, int(meta["multiple"]), int(meta["receptive_radius"]), sidecar_ensemble(meta))
    except FileNotFoundError:
        raise DenoiserModelError("the model's sidecar JSON (inputs and normalisation) is missing", json_path) from None
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise DenoiserModelError(f"the model's sidecar JSON is not valid ({e})", json_path) from None


def best_providers(available) -> list[str]:
    """onnxruntime providers in order of preference, those available here only."""
    chosen = [p for p in PREFERRED_PROVIDERS if p in available]
    return chosen or list(available)


class OnnxDenoiser:
    name = "onnx"

    def __init__(self, model_path=None, tile: int = DEFAULT_TILE, providers=None, threads: int | None = None,
                 ensemble: int | None = None):
        self.model_path = Path(model_path) if model_path is not None else DEFAULT_MODEL
        self.tile = int(tile)
        if ensemble is not None and ensemble not in ENSEMBLE_SIZES:
            raise ValueError(f"ensemble must be one of {ENSEMBLE_SIZES}, not {ensemble!r}")
        self.ensemble = ensemble
        self._providers = providers
        self._threads = threads
        self._session = None
        self.meta: dict | None = None

    # ---- loading (lazy) ----
    def _load(self) -> None:
        path = self.model_path
        if not path.is_file():
            raise DenoiserModelError("denoiser model file not found (train one with "
                                     "`python -m lift_gl.denoise.train`, see docs/denoiser.md)", path)
        meta, multiple, overlap, ensemble = read_sidecar(path)
        try:
            import onnxruntime as ort
        except ImportError:
            raise DenoiserModelError("the ONNX denoiser needs onnxruntime: pip install 'lift-gl[denoise]'",
                                     path) from None
        options = ort.SessionOptions()
        if self._threads:
            options.intra_op_num_threads = int(self._threads)
        providers = self._providers or best_providers(ort.get_available_providers())
        try:
            session = ort.InferenceSession(path.read_bytes(), options, providers=providers)
        except Exception as e:  # onnxruntime raises its own types for truncated or foreign files
            raise DenoiserModelError(f"not a loadable ONNX model ({type(e).__name__}: "
                                     f"{str(e).strip().splitlines()[0][:200]})", path) from None
        self.meta, self._multiple = meta, multiple
        if self.ensemble is None:
            self.ensemble = ensemble
        # tiles and their context are aligned to the network's multiple so that pooling grids agree
        self._overlap = -(-overlap // multiple) * multiple
        self._tile = max(multiple, self.tile // multiple * multiple)
        self._session = session

    @property
    def providers(self) -> list[str]:
        if self._session is None:
            self._load()
        return self._session.get_providers()

    # ---- denoising ----
    def _run(self, x: np.ndarray) -> np.ndarray:
        return self._session.run(None, {"input": x})[0]

    @property
    def temporal(self) -> bool:
        """Whether the model takes the previous frame (model_io.py: 13 input channels)."""
        if self._session is None:
            self._load()
        return self._session.get_inputs()[0].shape[1] == TEMPORAL_CHANNELS

    def denoise(self, color, albedo, normal, depth=None, variance=None, previous=None, valid=None) -> np.ndarray:
        """Denoised linear radiance (H, W, 3) float32; depth and variance are not used by this
        model; previous (H, W, 3: the last denoised frame reprojected here) and valid (H, W:
        1 where it holds, all 0 when absent) feed a temporal model and are ignored by others."""
        if self._session is None:
            self._load()
        color = checked_color(color, albedo, normal)
        x, exposure = network_input(color, albedo, normal, previous, valid, self.temporal)  # one exposure for every mirror image
        y = ensemble_mean(self._run_padded, x, self.ensemble)
        return network_output(y, exposure, albedo)

    def _run_padded(self, x: np.ndarray) -> np.ndarray:
        h, w = x.shape[2:]
        return run_tiled(self._run, pad_to_multiple(x, self._multiple), self._tile, self._overlap)[:, :, :h, :w]
