"""Reproject pass (temporal): the accumulation rewritten as the new camera sees it; runs
only on frames where the camera or an object moved since the previous frame.

inputs:  previous accumulation (sum, compensation, half difference, moments); the G-buffer's
         normal_depth, previous normal_depth and motion; the frame (neighbourhood clamp only)
outputs: history: the same accumulation buffers, reprojected (the accumulate pass then adds
         the frame); rejection (RGBA32F: bilinear weight rejected by depth, by normal, off
         screen or no surface here)

Written into a second set of textures, which then change places with the accumulate
pass's (no copy). shaders/passes/reproject.comp has the method.
"""
from __future__ import annotations

import moderngl
import numpy as np

from .. import shaders
from .common import groups, set_uniforms

SOURCE = shaders.SHADER_DIR / "passes" / "reproject.comp"
DEPTH_SLACK = 0.01  # relative view depth difference always allowed (float rounding, jitter)
NORMAL_COS = 0.9    # normals within 25.8 degrees match


class ReprojectPass:
    name = "reproject"
    inputs = ("previous accumulation", "normal_depth", "previous normal_depth", "motion", "frame")
    outputs = ("history", "rejection")

    def __init__(self, ctx, size):
        self.ctx = ctx
        self.size = size
        self.program = shaders.compile_compute(ctx, shaders.assemble(SOURCE))
        self.spare = tuple(ctx.texture(size, 4, dtype="f4") for _ in range(4))
        self.rejection = ctx.texture(size, 4, dtype="f4")
        self.rejection.write(np.zeros((size[1], size[0], 4), np.float32).tobytes())
        self.runs = 0  # frames reprojected since the renderer was made

    def run(self, accumulate, gbuffer, frame, history_cap: float, clamp_sigma: float = 0.0) -> None:
        inputs = {"u_prev_sum": accumulate.sum, "u_prev_compensation": accumulate.compensation,
                  "u_prev_half_difference": accumulate.half_difference, "u_prev_moments": accumulate.moments,
                  "u_prev_normal_depth": gbuffer.prev_normal_depth, "u_normal_depth": gbuffer.normal_depth,
                  "u_motion": gbuffer.motion, "u_frame": frame}
        for unit, texture in enumerate(inputs.values()):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            texture.use(location=unit)
        set_uniforms(self.program, {name: unit for unit, name in enumerate(inputs)})   # skips dropped samplers
        for unit, texture in enumerate(self.spare + (self.rejection,)):
            texture.bind_to_image(unit, read=False, write=True)
        self.program["u_history_cap"].value = float(history_cap)
        self.program["u_depth_slack"].value = DEPTH_SLACK
        self.program["u_normal_cos"].value = NORMAL_COS
        self.program["u_clamp_sigma"].value = float(clamp_sigma)
        self.ctx.memory_barrier()  # the frame and the accumulation were written as images
        self.program.run(*groups(*self.size))
        self.ctx.memory_barrier()
        self.spare = accumulate.replace_textures(self.spare)
        self.runs += 1

    def read_rejection(self) -> np.ndarray:
        """(H, W, 3) float32, row 0 = top: the last reprojection's rejected bilinear weight
        by depth (r), by normal (g), off screen or no surface (b); 0 before any."""
        w, h = self.size
        data = np.frombuffer(self.rejection.read(), np.float32).reshape(h, w, 4)[..., :3]
        return np.ascontiguousarray(data[::-1])

    def release(self) -> None:
        for obj in (self.program, *self.spare, self.rejection):
            obj.release()
