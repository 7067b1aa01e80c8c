"""What `lift-gl compare`'s checkpoints cost: a checkpointed run (readback, error estimate,
relMSE, RMSE, SSIM at 1, 2, 4, ... spp) against a plain render of the same spp and seed, as
`lift-gl render` does it. Pairs are interleaved and repeated, so that drift in the load of a
shared machine hits both alike; the median of the per-pair ratios is the figure.

    python benchmarks/checkpoint_overhead.py [SCENE] [--size 128] [--spp 64] [--pairs 5]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
from lift_gl import load_scene  # noqa: E402
from lift_gl.gl.context import describe  # noqa: E402
from lift_gl.renderer import Renderer  # noqa: E402
from lift_gl.report.compare import image_metrics  # noqa: E402
from lift_gl.report.machine import describe_machine, machine_line  # noqa: E402
from lift_gl.report.progressive import run_checkpoints, spp_checkpoints, warm_up  # noqa: E402

DEFAULT = REPO.parent / "shared" / "scenes_lift" / "cornell-box" / "scene.pbrt"


def plain(scene, size, spp, seed) -> float:
    r = Renderer(scene, size=size, seed=seed)
    warm_up(r)
    start = time.perf_counter()
    r.render(spp=spp)
    seconds = time.perf_counter() - start
    r.release()
    return seconds


def checkpointed(scene, size, spp, seed, reference) -> tuple[float, float, int]:
    r = Renderer(scene, size=size, seed=seed)
    warm_up(r)
    start = time.perf_counter()
    count = 0
    for cp in run_checkpoints(r, spp_targets=spp_checkpoints(spp)):
        image_metrics(cp.image, reference)
        count += 1
    wall = time.perf_counter() - start
    render = r.stats.render_seconds
    r.release()
    return wall, render, count


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", nargs="?", default=str(DEFAULT))
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--pairs", type=int, default=5)
    args = ap.parse_args()
    scene, size = load_scene(args.scene), (args.size, args.size)
    r = Renderer(scene, size=size, seed=999)
    reference = r.render(spp=16)  # any image of the right size: metrics cost the same
    print(f"machine: {machine_line(describe_machine(r.ctx))}")
    print(f"device: {describe(r.ctx)}")
    r.release()
    image_metrics(reference, reference)  # imports outside the timings
    ratios, inside = [], []
    for seed in range(1, args.pairs + 1):
        p = plain(scene, size, args.spp, seed)
        wall, render, count = checkpointed(scene, size, args.spp, seed, reference)
        ratios.append(wall / p)
        inside.append(wall / render)
        print(f"pair {seed}: plain {p:.2f} s; checkpointed wall {wall:.2f} s ({count} checkpoints, frames {render:.2f} s)"
              f" -> wall / plain {wall / p:.3f}, wall / frames {wall / render:.3f}", flush=True)
    print(f"median wall / plain render: {statistics.median(ratios):.3f} (min {min(ratios):.3f}, max {max(ratios):.3f})")
    print(f"median wall / its own frames: {statistics.median(inside):.3f} (the checkpoints' readback and metrics)")


if __name__ == "__main__":
    main()
