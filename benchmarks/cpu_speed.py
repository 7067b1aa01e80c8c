"""Cost per sample of `pt` on Lift's cornell-box on a CPU rasterizer (Mesa llvmpipe), for
several versions of the code or settings, interleaved so that all see the same machine load.

    python benchmarks/cpu_speed.py [--rounds 4] [--spp 32] [--size 128] VARIANT [VARIANT ...]

A VARIANT is LABEL=REV[,KEY=VALUE...]: REV a git revision (extracted with `git archive` into a
temporary folder) or `.` for this working tree; KEY=VALUE are environment variables (upper
case, e.g. LP_NUM_THREADS=1), pt parameters (e.g. rr_depth=1) or spf=N (samples per frame).
The first variant is the baseline. Each round runs every variant once, in a rotated order,
each in a fresh process: shader compilation and a 2-spp warm-up are not timed. Reported per
variant: the median over rounds of the render's wall time and of the process's CPU time (all
threads) per sample per pixel, and the median, min and max over rounds of the baseline's time
divided by the variant's (a speed-up; the rounds pair variants that ran side by side). On a
machine shared with other jobs the CPU time is the steadier measure: the wall time depends on
how much of the two cores the render got.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENE = REPO.parent / "shared" / "scenes_lift" / "cornell-box" / "scene.pbrt"

CHILD = r"""
import json, resource, sys, time
from lift_gl import load_scene
from lift_gl.gl.context import describe
from lift_gl.renderer import Renderer
scene_path, size, spp, spf, params = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), json.loads(sys.argv[5])
r = Renderer(load_scene(scene_path), size=(size, size), integrator="pt", params=params, samples_per_frame=spf or None)
r.render(spp=2)  # shader compilation and first-use costs
r.reset()
cpu = lambda: sum(resource.getrusage(resource.RUSAGE_SELF)[:2])
c0, t0 = cpu(), time.perf_counter()
r.render(spp=spp)
print(json.dumps({"wall_ms": (time.perf_counter() - t0) / spp * 1e3, "cpu_ms": (cpu() - c0) / spp * 1e3,
                  "device": describe(r.ctx), "dropped": r.stats.dropped_samples}))
"""


def parse_variant(text: str, tmp: Path) -> dict:
    label, _, spec = text.partition("=")
    rev, *settings = spec.split(",")
    env, params, spf = {}, {}, 0
    for item in settings:
        key, _, value = item.partition("=")
        if key == "spf":
            spf = int(value)
        elif key.isupper():
            env[key] = value
        else:
            params[key] = json.loads(value.lower() if value.lower() in ("true", "false") else value)
    if rev == ".":
        root = REPO
    else:
        root = tmp / label
        root.mkdir()
        archive = subprocess.run(["git", "-C", str(REPO), "archive", rev], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(root)], input=archive, check=True)
    return {"label": label, "root": root, "env": env, "params": params, "spf": spf, "wall": [], "cpu": []}


def run_once(v: dict, args) -> dict:
    env = dict(os.environ, **v["env"], PYTHONPATH=str(v["root"]))
    out = subprocess.run([sys.executable, "-c", CHILD, str(args.scene), str(args.size), str(args.spp), str(v["spf"]),
                          json.dumps(v["params"])], env=env, cwd=v["root"], capture_output=True, text=True)
    if out.returncode:
        sys.exit(f"{v['label']} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("variants", nargs="+")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--scene", type=Path, default=SCENE)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if not args.scene.is_file():
        sys.exit(f"{args.scene} not found (the shared data folder)")
    with tempfile.TemporaryDirectory() as tmp:
        variants = [parse_variant(text, Path(tmp)) for text in args.variants]
        loads = []
        for r in range(args.rounds):
            k = r % len(variants)
            for v in variants[k:] + variants[:k]:
                result = run_once(v, args)
                v["wall"].append(result["wall_ms"])
                v["cpu"].append(result["cpu_ms"])
                device = result["device"]
            loads.append(os.getloadavg()[0])
            print(f"round {r + 1}: " + ", ".join(f"{v['label']} {v['cpu'][-1]:.1f} ms CPU" for v in variants), flush=True)
    base = variants[0]
    print(f"\n{platform.node()}, {os.cpu_count()} CPUs, {device}; load average during the rounds "
          f"{min(loads):.1f}-{max(loads):.1f}; {args.size}x{args.size}, {args.spp} spp per run, {args.rounds} rounds")
    rows = []
    for v in variants:
        row = {"label": v["label"], "wall_ms_per_spp": v["wall"], "cpu_ms_per_spp": v["cpu"]}
        for m in ("wall", "cpu"):
            ratios = [b / x for b, x in zip(base[m], v[m])]
            row[f"{m}_speedup"] = {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios)}
            print(f"{v['label']:>16s} {m:4s} {statistics.median(v[m]):8.2f} ms/spp   {base['label']} / this: "
                  f"median {statistics.median(ratios):.3f} (min {min(ratios):.3f}, max {max(ratios):.3f})")
        rows.append(row)
    if args.json:
        args.json.write_text(json.dumps({"device": device, "loads": loads, "size": args.size, "spp": args.spp,
                                         "variants": rows}, indent=1))


if __name__ == "__main__":
    main()
