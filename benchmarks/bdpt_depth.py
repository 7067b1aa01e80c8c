"""bdpt trace-pass time of this checkout's plugin against a baseline plugin folder taken from
git (default: main's plugins/bdpt), for several max_depth values, interleaved in one run so
that drift in machine load hits both alike. Each render is timed by the trace pass's timer
(on llvmpipe: the CPU clock around ctx.finish()) and by the process's CPU time (getrusage,
llvmpipe's threads included: what a shared machine's load disturbs least). Also compares the
two images: the largest per-pixel relative difference (0 to float rounding where both use
the same random numbers) and the ratio of their means (near 1 where they differ only by noise).

    python benchmarks/bdpt_depth.py [SCENE] [--size 96] [--frames 6] [--rounds 3]
                                    [--depths 5 8 16 scene] [--baseline main]
"""
from __future__ import annotations

import argparse
import resource
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.renderer import Renderer

DEFAULT = Path(__file__).resolve().parent.parent.parent / "shared/scenes_lift/cornell-box/scene.pbrt"


REPO = Path(__file__).resolve().parent.parent


def baseline_plugin(ref: str, into: Path) -> Path:
    """plugins/bdpt as it is at git `ref`, written into a folder of its own."""
    folder = into / "bdpt"
    folder.mkdir()
    names = subprocess.run(["git", "ls-tree", "--name-only", f"{ref}:plugins/bdpt"], cwd=REPO, check=True,
                           capture_output=True, text=True).stdout.split()
    for name in names:
        blob = subprocess.run(["git", "show", f"{ref}:plugins/bdpt/{name}"], cwd=REPO, check=True,
                              capture_output=True).stdout
        (folder / name).write_bytes(blob)
    return folder


def trace_ms(scene, size, frames, depth, integrator):
    params = {} if depth is None else {"max_depth": depth}
    renderer = Renderer(scene, size=(size, size), integrator=integrator, params=params, timers=True, seed=3)
    renderer.render(spp=1)  # warm up (compile, first dispatch)
    renderer.reset()
    cpu_start = resource.getrusage(resource.RUSAGE_SELF)
    image = renderer.render(spp=frames)
    cpu_end = resource.getrusage(resource.RUSAGE_SELF)
    cpu_ms = 1e3 * ((cpu_end.ru_utime - cpu_start.ru_utime) + (cpu_end.ru_stime - cpu_start.ru_stime)) / frames
    ms = renderer.stats.pass_ms["trace"]
    depth_used = renderer.params["max_depth"]
    device = describe(renderer.ctx)
    renderer.release()
    return ms, cpu_ms, depth_used, device, image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("scene", nargs="?", default=str(DEFAULT))
    parser.add_argument("--size", type=int, default=96)
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--depths", nargs="+", default=["5", "8", "16", "scene"],
                        help="max_depth values; 'scene': the scene file's own")
    parser.add_argument("--baseline", default="main", help="git ref whose plugins/bdpt is the baseline")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run(args, str(baseline_plugin(args.baseline, Path(tmp))))


def run(args, baseline: str) -> None:
    scene = load_scene(args.scene)
    depths = [None if d == "scene" else int(d) for d in args.depths]
    times = {(d, fixed): [] for d in depths for fixed in (False, True)}
    cpu = {(d, fixed): [] for d in depths for fixed in (False, True)}
    means = {(d, fixed): [] for d in depths for fixed in (False, True)}
    used, images, worst = {}, {}, {d: 0.0 for d in depths}
    for _ in range(args.rounds):
        for d in depths:
            for fixed in (True, False):
                ms, cpu_ms, used[d], device, images[fixed] = trace_ms(scene, args.size, args.frames, d,
                                                                      baseline if fixed else "bdpt")
                times[(d, fixed)].append(ms)
                cpu[(d, fixed)].append(cpu_ms)
                means[(d, fixed)].append(float(np.mean(images[fixed], dtype=np.float64)))
            a, b = images[False].astype(np.float64), images[True].astype(np.float64)
            worst[d] = max(worst[d], float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-30))))
    print(f"device: {device}")
    print(f"baseline: plugins/bdpt at {args.baseline}")
    print(f"scene: {args.scene}  {args.size}x{args.size}, 1 spp x {args.frames} frames, best of {args.rounds}")
    print("trace ms: the trace pass's timer per frame; cpu ms: process CPU time per frame (all passes); best of rounds")
    print(f"{'max_depth':>12s} {'base trace':>11s} {'new trace':>10s} {'base/new':>9s} {'base cpu':>9s} {'new cpu':>8s} "
          f"{'base/new':>9s} {'max rel diff':>13s} {'mean new/base':>14s}")
    for d in depths:
        fixed, sized = min(times[(d, True)]), min(times[(d, False)])
        cpu_fixed, cpu_sized = min(cpu[(d, True)]), min(cpu[(d, False)])
        mean_ratio = np.mean(means[(d, False)]) / np.mean(means[(d, True)])
        label = f"{used[d]}" + (" (scene)" if d is None else "")
        print(f"{label:>12s} {fixed:11.2f} {sized:10.2f} {fixed / sized:9.3f} {cpu_fixed:9.2f} {cpu_sized:8.2f} "
              f"{cpu_fixed / cpu_sized:9.3f} {worst[d]:13.2e} {mean_ratio:14.4f}   "
              f"(trace: baseline {', '.join(f'{v:.1f}' for v in times[(d, True)])}; new {', '.join(f'{v:.1f}' for v in times[(d, False)])})")


if __name__ == "__main__":
    main()
