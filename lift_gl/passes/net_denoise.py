"""Network denoise pass: the GLSL network (lift_gl/denoise/glsl_net.py) fed from the renderer's
textures, with no readback: what GlslDenoiser.denoise does in numpy (model_io.network_input,
tiling's edge padding, model_io.network_output), done by three compute shaders.

inputs:  accumulation (sum, compensation), G-buffer albedo and normal_depth
outputs: radiance (RGBA32F, a = 1, the renderer's row order), the texture DenoisePass shows

net_exposure_blocks.comp, net_exposure.comp  the autoexposure: each 16x16 block's log mean
                   luminance (a work group a block), then their average, into an SSBO's word 0
net_input.comp     the (9, H', W') input tensor: demodulated mean x exposure, albedo, normal;
                   y flipped to the tensor's top-first rows, padded to the net's multiple
GlslNet.run()      the network
net_output.comp    cropped, divided by the exposure, times the albedo, y flipped back

A temporal model (13 input channels, model_io.py) also gets the previous frame's denoised
output: net_output.comp keeps it demodulated in `history`, and net_input.comp reads it back
the next frame, reprojected by the frame's motion vectors with the accumulation's own tap
rules (shaders/passes/history_taps.glsl), with its validity. The history holds when this pass
denoised the previous frame on that frame's own G-buffer (`history=True`, denoise every) and
the accumulation went on since (no reset: not the first frame, no camera cut, no resize).
"""
from __future__ import annotations

from .. import shaders
from ..bindings import STORAGE_BUFFERS
from ..denoise.demodulate import EPS
from ..denoise.model_io import EXPOSURE_BLOCK, EXPOSURE_KEY, EXPOSURE_RANGE, TEMPORAL_CHANNELS
from .common import groups, set_uniforms
from .reproject import DEPTH_SLACK, NORMAL_COS

SHADER_DIR = shaders.SHADER_DIR / "passes"
EXPOSURE_BINDING = STORAGE_BUFFERS["net_exposure"]   # apart from the convs' weights (0, 1)


class NetDenoise:
    name = "net denoise"
    inputs = ("accumulation", "albedo", "normal_depth")
    outputs = ("radiance",)

    def __init__(self, ctx, size, net):
        if net.input_channels not in (9, TEMPORAL_CHANNELS) or net.output_channels < 3:
            raise ValueError(f"{net.model_path}: the renderer's network input is 9 channels (13 with the previous "
                             f"frame) -> 3 (model_io.py), not {net.input_channels} -> {net.output_channels}")
        self.ctx = ctx
        self.size = tuple(size)
        self.net = net
        self.temporal = net.input_channels == TEMPORAL_CHANNELS
        w, h = self.size
        self.padded = (w + -w % net.multiple, h + -h % net.multiple)
        tensor = {**net.tensor_defines, **({"TEMPORAL": 1} if self.temporal else {})}
        self.blocks = shaders.compile_compute(ctx, shaders.assemble(SHADER_DIR / "net_exposure_blocks.comp"))
        self.exposure = shaders.compile_compute(ctx, shaders.assemble(SHADER_DIR / "net_exposure.comp"))
        self._tensor_defines = tensor
        self._inputs = {}  # with motion vectors or not: compiled on first use
        self.remodulate = shaders.compile_compute(ctx, shaders.assemble(SHADER_DIR / "net_output.comp", tensor))
        count = self._block_uniforms()["u_block_count"]
        self.exposure_buffer = ctx.buffer(reserve=4 * (1 + count[0] * count[1]))  # the exposure, then each block
        self.output = ctx.texture(self.size, 4, dtype="f4")
        self.history = ctx.texture(self.size, 4, dtype="f4") if self.temporal else None
        self._denoised_at = None  # accumulate.frames when this pass last wrote the history

    def _input_program(self, motion: bool):
        if motion not in self._inputs:
            defines = dict(self._tensor_defines, **({"HISTORY_MOTION": 1} if motion and self.temporal else {}))
            self._inputs[motion] = shaders.compile_compute(self.ctx, shaders.assemble(SHADER_DIR / "net_input.comp",
                                                                                      defines))
        return self._inputs[motion]

    def _block_uniforms(self) -> dict:
        """model_io.autoexposure's blocks: 16 a side, or the whole side when it is shorter."""
        w, h = self.size
        b = EXPOSURE_BLOCK
        return {"u_block": (min(b, w), min(b, h)), "u_block_count": (max(w // b, 1), max(h // b, 1)),
                "u_key": EXPOSURE_KEY, "u_range": tuple(float(r) for r in EXPOSURE_RANGE)}

    def run(self, accumulate, gbuffer, history: bool = False):
        """Denoise the accumulation's mean into self.output (returned); `history`: the guides
        are this frame's own G-buffer, so a temporal model may take the previous frame."""
        self.net.allocate(*self.padded)  # a no-op unless the net ran at another size meanwhile
        common = {"u_albedo": 0, "u_albedo_eps": EPS, "u_normal_depth": 1, "u_size": self.size}
        accumulate.sum.bind_to_image(0, read=True, write=False)
        accumulate.compensation.bind_to_image(1, read=True, write=False)
        gbuffer.albedo.use(location=0)
        gbuffer.normal_depth.use(location=1)
        self.exposure_buffer.bind_to_storage_buffer(EXPOSURE_BINDING)
        blocks = self._block_uniforms()
        set_uniforms(self.blocks, {**common, **blocks})
        self.blocks.run(*blocks["u_block_count"], 1)
        self.ctx.memory_barrier()
        set_uniforms(self.exposure, {**common, **blocks})
        self.exposure.run(1, 1, 1)
        self.ctx.memory_barrier()
        self.net.input_texture.bind_to_image(7, read=False, write=True)
        motion = history and getattr(gbuffer, "motion", None) is not None
        program = self._input_program(motion)
        uniforms = dict(common)
        if self.temporal:
            uniforms.update(self._history_inputs(accumulate, gbuffer, history, motion))
        set_uniforms(program, uniforms)
        program.run(*groups(*self.padded))
        self.ctx.memory_barrier()
        self.net.run()
        gbuffer.albedo.use(location=0)
        self.net.output_texture.bind_to_image(6, read=True, write=False)
        self.output.bind_to_image(7, read=False, write=True)
        if self.temporal:
            self.history.bind_to_image(5, read=False, write=True)
            self._denoised_at = accumulate.frames if history else None
        set_uniforms(self.remodulate, common)
        self.remodulate.run(*groups(*self.size))
        self.ctx.memory_barrier()
        return self.output

    def _history_inputs(self, accumulate, gbuffer, history: bool, motion: bool) -> dict:
        """Bind the history's textures (units 2-4); its uniforms. It holds only where this
        pass denoised the frame just before on its own G-buffer, the accumulation going on."""
        valid = history and self._denoised_at is not None and accumulate.frames == self._denoised_at + 1
        self.history.use(location=2)
        uniforms = {"u_history": 2, "u_history_valid": int(valid)}
        if motion:
            gbuffer.prev_normal_depth.use(location=3)
            gbuffer.motion.use(location=4)
            uniforms.update(u_prev_normal_depth=3, u_motion=4, u_depth_slack=DEPTH_SLACK, u_normal_cos=NORMAL_COS)
        return uniforms

    def release(self) -> None:
        for obj in (self.blocks, self.exposure, *self._inputs.values(), self.remodulate, self.exposure_buffer,
                    self.output, *([self.history] if self.history is not None else [])):
            obj.release()
