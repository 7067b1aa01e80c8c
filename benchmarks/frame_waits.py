"""Does a frame's time depend on how many frames are queued before the CPU waits for the GPU?
(docs/gpu.md, "Measuring": a render waits for the GPU every 64 frames. bdpt's 1080p frames of
the dining room measured 171 ms with a wait every 64 frames and 466 ms with one after every
frame; this script finds the GPU time the same either way, the 466 ms being the scene's path
length of 65, and a wait after every frame costing the wall clock the CPU's submission of the
next.)

    python benchmarks/frame_waits.py SCENE [--integrator bdpt:max_depth=32] [--size 1920x1080] [--waits 1,8,64]
        [--frames 16] [--rounds 2] [--timed SECONDS] [--out FILE.json]

For each wait interval k (interleaved over --rounds, the same renderer, reset before each run):
--frames frames are queued, the CPU waits (glFinish) after every k-th, and the run ends with a
wait. Recorded per run: wall ms a frame; each frame's GPU time by a GL timer query around the
whole frame (their sum against the wall time tells GPU work from idle or overlap); the SM clock
sampled every 2 ms on a thread through NVML (report/gpu_clock.py; None elsewhere); and the
image, which must not depend on k (the same seed and frames: the largest difference is
recorded). On a CPU rasterizer timer queries miss compute work, so only the wall time means
anything there. With --timed, render(seconds=...) is timed too, as the renderer queues frames
between its waits and with a wait after every frame.
"""
from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from gpu import portable, scene_name  # noqa: E402
from lift_gl.report.gpu_clock import ClockReader, warm_up  # noqa: E402
from lift_gl.report.records import write_json  # noqa: E402


class ClockSampler:
    """SM clock readings taken on a thread while a run lasts (none without NVML)."""

    def __init__(self, clock: ClockReader, period_s: float = 0.002):
        self.clock, self.period_s = clock, period_s
        self.readings: list[int] = []

    def __enter__(self):
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        if self.clock.available:
            self._thread.start()
        return self

    def _run(self):
        while not self._stop.is_set():
            mhz = self.clock.sm_mhz()
            if mhz is not None:
                self.readings.append(mhz)
            time.sleep(self.period_s)

    def __exit__(self, *exc):
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()
        return False

    def summary(self) -> dict | None:
        if not self.readings:
            return None
        r = np.array(self.readings)
        return {"samples": int(r.size), "min": int(r.min()), "median": float(np.median(r)), "max": int(r.max())}


def timed_run(renderer, frames: int, wait_every: int, clock: ClockReader) -> dict:
    """`frames` frames with a glFinish after every `wait_every`-th; see the module's docstring."""
    ctx = renderer.ctx
    renderer.reset()
    ctx.finish()
    queries = [ctx.query(time=True) for _ in range(frames)]
    with ClockSampler(clock) as sampler:
        start = time.perf_counter()
        for i, q in enumerate(queries):
            with q:
                renderer.render_frame()
            if (i + 1) % wait_every == 0:
                ctx.finish()
        ctx.finish()
        wall = time.perf_counter() - start
    gpu_ms = [q.elapsed / 1e6 for q in queries]
    return {"wait_every": wait_every, "frames": frames, "wall_ms_per_frame": 1e3 * wall / frames,
            "gpu_ms_per_frame_median": float(np.median(gpu_ms)), "gpu_ms_sum": float(np.sum(gpu_ms)),
            "wall_ms": 1e3 * wall, "gpu_ms": gpu_ms, "sm_clock": sampler.summary()}


def timed_renders(renderer, seconds: float, rounds: int) -> list[dict]:
    """render(seconds=...) as it queues frames between waits (lift_gl/gpu_waits.py)
    and with a wait after every frame (TIMED_WAIT_FRACTION 0, what it did before), interleaved:
    the frames each gets done in the same time."""
    import lift_gl.gpu_waits as gpu_waits

    fraction = gpu_waits.TIMED_WAIT_FRACTION
    out = []
    try:
        for r in range(rounds):
            for way in (("queued", "each frame") if r % 2 == 0 else ("each frame", "queued")):
                gpu_waits.TIMED_WAIT_FRACTION = fraction if way == "queued" else 0.0
                renderer.reset()
                renderer.render(seconds=seconds)
                stats = renderer.stats
                out.append({"waits": way, "round": r, "seconds": stats.render_seconds, "frames": stats.frames,
                            "ms_per_frame": 1e3 * stats.render_seconds / stats.frames})
                print(f"timed render, {way:>10}: {stats.frames} frames in {stats.render_seconds:.3f} s "
                      f"({out[-1]['ms_per_frame']:.3f} ms a frame)", flush=True)
    finally:
        gpu_waits.TIMED_WAIT_FRACTION = fraction
    return out


def measure(path: str, spec: str, size, waits: list[int], frames: int, rounds: int, backend="auto",
            timed_seconds: float | None = None) -> dict:
    """`spec`: a plugin with its settings, as `lift-gl compare` takes them (pt:max_depth=32)."""
    from lift_gl.renderer import Renderer
    from lift_gl.report.configurations import parse_spec
    from lift_gl.scene.loader import load_scene

    integrator, params = parse_spec(spec)
    renderer = Renderer(load_scene(path), size=size, integrator=integrator, params=params, backend=backend)
    clock = ClockReader(renderer.ctx.info.get("GL_RENDERER", ""))
    warm = warm_up(lambda: (renderer.render_frame(), renderer.ctx.finish()), clock, min_steps=2)
    runs, images = [], {}
    for r in range(rounds):
        order = waits if r % 2 == 0 else waits[::-1]
        for k in order:
            run = timed_run(renderer, frames, k, clock)
            run["round"] = r
            image = renderer.noisy_image()
            run["image_mean"] = float(image.mean())
            first = images.setdefault("first", image)
            run["max_abs_diff_vs_first"] = float(np.max(np.abs(image - first)))
            runs.append(run)
            print(f"{scene_name(path)} {spec} wait every {k:>3}: "
                  f"{run['wall_ms_per_frame']:8.2f} ms a frame (wall), GPU {run['gpu_ms_per_frame_median']:8.2f} "
                  f"(median), clock {run['sm_clock']}", flush=True)
    timed = timed_renders(renderer, timed_seconds, rounds) if timed_seconds else None
    info = renderer.ctx.info
    settings = {k: v for k, v in renderer.params.items()}
    renderer.release()
    return {"scene": portable(path), "integrator": spec, "params": settings, "size": list(size), "warm_up": warm,
            "gl": f"{info.get('GL_RENDERER')} | {info.get('GL_VERSION')}", "runs": runs, "timed_renders": timed}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("--integrator", default="bdpt", help="a plugin and its settings: bdpt:max_depth=32")
    p.add_argument("--size", default="1920x1080")
    p.add_argument("--waits", default="1,8,64", help="comma-separated: a glFinish after every k-th frame")
    p.add_argument("--frames", type=int, default=16)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--backend", default="auto")
    p.add_argument("--timed", type=float, metavar="SECONDS",
                   help="also render(seconds=SECONDS) with frames queued between waits and with a wait after each")
    p.add_argument("--out", type=Path)
    args = p.parse_args(argv)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    waits = [int(k) for k in args.waits.split(",")]
    if any(k < 1 for k in waits):
        raise SystemExit("--waits: every interval must be at least 1 frame")
    record = measure(args.scene, args.integrator, size, waits, args.frames, args.rounds, args.backend, args.timed)
    if args.out:
        write_json(args.out, record, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
