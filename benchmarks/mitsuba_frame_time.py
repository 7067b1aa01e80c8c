"""Mitsuba 3 frame time at 1 spp, the side-by-side baseline of benchmarks/gpu.py.

    python benchmarks/mitsuba_frame_time.py SCENE.xml [--variant cuda_ad_rgb] [--size 1920x1080]
                                            [--max-depth 32] [--frames 20] [--out FILE.json]

SCENE.xml comes from benchmarks/export_mitsuba.py. Film size, samples (1) and path length are
set here: --max-depth counts bounces as lift-gl does; Mitsuba's max_depth counts path
vertices, so it gets --max-depth + 1. The first renders compile Dr.Jit kernels (cached
afterwards) and are not timed; each timed frame is mi.render plus dr.eval and a device sync,
wall clock; the JSON keeps every frame, the table the median. On NVIDIA, frames are then
rendered until the GPU's SM clock has risen from idle (lift_gl/report/gpu_clock.py, as
lift-gl's benchmarks do) and the clock after each timed frame is kept.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("--variant", default="cuda_ad_rgb")
    parser.add_argument("--size", default="1920x1080")
    parser.add_argument("--max-depth", type=int, default=32)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    w, h = (int(v) for v in args.size.split("x"))
    scene = mi.load_file(str(args.scene))
    params = mi.traverse(scene)
    sensor = scene.sensors()[0]
    film_params = mi.traverse(sensor.film())
    film_params["size"] = mi.ScalarVector2u(w, h)
    film_params.update()
    integrator = mi.load_dict({"type": "path", "max_depth": args.max_depth + 1})
    del params

    def frame(seed):
        img = mi.render(scene, spp=1, integrator=integrator, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        return img

    start = time.perf_counter()
    for i in range(args.warmup):
        frame(i)
    warm_s = time.perf_counter() - start
    from lift_gl.report.gpu_clock import ClockReader, warm_up

    clock = ClockReader()
    clock_warm = warm_up(lambda: frame(0), clock)
    times, mhz = [], []
    for i in range(args.frames):
        start = time.perf_counter()
        img = frame(args.warmup + i)
        times.append(time.perf_counter() - start)
        mhz.append(clock.sm_mhz())
    shape = tuple(int(v) for v in img.shape)
    result = {"variant": args.variant, "size": [w, h], "max_depth_bounces": args.max_depth, "spp": 1,
              "frame_ms_median": 1e3 * statistics.median(times), "frame_ms_min": 1e3 * min(times),
              "frame_ms_all": [1e3 * t for t in times], "warmup_seconds": warm_s, "image_shape": shape,
              "mitsuba": mi.__version__, "drjit": dr.__version__, "scene": args.scene.name,
              "sm_clock": {"warm_up": clock_warm, "frames_mhz": mhz}}
    print(f"mitsuba {mi.__version__} {args.variant} {w}x{h} 1 spp depth {args.max_depth}: "
          f"median {result['frame_ms_median']:.2f} ms, min {result['frame_ms_min']:.2f} ms "
          f"(warm-up {warm_s:.1f} s; SM clock {min((m for m in mhz if m), default='not read')} MHz)", flush=True)
    if args.out:
        args.out.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
