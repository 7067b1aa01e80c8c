"""What the ONNX denoiser's network sees and gives back, in numpy (shared by training and
inference, so that both prepare inputs the same way).

Input (1, 9, H, W) float32: demodulated radiance times an exposure (3), albedo clipped to
[0, 1] (3), world-space normal in [-1, 1] (3); a temporal model's (1, 13, H, W) adds the
previous frame's denoised radiance reprojected to this frame, demodulated and exposed as the
colour is (3), and its validity (1): both 0 where the validity is 0 (disoccluded, the first
frame, after a cut), so that no history means exactly zeros there. The network itself takes the colour into a log
domain and its output back (that transform is inside the ONNX graph; the sidecar names it).
Output (1, 3, H, W): the denoised demodulated radiance times the same exposure. The sidecar JSON beside the .onnx file
says the same for other programs.
"""
from __future__ import annotations

import numpy as np

from .demodulate import demodulate, remodulate

EXPOSURE_KEY = 0.18  # the exposure maps the image's log-average luminance to this
EXPOSURE_BLOCK = 16  # luminance is averaged over blocks first, so 1-spp noise does not bias the key
EXPOSURE_RANGE = (1e-4, 1e4)
LUMINANCE = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
TEMPORAL_CHANNELS = 13  # a temporal model's input channels (train/model.py input_channels)


def clean(image: np.ndarray) -> np.ndarray:
    """Finite, non-negative float32 (a stray NaN/Inf or negative sample must not reach the network)."""
    image = np.nan_to_num(np.asarray(image, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    return np.maximum(image, 0.0)


def autoexposure(color: np.ndarray) -> float:
    """The scale that brings the image's log-average luminance (of 16x16 block means) to 0.18."""
    lum = clean(color) @ LUMINANCE
    h, w = lum.shape
    b = EXPOSURE_BLOCK
    hb, wb = max(h // b, 1), max(w // b, 1)
    blocks = lum[: hb * b, : wb * b].reshape(hb, min(b, h), wb, min(b, w)).mean(axis=(1, 3))
    lit = blocks[blocks > 1e-8]
    if lit.size == 0:
        return 1.0
    key = float(np.exp(np.mean(np.log(lit))))
    return float(np.clip(EXPOSURE_KEY / key, *EXPOSURE_RANGE))


def checked_color(color, albedo, normal) -> np.ndarray:
    """The colour as float32 (H, W, 3), its guides checked to have its shape (ValueError)."""
    color = np.asarray(color, dtype=np.float32)
    if color.ndim != 3 or color.shape[2] != 3:
        raise ValueError(f"color must be (H, W, 3), not {color.shape}")
    for label, guide in (("albedo", albedo), ("normal", normal)):
        if np.shape(guide) != color.shape:
            raise ValueError(f"{label} must have the colour's shape {color.shape}, not {np.shape(guide)}")
    return color


def network_input(color, albedo, normal, previous=None, valid=None, temporal: bool = False) -> tuple[np.ndarray, float]:
    """(1, 9, H, W) float32 network input and the exposure used (see the module docstring);
    `temporal`: (1, 13, H, W) with `previous` (H, W, 3 linear radiance) where `valid` (H, W)
    is 1, zeros where it is 0 or absent."""
    albedo = np.clip(clean(albedo), 0.0, 1.0)
    demod = demodulate(clean(color), albedo)
    exposure = autoexposure(demod)
    normal = np.clip(np.nan_to_num(np.asarray(normal, dtype=np.float32)), -1.0, 1.0)
    parts = [demod * np.float32(exposure), albedo, normal]
    if temporal:
        h, w = demod.shape[:2]
        valid = np.zeros((h, w), np.float32) if valid is None else np.clip(clean(valid), 0.0, 1.0)
        if valid.shape != (h, w):
            raise ValueError(f"valid must be (H, W) = {(h, w)}, not {valid.shape}")
        if previous is None:
            previous = np.zeros_like(demod)
        elif np.shape(previous) != demod.shape:
            raise ValueError(f"previous must have the colour's shape {demod.shape}, not {np.shape(previous)}")
        held = valid[..., None] > 0  # a select, so that no history is exactly 0 whatever `previous` holds
        history = np.where(held, demodulate(clean(previous), albedo) * np.float32(exposure), np.float32(0.0))
        parts += [history.astype(np.float32), valid[..., None]]
    x = np.concatenate(parts, axis=2)
    return np.ascontiguousarray(x.transpose(2, 0, 1)[None]), exposure


def network_output(y: np.ndarray, exposure: float, albedo) -> np.ndarray:
    """Radiance (H, W, 3) float32 from the network's output (1, 3, H, W)."""
    demod = clean(y[0].transpose(1, 2, 0)) / np.float32(exposure)
    return remodulate(demod, np.clip(clean(albedo), 0.0, 1.0))
