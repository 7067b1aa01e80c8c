"""Denoise time on this CPU: the ONNX model (onnxruntime) and OIDN (pyoidn), at 256x256,
1280x720 and 1920x1080, with albedo and normal, runs interleaved so that both see the same
machine load; the median of --repeat runs and the ratio OIDN / ONNX, in wall-clock seconds and
in CPU seconds of the process (all its threads: the work done, less sensitive to other jobs on
a shared machine).

    python benchmarks/denoise_time.py [--repeat 3] [--denoisers onnx,oidn] [--out FILE.md]

Denoiser names are looked up as in benchmarks/denoise_quality.py (the registry first).
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from denoise_quality import get_denoiser  # noqa: E402

SIZES = ((256, 256), (1280, 720), (1920, 1080))


def cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform
    return platform.processor() or platform.machine()


def inputs(w, h, seed=0):
    rng = np.random.default_rng(seed)
    color = rng.gamma(0.5, 1.0, (h, w, 3)).astype(np.float32)
    albedo = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    normal = rng.normal(size=(h, w, 3)).astype(np.float32)
    return color, albedo, normal / np.linalg.norm(normal, axis=2, keepdims=True)


def cpu_seconds() -> float:
    """User + system CPU time of this process, all threads."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--denoisers", default="onnx,oidn",
                   help="comma-separated; onnx:PATH is the ONNX denoiser with another model file")
    p.add_argument("--out", type=Path)
    a = p.parse_args(argv)
    names = a.denoisers.split(",")
    denoisers = {n: get_denoiser(n) for n in names}
    for d in denoisers.values():  # first use loads the model: not timed
        d.denoise(*inputs(32, 32))
    times = {(n, s): [] for n in names for s in SIZES}
    cpu = {(n, s): [] for n in names for s in SIZES}
    for w, h in SIZES:
        args = inputs(w, h)
        for _ in range(a.repeat):
            for n, d in denoisers.items():  # interleaved: each round times every denoiser once
                t, c = time.perf_counter(), cpu_seconds()
                d.denoise(*args)
                times[(n, (w, h))].append(time.perf_counter() - t)
                cpu[(n, (w, h))].append(cpu_seconds() - c)
    ratio = int({"onnx", "oidn"} <= set(names))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [f"Denoise time, median of {a.repeat} interleaved runs: {cpu_name()}, {os.cpu_count()} cores, "
             f"load average {load:.1f} at the end", "",
             "| size | " + " | ".join(f"{n} (s)" for n in names)
             + (" | oidn / onnx |" if ratio else " |") + " " + " | ".join(f"{n} (CPU s)" for n in names)
             + (" | oidn / onnx (CPU) |" if ratio else " |"),
             "|" + " --- |" * (1 + 2 * (len(names) + ratio))]
    for w, h in SIZES:
        row = f"| {w}x{h} |"
        for table in (times, cpu):
            med = {n: float(np.median(table[(n, (w, h))])) for n in names}
            row += " " + " | ".join(f"{med[n]:.3f}" for n in names)
            row += f" | {med['oidn'] / med['onnx']:.2f} |" if ratio else " |"
        lines.append(row)
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(text)


if __name__ == "__main__":
    main()
