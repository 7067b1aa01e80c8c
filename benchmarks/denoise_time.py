"""Denoise time on this CPU: the ONNX model (onnxruntime) and OIDN (pyoidn), at 256x256,
1280x720 and 1920x1080, with albedo and normal, runs interleaved so that both see the same
machine load; the median of --repeat runs and the ratio OIDN / ONNX, in wall-clock seconds and
in CPU seconds of the process (all its threads: the work done, less sensitive to other jobs on
a shared machine).

    python benchmarks/denoise_time.py [--repeat 3] [--denoisers onnx,oidn] [--sizes 256x256,1280x720,1920x1080]
                                      [--out FILE.md]

Denoiser names are looked up as in benchmarks/denoise_quality.py (the registry first); onnx:PATH
times another model file (benchmarks/denoiser_spec.py). With oidn among them, each other
denoiser gets a column oidn / NAME (above 1: NAME is the faster).
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
import denoiser_spec  # noqa: E402
from denoise_quality import get_denoiser  # noqa: E402

SIZES = "256x256,1280x720,1920x1080"


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


def size_list(text: str) -> list[tuple[int, int]]:
    return [tuple(int(v) for v in size.split("x")) for size in text.split(",")]


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--denoisers", default="onnx,oidn",
                   help="comma-separated; onnx:PATH is the ONNX denoiser with another model file")
    p.add_argument("--sizes", type=size_list, default=size_list(SIZES), help="WxH,...")
    p.add_argument("--out", type=Path)
    a = p.parse_args(argv)
    denoisers = {denoiser_spec.label(spec): get_denoiser(spec) for spec in a.denoisers.split(",")}
    names = list(denoisers)
    for d in denoisers.values():  # first use loads the model: not timed
        d.denoise(*inputs(32, 32))
    times = {(n, s): [] for n in names for s in a.sizes}
    cpu = {(n, s): [] for n in names for s in a.sizes}
    for w, h in a.sizes:
        args = inputs(w, h)
        for _ in range(a.repeat):
            for n, d in denoisers.items():  # interleaved: each round times every denoiser once
                t, c = time.perf_counter(), cpu_seconds()
                d.denoise(*args)
                times[(n, (w, h))].append(time.perf_counter() - t)
                cpu[(n, (w, h))].append(cpu_seconds() - c)
    against = [n for n in names if n != "oidn"] if "oidn" in names else []
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    columns = [f"{n} (s)" for n in names] + [f"oidn / {n}" for n in against] \
        + [f"{n} (CPU s)" for n in names] + [f"oidn / {n} (CPU)" for n in against]
    lines = [f"Denoise time, median of {a.repeat} interleaved runs: {cpu_name()}, {os.cpu_count()} cores, "
             f"load average {load:.1f} at the end", "",
             "| size | " + " | ".join(columns) + " |", "|" + " --- |" * (1 + len(columns))]
    for w, h in a.sizes:
        cells = []
        for table in (times, cpu):
            med = {n: float(np.median(table[(n, (w, h))])) for n in names}
            cells += [f"{med[n]:.3f}" for n in names] + [f"{med['oidn'] / med[n]:.2f}" for n in against]
        lines.append(f"| {w}x{h} | " + " | ".join(cells) + " |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(text)


if __name__ == "__main__":
    main()
