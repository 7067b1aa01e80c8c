"""What the à-trous denoiser costs against the trace pass, per resolution, on one machine.

For each size: a Renderer with denoise="final" on scenes/cornell.toml (pt, 1 spp a frame);
then, in rounds, one timed frame's trace pass and one timed denoiser run, interleaved so
that machine load hits them alike. Times are wall clock between ctx.finish() calls (on
llvmpipe the GPU is the CPU and its timer queries miss compute dispatches). The denoiser
run is split into its G-buffer guide pass (unjittered raster) and the filter itself
(demodulation + 5 à-trous iterations + remodulation). Reported: medians, and the ratio
denoise / trace of the same rounds.

    python benchmarks/atrous_times.py [--sizes 256x256,1280x720,1920x1080] [--rounds 3]
                                      [--json benchmarks/results/atrous_times.json]
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from lift_gl.gl.context import describe
from lift_gl.passes.common import GpuTimer
from lift_gl.renderer import Renderer
from lift_gl.report.machine import describe_machine, machine_line
from lift_gl.scene.loader import load_scene

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml"


def measure(scene, size, rounds: int) -> dict:
    r = Renderer(scene, size=size, denoise="final", timers=True)
    r.timers = {name: GpuTimer(r.ctx, cpu_clock=True) for name in ("gbuffer", "trace", "accumulate", "denoise")}
    r.render(spp=2)  # warm-up (shader compilation, first-use costs; the denoiser runs once); both halves filled
    trace, denoise, guides, total = [], [], [], []
    for _ in range(rounds):
        r.render_frame()
        trace.append(r.timers["trace"].last_ms)
        start = time.perf_counter()
        before = r.timers["gbuffer"].total_ns
        r.run_denoiser()  # the guide raster is not timed by a pass timer: it is the difference
        total.append(1e3 * (time.perf_counter() - start))
        denoise.append(r.timers["denoise"].last_ms)
        guides.append(total[-1] - denoise[-1])
        assert r.timers["gbuffer"].total_ns == before
    r.release()
    ratio = [d / t for d, t in zip(total, trace)]
    return {"size": list(size), "rounds": rounds, "trace_ms": trace, "filter_ms": denoise, "guides_ms": guides,
            "denoise_ms": total, "median_trace_ms": statistics.median(trace),
            "median_filter_ms": statistics.median(denoise), "median_denoise_ms": statistics.median(total),
            "denoise_over_trace": ratio, "median_ratio": statistics.median(ratio)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="256x256,1280x720,1920x1080")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    scene = load_scene(SCENE)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    results = []
    for size in sizes:
        result = measure(scene, size, args.rounds)
        results.append(result)
        print(f"{size[0]}x{size[1]}: trace {result['median_trace_ms']:.1f} ms, denoise {result['median_denoise_ms']:.1f} ms "
              f"(filter {result['median_filter_ms']:.1f} ms), ratio {result['median_ratio']:.3f}", flush=True)
    from lift_gl.gl.context import create_context

    ctx = create_context()
    machine = describe_machine(ctx)
    print(f"\nmachine: {machine_line(machine)}; {describe(ctx)}")
    print("| size | trace pass ms (1 spp) | à-trous ms: filter | + guides = denoise | denoise / trace |")
    print("|---|---|---|---|---|")
    for r in results:
        print(f"| {r['size'][0]}x{r['size'][1]} | {r['median_trace_ms']:.1f} | {r['median_filter_ms']:.1f} | "
              f"{r['median_denoise_ms']:.1f} | {r['median_ratio']:.3f} |")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"machine": machine, "device": describe(ctx), "scene": "scenes/cornell.toml",
                                         "integrator": "pt", "results": results}, indent=1) + "\n")


if __name__ == "__main__":
    main()
