"""One progressive render, stopped at log-spaced checkpoints.

At each checkpoint it records the render time (the frames' wall-clock time with the GPU
work finished, `ctx.finish()`, so readbacks and metrics are left out), the wall time since
the run began (everything included: this is what checkpoints cost), the samples per pixel,
the mean image and the error estimate without a reference.

Two budgets: equal spp (checkpoints at 1, 2, 4, ... spp, then the budget) and equal time
(checkpoints at budget / 2^k seconds; each one renders whole frames, at least one).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..error_estimate import ErrorEstimate


@dataclass
class Checkpoint:
    index: int
    spp: int
    render_seconds: float  # frames only, GPU work finished; checkpoint I/O excluded
    wall_seconds: float    # since the run began, checkpoint readbacks and metrics included
    image: np.ndarray      # mean radiance, float32 H x W x 3
    estimate: ErrorEstimate | None
    dropped_samples: int


def spp_checkpoints(spp: int, per_doubling: int = 1) -> list[int]:
    """Log-spaced sample counts up to and including `spp`: 1, 2, 4, ... (per_doubling
    points per factor of two), distinct whole numbers."""
    if spp < 1:
        raise ValueError(f"spp must be at least 1, not {spp}")
    steps = int(math.floor(math.log2(spp) * per_doubling + 1e-9))
    points = sorted({int(round(2 ** (k / per_doubling))) for k in range(steps + 1)} | {spp})
    return [p for p in points if p <= spp]


def time_checkpoints(seconds: float, per_doubling: int = 1, decades: float = 3.0) -> list[float]:
    """Log-spaced times up to `seconds`, from `seconds` / 10^decades."""
    if not seconds > 0:
        raise ValueError(f"time budget must be positive, not {seconds}")
    steps = int(math.ceil(decades * math.log2(10) * per_doubling))
    return [seconds * 2 ** (-k / per_doubling) for k in range(steps, -1, -1)]


def warm_up(renderer) -> None:
    """One frame, then a reset: shader JIT and first-use costs stay out of the timings."""
    renderer.render(spp=1)
    renderer.reset()


def run_checkpoints(renderer, spp_targets=None, time_targets=None, on_checkpoint=None):
    """Render progressively; yield a Checkpoint at each target (spp or seconds of render
    time). `on_checkpoint(checkpoint)` runs inside the wall clock (metrics, progress)."""
    if (spp_targets is None) == (time_targets is None):
        raise ValueError("give either spp_targets or time_targets")
    start = time.perf_counter()
    index = 0
    if spp_targets is not None:
        targets = [("spp", int(t)) for t in spp_targets]
    else:
        targets = [("seconds", float(t)) for t in time_targets]
    for kind, target in targets:
        stats = renderer.stats
        if kind == "spp":
            todo = target - stats.spp
            if todo <= 0:
                continue
            image = renderer.render(spp=todo)
        else:
            todo = target - stats.render_seconds
            if todo <= 0 and stats.frames > 0:
                continue  # an earlier frame already went past this target
            image = renderer.render(seconds=max(todo, 1e-9))
        estimate = renderer.estimate_error()
        checkpoint = Checkpoint(index=index, spp=renderer.stats.spp, render_seconds=renderer.stats.render_seconds,
                                wall_seconds=time.perf_counter() - start, image=image, estimate=estimate,
                                dropped_samples=renderer.stats.dropped_samples)
        if on_checkpoint is not None:
            on_checkpoint(checkpoint)
        index += 1
        yield checkpoint
