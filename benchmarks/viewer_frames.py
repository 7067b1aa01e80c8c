"""Viewer frame times: the whole viewer frame (input -> Renderer frame -> tone map -> draw ->
ImGui panels -> swap) against the headless Renderer's per-pass times, on one machine.

    python benchmarks/viewer_frames.py [--size 1280x720] [--window pyglet|headless] [--frames 30]

Three viewer runs of the same scene and window: a still camera at full resolution, a camera
that turns every frame at full resolution, and the same motion at the "scale while moving"
(0.5), then the headless Renderer at the same resolution with GPU timers (its pass times are
what the statistics panel shows). Prints a markdown table and writes JSON with --json FILE.
Frame times are medians of `--frames` frames after `--warmup` frames; ratios are between
runs of this one invocation. `--window headless` draws offscreen through EGL (no X server):
that is how it runs on a GPU machine without a display.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def _size(text):
    w, h = (int(v) for v in text.lower().split("x"))
    return w, h


def viewer_runs(args) -> list[dict]:
    from lift_gl.app.window import ViewerWindow, ViewOptions

    options = ViewOptions(scene=str(args.scene), window_size=args.size, window_class=args.window, render_scale=1.0,
                          moving_scale=1.0, panels=("settings", "statistics"))
    window = ViewerWindow(options)
    session = window.session
    results = []
    for label, moving, moving_scale in (("still", False, 1.0), ("moving", True, 1.0),
                                        ("moving, scale 0.5", True, 0.5)):
        session.resolution.moving_scale = moving_scale
        session.set_moving(False)
        session.apply_resolution()
        session.restart()
        times, render_ms = [], []
        for i in range(args.warmup + args.frames):
            if moving:
                session.controller.look(3, 0)
                window._camera_moved()
            start = time.perf_counter()
            window.frame()
            window.wnd.swap_buffers()
            window.ctx.finish()
            if i >= args.warmup:
                times.append((time.perf_counter() - start) * 1e3)
                render_ms.append(session.last_frame.wall_ms)
        results.append({"run": label, "render_size": list(session.renderer.size),
                        "frame_ms": float(np.median(times)), "render_ms": float(np.median(render_ms)),
                        "pass_ms": session.last_frame.pass_ms})
    device = f"{window.ctx.info['GL_RENDERER']} | {window.ctx.info['GL_VERSION']}"
    window.close()
    for r in results:
        r["device"] = device
        r["window"] = args.window
    return results


def headless_run(args, size) -> dict:
    """The Renderer alone at `size`: the viewer's render size (its panels take part of the
    window), so that its passes are timed on the same pixels."""
    from lift_gl import load_scene
    from lift_gl.gl.context import describe
    from lift_gl.renderer import Renderer

    renderer = Renderer(load_scene(args.scene), size=tuple(size), timers=True)
    renderer.render(spp=args.warmup)
    renderer.display()
    renderer.reset()
    for t in renderer.timers.values():
        t.total_ns, t.count = 0, 0
    start = time.perf_counter()
    for _ in range(args.frames):
        renderer.render(spp=1, readback=False)
        renderer.display(readback=False)
    wall = (time.perf_counter() - start) * 1e3 / args.frames
    return {"run": "headless Renderer", "render_size": list(renderer.size), "frame_ms": wall,
            "pass_ms": {name: t.mean_ms for name, t in renderer.timers.items()}, "device": describe(renderer.ctx)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", type=Path, default=REPO / "scenes" / "cornell.toml")
    p.add_argument("--size", type=_size, default=(1280, 720))
    p.add_argument("--window", choices=("pyglet", "glfw", "headless"), default="pyglet")
    p.add_argument("--frames", type=int, default=30)
    p.add_argument("--warmup", type=int, default=5)
    p.add_argument("--json", type=Path)
    p.add_argument("--no-viewer", action="store_true", help="only the headless per-pass times")
    args = p.parse_args(argv)

    rows = [] if args.no_viewer else viewer_runs(args)
    rows.append(headless_run(args, rows[0]["render_size"] if rows else args.size))
    print(f"scene {args.scene.name}, window {args.size[0]}x{args.size[1]}, pt 1 spp/frame, median of {args.frames} frames")
    print(f"device: {rows[-1]['device']}")
    print("| run | render size | frame (ms) | Renderer step (ms) | per pass (ms) |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        passes = ", ".join(f"{k} {v:.2f}" for k, v in r["pass_ms"].items())
        step = f"{r['render_ms']:.2f}" if "render_ms" in r else "-"
        print(f"| {r['run']} | {r['render_size'][0]}x{r['render_size'][1]} | {r['frame_ms']:.2f} | {step} | {passes} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
