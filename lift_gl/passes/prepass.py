"""Prepass: a plugin's `[prepass]` function for every pixel sample, before the trace pass.

inputs:  scene buffers, camera
outputs: prepass (the plugin's storage: `entries` uvec4s a pixel sample, shaders/lift/prepass.glsl),
         which the trace pass's radiance() of the same pixel sample reads; splats, where the
         plugin has them (they go into the trace pass's splat buffer, added after the trace)

Why a pass of its own: work that a megakernel would keep per invocation (bdpt's light subpath,
in a local array that on a GPU lives in slow local memory) is written to global buffers that
the next pass reads coalesced, and each pass runs with only its own half's registers (as in
Davidovic et al. 2014, "Progressive light transport simulation on the GPU").

The program is shaders/lift/host_prepass.comp after the trace programs' generated head
(passes/trace.py): the same work groups over the same tiles as the trace pass, and each
sample's random numbers as the trace pass draws them.
"""
from __future__ import annotations

from dataclasses import dataclass

import moderngl

from .. import shaders
from ..bindings import STORAGE_BUFFERS
from ..errors import LimitError
from ..plugins import Plugin
from .common import groups, set_uniforms, tile_dispatch_size
from .trace import host_defines, program_head

HOST_PREPASS = "lift/host_prepass.comp"
MAX_BUFFERS = 4          # binding points prepass0..3 (lift_gl/bindings.py)
UVEC4_BYTES = 16


@dataclass(frozen=True)
class PrepassLayout:
    """Where the prepass's entries go: `buffers` storage buffers of `buffer_entries` entries,
    each entry a run of one uvec4 per pixel sample of the frame."""
    entries: int          # uvec4s a pixel sample
    invocations: int      # of one dispatch: the image in whole work groups
    buffers: int
    buffer_entries: int
    max_block: int        # the driver's largest storage block, bytes

    def defines(self) -> dict:
        return {"LIFT_PREPASS": True, "LIFT_PREPASS_BUFFERS": self.buffers,
                "LIFT_PREPASS_BUFFER_ENTRIES": self.buffer_entries}

    def stride(self, samples: int) -> int:
        """The pixel samples of a frame of `samples` per pixel: each entry's run."""
        return self.invocations * samples

    def buffer_bytes(self, samples: int) -> int:
        return self.buffer_entries * self.stride(samples) * UVEC4_BYTES


def prepass_layout(ctx, plugin: Plugin, params: dict, size, defines: dict, local_size, samples: int) -> PrepassLayout:
    """The fewest buffers that hold `samples` per pixel of the plugin's entries; LimitError
    where four would not."""
    entries = plugin.prepass.entry_count(dict(plugin.defaults(), **params))
    gx, gy, _ = groups(*tile_dispatch_size(defines, size, local_size), local_size)
    invocations = gx * gy * local_size[0] * local_size[1]
    max_block = int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
    per_buffer = max_block // (invocations * samples * UVEC4_BYTES)
    buffers = -(-entries // per_buffer) if per_buffer > 0 else MAX_BUFFERS + 1
    if buffers > MAX_BUFFERS:
        raise LimitError(f"plugin {plugin.name}: its prepass needs {entries} x 16 bytes for each of "
                         f"{invocations * samples} pixel samples ({size[0]}x{size[1]}, {samples} a frame), "
                         f"more than {MAX_BUFFERS} storage buffers of {max_block / 2**20:.0f} MiB "
                         "(GL_MAX_SHADER_STORAGE_BLOCK_SIZE): fewer samples a frame, a smaller image or "
                         "shorter paths fit")
    return PrepassLayout(entries, invocations, buffers, -(-entries // buffers), max_block)


class PrepassPass:
    name = "prepass"
    inputs = ("scene", "camera")
    outputs = ("prepass",)

    def __init__(self, ctx: moderngl.Context, size, plugin: Plugin, defines: dict, choices, layout: PrepassLayout):
        self.ctx = ctx
        self.size = size
        self.plugin = plugin
        self.layout = layout
        defines, self.local_size = host_defines(ctx, plugin, dict(defines, **layout.defines()), choices)
        self.defines = defines
        text = (program_head(plugin, self.local_size)
                + f'\n// ---- host ----\n#define LIFT_PREPASS_FUNCTION {plugin.prepass.function}\n'
                + f'#include "{HOST_PREPASS}"\n')
        self.source = shaders.assemble(text, defines, include_dirs=[plugin.folder],
                                       main_name=f"<{plugin.name} prepass host main>")
        self.program = shaders.compile_compute(ctx, self.source)
        self.buffers = []
        self.samples = 0   # the samples a frame the buffers hold

    def uniforms(self, samples: int) -> dict:
        """What both passes index the storage by, for a frame of `samples` per pixel."""
        return {"u_prepass_invocations": self.layout.invocations, "u_prepass_stride": self.layout.stride(samples)}

    def _allocate(self, samples: int) -> None:
        if samples <= self.samples:
            return
        nbytes = self.layout.buffer_bytes(samples)
        if nbytes > self.layout.max_block:
            raise LimitError(f"plugin {self.plugin.name}: {samples} samples a frame need prepass buffers of "
                             f"{nbytes / 2**20:.0f} MiB, more than GL_MAX_SHADER_STORAGE_BLOCK_SIZE "
                             f"({self.layout.max_block / 2**20:.0f} MiB): at most {self.samples} a frame here")
        for buffer in self.buffers:
            buffer.release()
        self.buffers = [self.ctx.buffer(reserve=nbytes) for _ in range(self.layout.buffers)]
        self.samples = samples

    def bind(self) -> None:
        for k, buffer in enumerate(self.buffers):
            buffer.bind_to_storage_buffer(STORAGE_BUFFERS[f"prepass{k}"])

    def run(self, uniforms: dict, splats=None) -> None:
        """One frame of u_samples per pixel; `splats`: the trace pass's splat buffer."""
        self._allocate(int(uniforms["u_samples"]))
        set_uniforms(self.program, uniforms)
        self.bind()
        if splats is not None:
            splats.bind()
        self.program.run(*groups(*tile_dispatch_size(self.defines, self.size, self.local_size), self.local_size))
        self.ctx.memory_barrier()   # the trace pass reads what it stored

    def release(self) -> None:
        self.program.release()
        for buffer in self.buffers:
            buffer.release()
