"""Accumulate pass (still camera): exact running mean of all frames since the last reset.

inputs:  frame (RGBA32F: radiance sum, valid sample count)
outputs: accumulation (sum and compensation, RGBA32F each); mean = (sum + c).rgb / (sum + c).a
"""
from __future__ import annotations

import numpy as np

from .. import shaders
from .common import groups

SOURCE = shaders.SHADER_DIR / "passes" / "accumulate.comp"


class AccumulatePass:
    name = "accumulate"
    inputs = ("frame",)
    outputs = ("accumulation",)

    def __init__(self, ctx, size):
        self.ctx = ctx
        self.size = size
        self.program = shaders.compile_compute(ctx, shaders.assemble(SOURCE))
        self.sum = ctx.texture(size, 4, dtype="f4")
        self.compensation = ctx.texture(size, 4, dtype="f4")
        self._pixel_fbo = None  # made on the first read_pixel (the viewer's pixel inspector)
        self.reset()

    def reset(self) -> None:
        zeros = np.zeros((self.size[1], self.size[0], 4), np.float32).tobytes()
        self.sum.write(zeros)
        self.compensation.write(zeros)

    def run(self, frame) -> None:
        frame.bind_to_image(0, read=True, write=False)
        self.sum.bind_to_image(1, read=True, write=True)
        self.compensation.bind_to_image(2, read=True, write=True)
        self.program.run(*groups(*self.size))

    def read_totals(self) -> np.ndarray:
        """(H, W, 4) float64 totals: rgb radiance sums and the sample count; row 0 = bottom."""
        w, h = self.size
        s = np.frombuffer(self.sum.read(), np.float32).reshape(h, w, 4).astype(np.float64)
        c = np.frombuffer(self.compensation.read(), np.float32).reshape(h, w, 4).astype(np.float64)
        return s + c

    def read_mean(self) -> np.ndarray:
        """(H, W, 3) float32 mean radiance, row 0 = top (image order)."""
        totals = self.read_totals()
        count = totals[..., 3:4]
        mean = np.divide(totals[..., :3], count, out=np.zeros_like(totals[..., :3]), where=count > 0)
        return np.ascontiguousarray(mean[::-1]).astype(np.float32)

    def read_pixel(self, x: int, y: int) -> tuple[np.ndarray, float]:
        """Mean radiance (float64 RGB) and sample count of one pixel, (x, y) in GL order
        (row 0 = bottom); reads back 2 texels, not the image."""
        if self._pixel_fbo is None:
            self._pixel_fbo = self.ctx.framebuffer([self.sum, self.compensation])
        texels = [np.frombuffer(self._pixel_fbo.read(viewport=(x, y, 1, 1), components=4, attachment=i,
                                                     dtype="f4"), np.float32).astype(np.float64)
                  for i in (0, 1)]
        total = texels[0] + texels[1]
        count = float(total[3])
        return (total[:3] / count if count > 0 else np.zeros(3)), count

    def release(self) -> None:
        for obj in (self.program, self.sum, self.compensation, self._pixel_fbo):
            if obj is not None:
                obj.release()
