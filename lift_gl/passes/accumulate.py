"""Accumulate pass: exact running mean of all frames since the last reset (still camera),
or of the frame added to the reprojected history (passes/reproject.py runs first then).

inputs:  frame (RGBA32F: radiance sum, valid sample count); with temporal reprojection, history
         (the accumulation as the reproject pass rewrote it for this frame's view: the same textures)
outputs: accumulation (sum and compensation, RGBA32F each); mean = (sum + c).rgb / (sum + c).a
         half difference (RGBA32F): frames of half A minus frames of half B since the reset
         (half_sign), for the error estimate without a reference (lift_gl/error_estimate.py)
         moments (RGBA32F): sum of the frames' luminance, of its square, number of frames
         (read_variance: the variance view, a denoiser's guide)
"""
from __future__ import annotations

import numpy as np

from .. import shaders
from .common import groups

SOURCE = shaders.SHADER_DIR / "passes" / "accumulate.comp"


def half_sign(frame: int) -> float:
    """+1 (half A) or -1 (half B) for the frame-th frame since the reset.

    Not the frame's parity: the subpixel jitter follows a Halton sequence whose base-2
    coordinate puts odd and even frames in opposite halves of the pixel, so a parity split
    would compare two different sub-pixel integrals, and at edges the estimate would stop
    falling. Instead each pair of frames (2k, 2k + 1) sends one frame to each half, which one
    decided by a hashed bit of k: the halves stay equal in size and each is a random half of
    the jitter sequence, an estimate of the whole pixel."""
    x = ((frame // 2) * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & 0xFFFFFFFFFFFFFFFF  # splitmix64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    first_to_a = (x ^ (x >> 31)) & 1
    return 1.0 if (frame % 2 == 0) == bool(first_to_a) else -1.0


class AccumulatePass:
    name = "accumulate"
    inputs = ("frame", "history?")
    outputs = ("accumulation", "half difference", "moments")

    def __init__(self, ctx, size):
        self.ctx = ctx
        self.size = size
        self.program = shaders.compile_compute(ctx, shaders.assemble(SOURCE))
        self._late_program = None  # with LIFT_LATE_SAMPLES: made on the first frame with late samples
        self.sum = ctx.texture(size, 4, dtype="f4")
        self.compensation = ctx.texture(size, 4, dtype="f4")
        self._pixel_fbo = None  # made on the first read_pixel (the viewer's pixel inspector)
        self.half_difference = ctx.texture(size, 4, dtype="f4")
        self.moments = ctx.texture(size, 4, dtype="f4")
        self.frames = 0  # since the reset: picks the half a frame goes to (half_sign)
        self.reset()

    def reset(self) -> None:
        zeros = np.zeros((self.size[1], self.size[0], 4), np.float32).tobytes()
        for texture in self.textures():
            texture.write(zeros)
        self.frames = 0

    def run(self, frame, late=None) -> None:
        """Add the frame; `late`: (image, tag image, tag) of samples of earlier frames' parked
        paths (passes/carry.py): the texels of that tag are added with it."""
        program = self.program
        if late is not None:
            if self._late_program is None:
                self._late_program = shaders.compile_compute(
                    self.ctx, shaders.assemble(SOURCE, defines={"LIFT_LATE_SAMPLES": True}))
            program = self._late_program
            image, tags, tag = late
            image.bind_to_image(5, read=True, write=False)
            tags.bind_to_image(6, read=True, write=False)
            program["u_late_frame_tag"].value = tag
        frame.bind_to_image(0, read=True, write=False)
        self.sum.bind_to_image(1, read=True, write=True)
        self.compensation.bind_to_image(2, read=True, write=True)
        self.half_difference.bind_to_image(3, read=True, write=True)
        self.moments.bind_to_image(4, read=True, write=True)
        program["u_half_sign"].value = half_sign(self.frames)
        program.run(*groups(*self.size))
        self.ctx.memory_barrier()  # the next frame's accumulation and the display read these images
        self.frames += 1

    def textures(self) -> tuple:
        """The state a reprojection rewrites (passes/reproject.py), in its binding order."""
        return self.sum, self.compensation, self.half_difference, self.moments

    def replace_textures(self, textures) -> tuple:
        """Take these textures as the state (the reprojected history); give back the old ones."""
        old = self.textures()
        self.sum, self.compensation, self.half_difference, self.moments = textures
        if self._pixel_fbo is not None:  # it reads the old sum and compensation
            self._pixel_fbo.release()
            self._pixel_fbo = None
        return old

    def read_variance(self) -> np.ndarray:
        """(H, W) float32, row 0 = top: per pixel, the variance of one frame's luminance
        estimate, from the moments of the frames so far (unbiased: divided by frames - 1);
        0 where fewer than two frames. The mean's variance is this / frames."""
        m = self._read(self.moments)
        frames = m[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = m[..., 0] / frames
            variance = (m[..., 1] / frames - mean * mean) * frames / (frames - 1)
        variance = np.where(frames > 1.5, np.maximum(variance, 0.0), 0.0)
        return np.ascontiguousarray(variance[::-1]).astype(np.float32)

    def _read(self, texture) -> np.ndarray:
        w, h = self.size
        return np.frombuffer(texture.read(), np.float32).reshape(h, w, 4).astype(np.float64)

    def read_totals(self) -> np.ndarray:
        """(H, W, 4) float64 totals: rgb radiance sums and the sample count; row 0 = bottom."""
        return self._read(self.sum) + self._read(self.compensation)

    def read_half_difference(self) -> np.ndarray:
        """(H, W, 4) float64: totals of half A minus totals of half B (rgb sums, sample
        count); row 0 = bottom."""
        return self._read(self.half_difference)

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
        for obj in (self.program, self._late_program, *self.textures(), self._pixel_fbo):
            if obj is not None:
                obj.release()
