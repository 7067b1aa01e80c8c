"""Mitsuba 3's error against render time on an exported scene (run with a Python that has
`mitsuba`; lift_gl on PYTHONPATH for the metrics). The baseline for benchmarks/
cornell_convergence.py, measured alongside it so that the two share the machine's load.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so PYTHONPATH=. \\
        MITSUBA_PYTHON benchmarks/mitsuba_convergence.py OUTDIR/scene.xml REF.exr [--spp 1024]

Each checkpoint is a separate render of that many samples (Mitsuba renders in one pass);
time is the wall time of mi.render including its JIT compilation, as a user sees it, and
also without the first (compiling) call.
"""
from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np


def cpu_seconds() -> float:
    """CPU time of this process, all threads (Dr.Jit's pool included)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    import mitsuba as mi

    parser = argparse.ArgumentParser()
    parser.add_argument("xml")
    parser.add_argument("reference")
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--downsample", type=int, default=1,
                        help="box-downsample Mitsuba's image by this factor before comparing (a render at the "
                             "film's size with its filter, as the reference was made; --spp is per film pixel)")
    parser.add_argument("--out")
    args = parser.parse_args()
    mi.set_variant(args.variant)
    from lift_gl.metrics import box_downsample, rel_mse

    scene = mi.load_file(args.xml)
    size = scene.sensors()[0].film().size()
    ref = np.array(mi.Bitmap(args.reference).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32), np.float32)
    ref = box_downsample(ref, ref.shape[0] * args.downsample // int(size[1]))
    mi.render(scene, spp=1)  # JIT warm-up, reported separately
    rows = []
    spp = 1
    while spp <= args.spp:
        start, cpu_start = time.perf_counter(), cpu_seconds()
        image = np.array(mi.render(scene, spp=spp, seed=spp), np.float32)
        if args.downsample > 1:
            image = box_downsample(image, args.downsample)
        seconds, cpu = time.perf_counter() - start, cpu_seconds() - cpu_start
        rows.append({"spp": spp, "samples_per_output_pixel": spp * args.downsample ** 2, "seconds": seconds, "cpu_seconds": cpu, "rel_mse": rel_mse(image, ref)})
        print(f"{spp:6d} spp  {seconds:8.2f} s  CPU {cpu:8.2f} s  relMSE {rows[-1]['rel_mse']:.5f}", flush=True)
        spp *= 2
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"variant": args.variant, "downsample": args.downsample, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
