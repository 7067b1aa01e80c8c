"""Paths carried into the next frame: the host side of LIFT_CARRY_PATHS (passes/trace.py's
queued megakernel, lift_trace_pixel_queue).

Why: a frame's dispatch ends only when its longest paths have ended, and once the pixel queue
has run out those run alone on a few lanes; on an H100 at 1080p that tail is 0.5-0.7 ms of the
classroom's and the dining room's frames (docs/gpu.md "Tenth session"). With carrying on, a
lane whose path is still under way when the queue has run out parks the path (its state,
random numbers and pixel) in one half of a buffer, and the next frame's lanes resume the parked
paths first. What a resumed path adds goes to the `late` image, tagged with the frame in
`late_tag`; the accumulation adds the texels of that frame's tag (older ones are stale, so
nothing needs clearing) to that frame's: per pixel, radiance and sample count, so the running mean stays exact (a
pixel whose sample is late has one sample fewer until it lands, never a wrong one).

Who may park: the renderer asks for it frame by frame (Renderer.render: a still camera, every
frame of a render of known length but its last, which finishes every path). Parked paths that
cannot land (the camera moved, a reset) are discarded: those pixels miss one sample, which the
per-pixel count accounts for. The option carry_paths (lift_gl/options.py) = on | off | faster
| always | auto: auto is faster on GPUs, off on CPU rasterizers, where lanes rarely see the
queue run out while a path is under way; always parks every new path after its first vertex
whether the queue has run out or not, which puts the mechanism to work on every pixel (tests).
faster times the megakernel with and without the carry code on the first frames of a render
that may park and keeps the faster (CarryTuning). Why not simply on: on an H100 carrying made
the dining room's frame 8-12% faster at Lift's Russian roulette and the classroom's 2.5%, but
the Covered Dragon's and the cornell-box's 7-16% slower, where the carry code compiled in and
never used already costs 12-22% (on the dragon it costs the megakernel a step of occupancy,
16 warps an SM to 12), and no cheaper form of it was found. Only the queued megakernel (a
plugin with LIFT_PATH_STEPS and the option pixel_queue on) can carry.
"""
from __future__ import annotations

import numpy as np

from .common import fastest_half_mean, set_uniforms

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


# carry_paths=faster: frames a block, and blocks of each way. A block's frames are
# queued as a render queues them and timed together between two finishes (a wait after every
# frame cost the small scenes' frames 4x their time on an H100, mostly the wait, and let the
# GPU's clock drop: the first version of this choice, timing each frame alone, kept the slower
# way on the cornell-box and the Covered Dragon in one process of two; docs/gpu.md "Twelfth
# session"). A carry block's last frame parks nothing, so every block ends with all its paths
# done and both ways' blocks do the same work. Only the frames between a block's first and last
# are timed (CARRY_TIMED): the carry way's first frame resumes nothing and its last runs its
# whole tail, which a render that carries never does, so a block timed whole charged the carry
# way one frame's tail per block (about 0.09 ms a frame on the classroom at 1080p, as much as
# the two ways differ there, and it kept the plain way in some processes: docs/gpu.md
# "Fourteenth session"). Blocks in the order carry, plain, plain, carry, ... (a drift in the
# GPU's clock then weighs both alike). Each way's blocks are summed up by the mean of its faster
# half (fastest_half_mean), not by their mean: a render's first carry block runs slow (on an
# H100 the slowest of the three in 15 of 16 cases, up to 4.1x the others; the dining room's at
# 6.74 ms a frame against 3.49 and 3.52), and the mean let it keep the plain megakernel in the
# first case of two processes of two (3.77-3.79 ms frames against 3.37-3.39; docs/gpu.md
# "Fifteenth session").
CARRY_BLOCK = 10
CARRY_TIMED = CARRY_BLOCK - 2
CARRY_ROUNDS = 3
CARRY_ORDER = ("carry", "plain", "plain", "carry")
# A render shorter than the choice (its untimed first frame and the blocks) does not start it:
# it would only pay for building the second megakernel.
CARRY_TUNING_FRAMES = 1 + 2 * CARRY_ROUNDS * CARRY_BLOCK


class CarryTuning:
    """The choice between the megakernel with the carry code and without it, made by timing
    blocks of frames of a render that may park (passes/trace.py runs the frames; this keeps
    the blocks' times and says which way comes next, whether a frame may park and when the
    clock is read)."""

    def __init__(self, defines: dict):
        self.defines = defines      # the carry program's
        self.program = None         # built on the first frame that may park
        self.source = None
        self.warmed = False         # its first dispatch ran, untimed
        self.blocks = {"carry": [], "plain": []}   # seconds of each finished block's timed frames
        self.way = None             # the block under way ...
        self.frames = 0             # ... its frames run
        self.began = None           # ... when its timed frames began (after a finish)
        self.timed = None           # ... and how long they took

    def start(self) -> str:
        """Begins the next block (its way, in CARRY_ORDER)."""
        done = sum(len(v) for v in self.blocks.values())
        self.way, self.frames, self.began, self.timed = CARRY_ORDER[done % len(CARRY_ORDER)], 0, None, None
        return self.way

    def parks(self, park: bool) -> bool:
        """Whether this frame of the block may park: the carry way's, except its block's last."""
        return park and self.way == "carry" and self.frames < CARRY_BLOCK - 1

    def last(self) -> bool:
        """Whether the frame about to run ends its block."""
        return self.frames == CARRY_BLOCK - 1

    def clock_due(self) -> bool:
        """Whether the clock is read now, after a finish (the block's frames run so far counted):
        after its first frame (the timed ones begin) and before its last (they end)."""
        return self.frames in (1, CARRY_BLOCK - 1)

    def clock(self, now: float) -> None:
        if self.frames == 1:
            self.began = now
        else:
            self.timed = now - self.began

    def end(self) -> bool:
        """The block under way ended; true once every block is timed."""
        self.blocks[self.way].append(self.timed)
        self.way = None
        return all(len(v) >= CARRY_ROUNDS for v in self.blocks.values())

    def abort(self) -> None:
        """The block under way cannot go on (a frame that may not park, a reset): not counted."""
        self.way = None

    def block_ms(self) -> dict:
        """Each way's blocks in the order timed: a timed frame's mean time in each, ms."""
        return {k: [1e3 * b / CARRY_TIMED for b in v] for k, v in self.blocks.items()}

    def frame_ms(self) -> dict:
        """Each way's time of a timed frame: the mean of its faster half of blocks, ms."""
        return {k: fastest_half_mean(v) for k, v in self.block_ms().items() if v}

    def faster(self) -> str:
        ms = self.frame_ms()
        return "carry" if ms["carry"] < ms["plain"] else "plain"
