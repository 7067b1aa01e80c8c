"""When Renderer.render() waits for the GPU (ctx.finish) between the frames it queues.

A render of a fixed number of samples waits every MAX_QUEUED_FRAMES frames. On an H100 (driver
580.159) 8192 frames of the dining room queued by one call came back black, with the pixel queue
on or off, and so did the next renderer's image in that process; waiting every 64 gave the right
image. 2048 of its frames (7.5 s of work), the cornell-box's 8192 (3.4 s) and 96 of bdpt's (64 a
wait, 16 s) came back right: the cause is not known (docs/gpu.md). CPU rasterizers did not show it.

A timed render, or one that reports progress, waits for the GPU to read the clock or report.
Waiting after every frame costs a GPU the CPU's submission of the next (H100, pt, dining room at
1080p: 12.0 against 11.3 ms a frame for the same GPU time), which equal-time comparisons charged
to the fastest integrators. Such a render queues, between waits, the frames that the frame time
measured so far says take TIMED_WAIT_FRACTION of its time budget (PROGRESS_INTERVAL_S with
progress), at least one and at most MAX_QUEUED_FRAMES: a timed render ends at most that
fraction (and a frame) past its budget.
"""
from __future__ import annotations

MAX_QUEUED_FRAMES = 64
TIMED_WAIT_FRACTION = 0.02
PROGRESS_INTERVAL_S = 0.25


def frames_between_waits(seconds: float | None, progress: bool, elapsed: float, frames: int) -> int:
    """How many frames render() queues before its next wait, after `frames` frames took
    `elapsed` seconds of a budget of `seconds` (None: a number of samples)."""
    if seconds is None and not progress:
        return MAX_QUEUED_FRAMES
    interval = PROGRESS_INTERVAL_S if progress else float("inf")
    if seconds is not None:
        interval = min(interval, TIMED_WAIT_FRACTION * seconds, max(seconds - elapsed, 0.0))
    per_frame = elapsed / max(frames, 1)
    if per_frame <= 0.0:
        return 1
    # (a hair over 1: a frame time read as 0.0100000001 s must still fit 10 in 0.1 s)
    return int(max(1, min(MAX_QUEUED_FRAMES, interval / per_frame * (1.0 + 1e-9))))
