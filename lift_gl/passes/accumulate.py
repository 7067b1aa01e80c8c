"""Accumulate pass (still camera): exact running mean of all frames since the last reset.

inputs:  frame (RGBA32F: radiance sum, valid sample count)
outputs: accumulation (sum and compensation, RGBA32F each); mean = (sum + c).rgb / (sum + c).a
         half difference (RGBA32F): even frames minus odd frames since the reset, for the
         error estimate without a reference (lift_gl/error_estimate.py)
"""
from __future__ import annotations

import numpy as np

from .. import shaders
from .common import groups

SOURCE = shaders.SHADER_DIR / "passes" / "accumulate.comp"


class AccumulatePass:
    name = "accumulate"
    inputs = ("frame",)
    outputs = ("accumulation", "half difference")

    def __init__(self, ctx, size):
        self.ctx = ctx
        self.size = size
        self.program = shaders.compile_compute(ctx, shaders.assemble(SOURCE))
        self.sum = ctx.texture(size, 4, dtype="f4")
        self.compensation = ctx.texture(size, 4, dtype="f4")
        self.half_difference = ctx.texture(size, 4, dtype="f4")
        self.frames = 0  # since the reset: its parity picks the half a frame goes to
        self.reset()

    def reset(self) -> None:
        zeros = np.zeros((self.size[1], self.size[0], 4), np.float32).tobytes()
        for texture in (self.sum, self.compensation, self.half_difference):
            texture.write(zeros)
        self.frames = 0

    def run(self, frame) -> None:
        frame.bind_to_image(0, read=True, write=False)
        self.sum.bind_to_image(1, read=True, write=True)
        self.compensation.bind_to_image(2, read=True, write=True)
        self.half_difference.bind_to_image(3, read=True, write=True)
        self.program["u_half_sign"].value = 1.0 if self.frames % 2 == 0 else -1.0
        self.program.run(*groups(*self.size))
        self.frames += 1

    def _read(self, texture) -> np.ndarray:
        w, h = self.size
        return np.frombuffer(texture.read(), np.float32).reshape(h, w, 4).astype(np.float64)

    def read_totals(self) -> np.ndarray:
        """(H, W, 4) float64 totals: rgb radiance sums and the sample count; row 0 = bottom."""
        return self._read(self.sum) + self._read(self.compensation)

    def read_half_difference(self) -> np.ndarray:
        """(H, W, 4) float64: even-frame totals minus odd-frame totals (rgb sums, sample
        count); row 0 = bottom."""
        return self._read(self.half_difference)

    def read_mean(self) -> np.ndarray:
        """(H, W, 3) float32 mean radiance, row 0 = top (image order)."""
        totals = self.read_totals()
        count = totals[..., 3:4]
        mean = np.divide(totals[..., :3], count, out=np.zeros_like(totals[..., :3]), where=count > 0)
        return np.ascontiguousarray(mean[::-1]).astype(np.float32)

    def release(self) -> None:
        for obj in (self.program, self.sum, self.compensation, self.half_difference):
            obj.release()
