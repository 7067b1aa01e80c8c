"""Splat buffer: lets a trace plugin add to any pixel of the frame (light tracing).

inputs:  frame (RGBA32F, written by the trace pass), splats (the `splats` SSBO, lift_gl/bindings.py: r, g, b
         float sums per pixel, filled by splat() in shaders/lift/splat.glsl)
outputs: frame with the splats added to its radiance sums; splats cleared for the next frame

Used only for plugins whose manifest says `splats = true`. Sums are float atomics where the
driver has GL_NV_shader_atomic_float (llvmpipe and NVIDIA do), otherwise a compare-and-swap
loop on the bits (the define LIFT_SPLATS_CAS), which any OpenGL 4.3 driver runs.
"""
from __future__ import annotations

from .. import shaders
from ..bindings import STORAGE_BUFFERS
from .common import groups

SPLAT_BINDING = STORAGE_BUFFERS["splats"]
FLOAT_ATOMICS = "GL_NV_shader_atomic_float"
RESOLVE_SOURCE = shaders.SHADER_DIR / "passes" / "splat_resolve.comp"


def splat_defines(ctx) -> dict:
    """The defines a shader that calls splat() needs on this context."""
    if FLOAT_ATOMICS in ctx.extensions:
        return {"LIFT_SPLATS": True}
    return {"LIFT_SPLATS": True, "LIFT_SPLATS_CAS": True}


class SplatBuffer:
    """The per-pixel sums (cleared) and the pass that adds them to a frame."""

    def __init__(self, ctx, size):
        self.ctx = ctx
        self.size = size
        self.buffer = ctx.buffer(reserve=4 * 3 * size[0] * size[1])
        self.buffer.clear()
        self.resolve = shaders.compile_compute(ctx, shaders.assemble(RESOLVE_SOURCE))

    def bind(self) -> None:
        self.buffer.bind_to_storage_buffer(SPLAT_BINDING)

    def add_to(self, frame) -> None:
        """frame.rgb += splats; splats = 0. Waits for the trace pass's atomics and stores."""
        self.ctx.memory_barrier()
        frame.bind_to_image(0, read=True, write=True)
        self.bind()
        self.resolve.run(*groups(*self.size))
        self.ctx.memory_barrier()

    def release(self) -> None:
        self.buffer.release()
        self.resolve.release()
