"""Tonemap pass: accumulated mean radiance -> display sRGB (RGBA8), as lift_gl/tonemap.py.

inputs:  accumulation (sum, compensation), or the denoised image where it is current
outputs: display (RGBA8, sRGB-encoded)
"""
from __future__ import annotations

import numpy as np

from .. import shaders
from ..tonemap import OPERATORS
from .common import groups

SOURCE = shaders.SHADER_DIR / "passes" / "tonemap.comp"


class TonemapPass:
    name = "tonemap"
    inputs = ("accumulation", "denoised?")
    outputs = ("display",)

    def __init__(self, ctx, size):
        self.size = size
        self.ctx = ctx
        self.program = shaders.compile_compute(ctx, shaders.assemble(SOURCE))
        self.display = ctx.texture(size, 4, dtype="f1")

    def run(self, accumulate, exposure: float = 0.0, operator: str = "aces", gamma: float | None = None) -> None:
        """gamma None: the sRGB curve; a number g > 0: encode x^(1/g) instead."""
        if operator not in OPERATORS:
            raise ValueError(f"unknown tone mapping operator {operator!r}; choose one of {', '.join(OPERATORS)}")
        if gamma is not None and not gamma > 0:
            raise ValueError(f"display gamma must be positive, not {gamma!r}")
        self.program["u_exposure"].value = float(exposure)
        self.program["u_operator"].value = OPERATORS.index(operator)
        self.program["u_gamma"].value = 0.0 if gamma is None else float(gamma)
        accumulate.sum.bind_to_image(1, read=True, write=False)
        accumulate.compensation.bind_to_image(2, read=True, write=False)
        self.display.bind_to_image(3, read=False, write=True)
        self.program.run(*groups(*self.size))
        self.ctx.memory_barrier()  # what reads the display image comes next

    def read(self) -> np.ndarray:
        """uint8 (H, W, 3) sRGB, row 0 = top."""
        w, h = self.size
        rgba = np.frombuffer(self.display.read(), np.uint8).reshape(h, w, 4)
        return np.ascontiguousarray(rgba[::-1, :, :3])

    def release(self) -> None:
        self.program.release()
        self.display.release()
