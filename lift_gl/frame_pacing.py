"""How many frames Renderer.render() hands the GPU before it waits for them (ctx.finish).

Why wait at all: on an H100 (driver 580.159), the dining room's 8192 frames queued by one
render() call (about 20 s of GPU work) came back black, with the pixel queue on or off, and so
did the next renderer's image in that process, while 2048 of them (7.5 s) and the cornell-box's
8192 (3.4 s) came back right (docs/gpu.md "Ninth session"). So what is queued is bounded in
time, not only in frames: after the first frame (whose time is not known yet) a render waits
whenever the frames queued since its last wait would take MAX_QUEUED_SECONDS at the rate it
last measured, and after MAX_QUEUED_FRAMES in any case. A wait costs the GPU the time the CPU
takes to queue the next frame: 1.6% of the cornell-box's 1.46 ms frames at 64 a wait (H100).
"""
from __future__ import annotations

import time

MAX_QUEUED_FRAMES = 64
MAX_QUEUED_SECONDS = 0.25


class FramePacer:
    """Says when render() should wait (frame_queued) and learns the frame time from each wait
    (waited). One per renderer: what it learned carries over to its next render() call."""

    def __init__(self, clock=time.perf_counter):
        self.clock = clock
        self.limit = 1          # frames to queue before the next wait; 1 until a frame is timed
        self.queued = 0
        self.since = clock()

    def start(self) -> None:
        """A render() call begins: nothing of this renderer is queued (the last call waited)."""
        self.queued = 0
        self.since = self.clock()

    def frame_queued(self) -> bool:
        """One more frame queued; True where render() should wait now."""
        self.queued += 1
        return self.queued >= self.limit

    def waited(self) -> None:
        """render() just waited for every frame queued: their time sets the next limit."""
        now = self.clock()
        if self.queued > 0:
            per_frame = (now - self.since) / self.queued
            fit = int(MAX_QUEUED_SECONDS / per_frame) if per_frame > 0 else MAX_QUEUED_FRAMES
            self.limit = max(1, min(MAX_QUEUED_FRAMES, fit))
        self.queued = 0
        self.since = now
