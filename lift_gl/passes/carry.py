"""Paths carried into the next frame: the host side of LIFT_CARRY_PATHS (shaders/lift/host_carry.glsl,
in the pixel queue's loop, lift/host_pixel_queue.glsl).

Why: a frame's dispatch ends only when its longest paths have ended, and once the pixel queue
has run out those run alone on a few lanes; on an H100 at 1080p that tail is 0.5-0.7 ms of the
classroom's and the dining room's frames (docs/gpu.md). With carrying on, a lane whose path is
still under way when the queue has run out parks the path (its state, random numbers and pixel)
in one half of a buffer, and the next frame's lanes resume the parked paths first. What a
resumed path adds goes to the `late` image, tagged with the frame in `late_tag`; the
accumulation adds the texels of that frame's tag (older ones are stale, so nothing needs
clearing) to that frame's: per pixel, radiance and sample count, so the running mean stays
exact (a pixel whose sample is late has one sample fewer until it lands, never a wrong one).

Who may park: the renderer asks for it frame by frame (Renderer.render: a still camera, every
frame of a render of known length but its last, which finishes every path). Parked paths that
cannot land (the camera moved, a reset) are discarded: those pixels miss one sample, which the
per-pixel count accounts for. Where it is compiled in is the option carry_paths
(lift_gl/options.py resolve): on | off | always | auto; always parks every new path after its
first vertex whether the queue has run out or not, which puts the mechanism to work on every
pixel (tests on CPU rasterizers, whose lanes rarely see the queue run out).
"""
from __future__ import annotations

import numpy as np

from .common import set_uniforms

# GL binding points (shaders/lift/host_carry.glsl)
CARRY_BINDING = 15
LATE_IMAGE_UNIT = 1
LATE_TAG_IMAGE_UNIT = 2
HEADER_BYTES = 16            # lift_carry_count[2], lift_carry_next[2]
MAX_PARKED = 1 << 18         # paths a half is sized for: more than the lanes an H100 keeps in flight
# The host does not know the plugin's PathState layout: it sizes each half for MAX_PARKED
# entries of ENTRY_BYTES, and the shader divides the buffer's length by its own entry size
# (pt's parked path is 224 bytes in std430). A larger entry holds fewer; the extra paths run on.
ENTRY_BYTES = 256


class CarriedPaths:
    """The parked paths' buffer (two halves: one parked into, one resumed from, swapping every
    frame) and the late image."""

    def __init__(self, ctx, size, max_buffer_bytes: int = 1 << 27):
        self.ctx = ctx
        entries = min(size[0] * size[1], MAX_PARKED)
        self.buffer = ctx.buffer(reserve=min(HEADER_BYTES + 2 * entries * ENTRY_BYTES, max_buffer_bytes))
        self.buffer.write(bytes(HEADER_BYTES))
        self.late = ctx.texture(size, 4, dtype="f4")
        # which frame wrote each late texel (0: none yet); the accumulation adds only this frame's
        self.late_tag = ctx.texture(size, 1, dtype="u4")
        self.late_tag.write(np.zeros((size[1], size[0]), np.uint32).tobytes())
        self.tag = 0             # this frame's tag: frames dispatched since the carry began
        self.side = 0            # the half this frame parks into
        self.parked = False      # the last frame may have parked paths (so the next one resumes)
        self.resumed = False     # this frame's dispatch resumed paths: the late image holds samples

    def before_dispatch(self, program, park: bool) -> None:
        """Bind for the next frame's dispatch: it resumes the other half's paths (if the last
        frame parked any) and parks into its own half where `park`."""
        self.side ^= 1
        other = 1 - self.side
        # this frame's park count and the other half's resume cursor start at 0; the other half's
        # count is what the last frame parked, or 0 if it could not have parked
        self.buffer.write(np.array([0], np.uint32).tobytes(), offset=4 * self.side)
        if not self.parked:
            self.buffer.write(np.array([0], np.uint32).tobytes(), offset=4 * other)
        self.buffer.write(np.array([0], np.uint32).tobytes(), offset=8 + 4 * other)
        self.resumed = self.parked
        self.parked = park
        self.tag = self.tag % 0xFFFFFFFF + 1   # 1 to 2**32 - 1 (0 marks a texel never written)
        self.buffer.bind_to_storage_buffer(CARRY_BINDING)
        self.late.bind_to_image(LATE_IMAGE_UNIT, read=False, write=True)
        self.late_tag.bind_to_image(LATE_TAG_IMAGE_UNIT, read=False, write=True)
        # (set_uniforms skips a uniform the compiler dropped: benchmarks/gpu_pt_variants.py's edits may)
        set_uniforms(program, {"u_carry_side": self.side, "u_park": int(park), "u_late_tag": self.tag})

    def discard(self) -> None:
        """Forget the parked paths (the camera moved, the accumulation restarted)."""
        self.parked = False

    def release(self) -> None:
        self.buffer.release()
        self.late.release()
        self.late_tag.release()
