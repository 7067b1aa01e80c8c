"""The viewer's frame, timed: what `lift-gl bench --interactive DENOISER` and
`benchmarks/gpu.py interactive` measure.

A renderer as the viewer makes it (temporal reprojection, the denoiser after every frame) is
shown a slowly turning camera (TURN_DEGREES a frame about the target), and each frame is what
the viewer's draw does: set_camera, render_frame (G-buffer, trace, reprojection, accumulation,
the denoiser and its guides), display without readback. Two runs:

- frame ms: the wall clock over `frames` frames, GPU work finished (best of `repeat`);
- per pass: a GL timer query around each pass (on llvmpipe the CPU clock between two
  glFinish calls: lift_gl/passes/common.py GpuTimer), and the denoiser's guides, a G-buffer
  of their own where the frame's cannot serve, timed as "guides".

Only the public Renderer API is used, so the same module times another checkout's renderer
(a before-and-after run).
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

TURN_DEGREES = 0.2  # a frame: a slow pan, which reprojects every frame


def turned(camera, degrees: float):
    """The camera turned about the vertical axis through its target."""
    angle = math.radians(degrees)
    offset = np.asarray(camera.position, np.float64) - np.asarray(camera.target, np.float64)
    axis = np.asarray(camera.up, np.float64)
    axis = axis / np.linalg.norm(axis)
    c, s = math.cos(angle), math.sin(angle)
    rotated = offset * c + np.cross(axis, offset) * s + axis * float(axis @ offset) * (1.0 - c)
    return dataclasses.replace(camera, position=np.asarray(camera.target, np.float64) + rotated)


class _GuidesTimer:
    """frame.guides timed while the per-pass run lasts: the G-buffer rendered for the guides
    when the frame's own cannot be used."""

    def __init__(self, renderer):
        from .. import frame

        self.frame, self.original = frame, frame.guides
        self.timer = renderer._timer()

        def timed_guides(r):
            with self.timer:
                return self.original(r)
        frame.guides = timed_guides

    def restore(self) -> None:
        self.frame.guides = self.original


def interactive_case(scene, size, integrator="pt", params=None, denoiser="atrous", frames=50, repeat=3,
                     backend="auto", options=None) -> dict:
    from ..frame_settings import DenoiseSettings
    from ..renderer import Renderer

    r = Renderer(scene, size=size, integrator=integrator, params=params, backend=backend, options=options,
                 denoise=DenoiseSettings("every", denoiser), temporal="reproject")
    start_camera = scene.camera

    def run(count: int) -> float:
        r.reset()
        r.set_camera(start_camera)
        r.ctx.finish()
        begin = time.perf_counter()
        for k in range(count):
            r.set_camera(turned(start_camera, TURN_DEGREES * (k + 1)))
            r.render_frame()
            r.display(readback=False)
        r.ctx.finish()
        return (time.perf_counter() - begin) / count

    try:
        run(8)  # shader JIT and first-use costs
        frame_ms = [1e3 * run(frames) for _ in range(max(repeat, 1))]
        r.timers = {p.name: r._timer() for p in r.passes}
        guides = _GuidesTimer(r)
        try:
            run(frames)
        finally:
            guides.restore()
        passes = {name: t.mean_ms for name, t in r.timers.items() if t.count}
        if guides.timer.count:
            passes["guides"] = guides.timer.total_ns / frames / 1e6  # per frame, as the others
        r.timers = None
        return {"size": list(size), "integrator": integrator, "denoiser": denoiser, "frames": frames,
                "repeat": repeat, "frame_ms": min(frame_ms), "frame_ms_all": frame_ms, "pass_ms": passes,
                "reprojected": r.stats.reprojected, "gbuffer": type(r.gbuffer).__name__,
                "explain": r.explain()}
    finally:
        r.release()


def table(cases: list[dict]) -> str:
    """Markdown: one row a case, a column a pass (those that ran, in order), then the frame."""
    passes = []
    for case in cases:
        passes += [p for p in case["pass_ms"] if p not in passes]
    header = ["scene", "integrator", "size", "denoiser", "G-buffer"] + [f"{p} ms" for p in passes] + ["frame ms", "fps"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for c in cases:
        cells = [c.get("scene_name", ""), c.get("spec", c["integrator"]), "x".join(map(str, c["size"])), c["denoiser"],
                 c["gbuffer"]]
        cells += [f"{c['pass_ms'][p]:.2f}" if p in c["pass_ms"] else "–" for p in passes]
        cells += [f"{c['frame_ms']:.2f}", f"{1e3 / c['frame_ms']:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
