"""Error against render time of `pt` on Lift's cornell-box (pbrt-v3) vs. Tungsten's reference.

    python benchmarks/cornell_convergence.py [--size 128] [--spp 1024] [--target 0.00105]
        [--samples-per-frame N] [--out FILE.json]

Renders progressively and, at doubling sample counts, records render time (wall, GPU work
finished), relMSE against the reference box-downsampled to the render size, and SSIM of the
tone-mapped images. The time to reach --target relMSE is interpolated on the log-log curve.
Mitsuba 3.9.1 (llvm_ad_rgb, this machine's 2 cores) reaches relMSE 0.00105 at 128x128 in
about 20-26 s: that is the default target.
"""
from __future__ import annotations

import argparse
import platform
import resource
import time
from pathlib import Path

import numpy as np

from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.image_io import read_image
from lift_gl.metrics import box_downsample, rel_mse, ssim
from lift_gl.renderer import Renderer
from lift_gl.report.records import write_json

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"


def process_cpu_seconds() -> float:
    """CPU time of this process, all threads (llvmpipe's included): on a machine shared with
    other jobs the wall time depends on how much of the cores a run got, this does not."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def seconds_to(rows: list, target: float, key: str) -> float | None:
    """Time (`key`) to reach relMSE `target`, interpolated on the log-log curve."""
    for a, b in zip(rows, rows[1:]):
        if a["rel_mse"] > target >= b["rel_mse"]:
            f = (np.log(a["rel_mse"]) - np.log(target)) / (np.log(a["rel_mse"]) - np.log(b["rel_mse"]))
            return float(np.exp(np.log(a[key]) + f * (np.log(b[key]) - np.log(a[key]))))
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--target", type=float, default=0.00105)
    parser.add_argument("--shared", type=Path, default=SHARED)
    parser.add_argument("--samples-per-frame", type=int, default=None,
                        help="samples per pixel in each frame (default: the renderer's, 1 for pt)")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()

    scene = load_scene(args.shared / "scenes_lift/cornell-box/scene.pbrt")
    reference = read_image(args.shared / "refs/lift/cornell-box.exr")
    reference = box_downsample(reference, reference.shape[0] // args.size)
    renderer = Renderer(scene, size=(args.size, args.size), integrator="pt", samples_per_frame=args.samples_per_frame)
    rows = []
    checkpoints = [2 ** k for k in range(0, 20) if 2 ** k <= args.spp]
    elapsed = cpu = 0.0
    for spp in checkpoints:
        start, cpu_start = time.perf_counter(), process_cpu_seconds()
        image = renderer.render(spp=spp - renderer.stats.spp)
        elapsed += time.perf_counter() - start  # includes the readback of the mean image
        cpu += process_cpu_seconds() - cpu_start
        rows.append({"spp": spp, "seconds": elapsed, "cpu_seconds": cpu, "rel_mse": rel_mse(image, reference),
                     "ssim": ssim(image, reference)})
        print(f"{spp:6d} spp  {elapsed:8.2f} s  CPU {cpu:8.2f} s  relMSE {rows[-1]['rel_mse']:.5f}  "
              f"SSIM {rows[-1]['ssim']:.4f}", flush=True)
    time_to_target = seconds_to(rows, args.target, "seconds")
    cpu_to_target = seconds_to(rows, args.target, "cpu_seconds")
    result = {"machine": f"{platform.node()} {platform.processor() or platform.machine()}, {describe(renderer.ctx)}",
              "size": args.size, "samples_per_frame": renderer.samples_per_frame, "rows": rows, "target_rel_mse": args.target, "seconds_to_target": time_to_target,
              "cpu_seconds_to_target": cpu_to_target,
              "dropped_samples": renderer.stats.dropped_samples}
    print(f"time to relMSE {args.target}: {time_to_target} s, CPU {cpu_to_target} s")
    if args.out:
        write_json(args.out, result, indent=1)


if __name__ == "__main__":
    main()
