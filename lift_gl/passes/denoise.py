"""Denoise pass: the accumulated mean -> a denoised radiance image, on the G-buffer's guides.

inputs:  accumulation (sum, compensation), half difference (the variance guide), G-buffer
         albedo and normal_depth (through the pixel centres, or the frame's own G-buffer where it
         denoises every frame: lift_gl/frame.py guides, frame_guides)
outputs: denoised (RGBA32F: radiance, a = 1)

The à-trous denoiser runs on the GPU from end to end: denoise_input.comp demodulates the
mean by the albedo and adds the variance of its luminance (shaders/passes/
denoise_variance.glsl), then passes/atrous.py filters and multiplies the albedo back. A numpy
denoiser (onnx, oidn) gets the mean, the guides and the variance read back, and its result
is uploaded again, so the tonemap pass and the viewer see it the same way. The GLSL network
(denoiser "glsl") stays on the GPU instead: passes/net_denoise.py builds its input from these
textures and remodulates its output, with no readback.

`sum` and `compensation` name the output as the accumulation names its buffers, so the
tonemap pass shows the denoised image by being handed this pass instead of the accumulation.
"""
from __future__ import annotations

import numpy as np

from .. import shaders
from ..denoise.demodulate import EPS
from .atrous import AtrousFilter, AtrousSettings
from .common import groups, set_uniforms

SOURCE = shaders.SHADER_DIR / "passes" / "denoise_input.comp"


class DenoisePass:
    name = "denoise"
    inputs = ("accumulation", "half difference", "albedo", "normal_depth")
    outputs = ("denoised",)

    def __init__(self, ctx, size, denoiser_name: str, numpy_denoiser=None, settings: AtrousSettings | None = None):
        self.ctx = ctx
        self.size = tuple(size)
        self.denoiser_name = denoiser_name
        self.numpy_denoiser = numpy_denoiser  # None: the GPU à-trous filter
        self.atrous = self.input = self.irradiance = self.output = self.net = None
        if getattr(numpy_denoiser, "name", None) == "glsl":
            from .net_denoise import NetDenoise

            if getattr(numpy_denoiser, "ensemble", None) not in (None, 1):  # said, not silently ignored
                from ..errors import DenoiserError

                raise DenoiserError("the renderer's glsl denoiser runs the network once on its textures: "
                                    "ensemble > 1 is for the onnx denoiser or GlslDenoiser.denoise on arrays")

            self.net = NetDenoise(ctx, self.size, numpy_denoiser.network())
            self.output = self.net.output  # _run_numpy (the readback road, for comparison) writes here too
        elif numpy_denoiser is None:
            self.input = shaders.compile_compute(ctx, shaders.assemble(SOURCE))
            self.irradiance = ctx.texture(self.size, 4, dtype="f4")
            self.atrous = AtrousFilter(ctx, self.size, settings)
        else:
            self.output = ctx.texture(self.size, 4, dtype="f4")
        self.compensation = ctx.texture(self.size, 4, dtype="f4")  # zeros: the tonemap adds it
        self.compensation.write(np.zeros((self.size[1], self.size[0], 4), np.float32).tobytes())

    @property
    def sum(self):
        return self.output

    def run(self, accumulate, gbuffer, history: bool = False) -> None:
        """history: `gbuffer` is this frame's own (denoise every), so a temporal network may
        take the previous frame's output (passes/net_denoise.py)."""
        if self.net is not None:
            self.net.run(accumulate, gbuffer, history)
            return
        if self.numpy_denoiser is not None:
            self._run_numpy(accumulate, gbuffer)
            return
        accumulate.sum.bind_to_image(0, read=True, write=False)
        accumulate.compensation.bind_to_image(1, read=True, write=False)
        accumulate.half_difference.bind_to_image(2, read=True, write=False)
        self.irradiance.bind_to_image(3, read=False, write=True)
        gbuffer.albedo.use(location=0)
        set_uniforms(self.input, {"u_albedo": 0, "u_albedo_eps": EPS})
        self.input.run(*groups(*self.size))
        self.ctx.memory_barrier()
        self.output = self.atrous.run(self.irradiance, gbuffer.normal_depth, gbuffer.albedo, EPS)

    def _run_numpy(self, accumulate, gbuffer) -> None:
        from ..denoise.variance import luminance_variance

        w, h = self.size
        albedo = np.frombuffer(gbuffer.albedo.read(), np.float16).reshape(h, w, 4)[::-1, :, :3].astype(np.float32)
        nd = np.frombuffer(gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)[::-1]
        variance = luminance_variance(accumulate.read_totals(), accumulate.read_half_difference())[::-1]
        result = self.numpy_denoiser.denoise(accumulate.read_mean(), np.ascontiguousarray(albedo),
                                             np.ascontiguousarray(nd[..., :3]), np.ascontiguousarray(nd[..., 3]),
                                             np.ascontiguousarray(variance))
        result = np.nan_to_num(np.asarray(result, np.float32).reshape(h, w, 3), nan=0.0, posinf=0.0, neginf=0.0)
        rgba = np.dstack([result, np.ones((h, w), np.float32)])[::-1]
        self.output.write(np.ascontiguousarray(rgba).tobytes())

    def read(self) -> np.ndarray:
        """(H, W, 3) float32 denoised radiance, row 0 = top."""
        w, h = self.size
        rgba = np.frombuffer(self.output.read(), np.float32).reshape(h, w, 4)
        return np.ascontiguousarray(rgba[::-1, :, :3])

    def release(self) -> None:
        for obj in (self.input, self.irradiance, self.compensation):
            if obj is not None:
                obj.release()
        if self.net is not None:
            self.net.release()  # owns self.output
        elif self.atrous is not None:
            self.atrous.release()  # owns self.output in the GPU case
        elif self.output is not None:
            self.output.release()
