"""Reduced trace pass: a plugin's second estimate (its `[reduced]` function) for one pixel in
every scale x scale block (a hybrid plugin's indirect light).

inputs:  scene buffers, camera, G-buffer visibility (the full-resolution first hits) and albedo
outputs: reduced (RGBA32F, ceil(W / scale) x ceil(H / scale): the estimate divided by the
         first hit's albedo, summed over this frame's samples, in rgb; their count in a;
         0 samples where the first hit is black or missing: no information to spread)

Block b is represented by full-resolution pixel b * scale + offset, where the offset is the
same for the whole frame and walks over the block from frame to frame (`block_offset`), so
that over scale^2 frames every pixel is traced. The estimate is demodulated (divided by the
albedo of the surface it starts from) so that the upsampling pass can multiply each pixel's
own albedo back in: material and texture edges stay sharp. Both passes take that albedo from
the G-buffer (textures applied, as the denoiser's guide), so that demodulating and remodulating
one pixel cancel exactly. The upsampling pass (passes/upsample.py) reads the guides (normal,
depth) of the same representative pixels from the G-buffer. The program is
shaders/lift/host_reduced.comp after the trace programs' generated head (passes/trace.py).
"""
from __future__ import annotations

import moderngl

from .. import shaders
from ..plugins import Plugin
from .camera import halton
from .common import LOCAL_SIZE, groups, set_uniforms
from .trace import program_head

HOST_REDUCED = "lift/host_reduced.comp"   # the program's host file: the sample loop, the guard

OFFSET_BASES = (5, 7)  # Halton bases for the block offsets: unlike the subpixel jitter's (2, 3)


def block_offset(frame: int, scale: int) -> tuple[int, int]:
    """The representative pixel of every block in this frame: a low-discrepancy walk over
    the scale x scale block."""
    return (int(halton(frame + 1, OFFSET_BASES[0]) * scale), int(halton(frame + 1, OFFSET_BASES[1]) * scale))


def reduced_size(size, scale: int) -> tuple[int, int]:
    return (-(-size[0] // scale), -(-size[1] // scale))


def generate_main(plugin: Plugin) -> str:
    """The reduced pass's program: the trace programs' head, then its host file, which calls
    the manifest's [reduced] function."""
    return (program_head(plugin, (LOCAL_SIZE, LOCAL_SIZE))
            + f'\n// ---- host ----\n#define LIFT_REDUCED_RADIANCE {plugin.reduced.function}\n#include "{HOST_REDUCED}"\n')


class ReducedTracePass:
    name = "reduced"
    inputs = ("scene", "camera", "visibility", "albedo")
    outputs = ("reduced",)

    def __init__(self, ctx: moderngl.Context, size, plugin: Plugin, defines: dict):
        self.ctx = ctx
        self.size = size
        self.plugin = plugin
        self.source = shaders.assemble(generate_main(plugin), dict(defines), include_dirs=[plugin.folder],
                                       main_name=f"<{plugin.name} reduced-resolution host main>")
        self.program = shaders.compile_compute(ctx, self.source)
        self.scale = None
        self.reduced = None

    def _allocate(self, scale: int) -> None:
        if scale == self.scale:
            return
        if self.reduced is not None:
            self.reduced.release()
        self.scale = scale
        self.reduced = self.ctx.texture(reduced_size(self.size, scale), 4, dtype="f4")

    def run(self, uniforms: dict, gbuffer, scale: int, offset: tuple[int, int]) -> None:
        self._allocate(int(scale))
        set_uniforms(self.program, dict(uniforms, u_scale=self.scale, u_block_offset=offset))
        for unit, (name, texture) in enumerate((("u_visibility", gbuffer.visibility), ("u_albedo", gbuffer.albedo))):
            texture.use(location=unit)
            self.program[name].value = unit
        self.reduced.bind_to_image(0, read=False, write=True)
        self.program.run(*groups(*self.reduced.size))
        self.ctx.memory_barrier()  # the upsampling reads it

    def release(self) -> None:
        self.program.release()
        if self.reduced is not None:
            self.reduced.release()
