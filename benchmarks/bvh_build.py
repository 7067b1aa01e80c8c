"""BVH build speed and tree quality for random triangle soups (10k, 100k, 1M) and, when the
asset is present, the 100k-triangle dragon.

    python benchmarks/bvh_build.py [--sizes 10000,100000,1000000] [--repeat 1] [--out FILE.json]

Prints a table; --out also writes the figures as JSON. The SAH cost column is the expected
number of box + triangle tests of a random ray that hits the root box (lower is better).
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from lift_gl.accel.bvh import BVH, build_bvh, sah_cost  # noqa: E402,F401 (sah_cost: other benchmarks import it from here)
from lift_gl.report.records import write_json  # noqa: E402

DRAGON = Path(__file__).resolve().parent.parent.parent / "shared" / "assets" / "meshes" / "dragon_100k.ply"


def random_soup(n: int, seed: int = 0) -> np.ndarray:
    """Triangles of roughly equal size scattered in a unit cube (about 1/cbrt(n) apart)."""
    rng = np.random.default_rng(seed)
    size = 0.5 / np.cbrt(n)
    return (rng.random((n, 1, 3)) + size * rng.standard_normal((n, 3, 3))).astype(np.float32)


def load_mesh(path: Path) -> np.ndarray:
    import trimesh

    mesh = trimesh.load(path, force="mesh", process=False)
    return np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.faces)]


def bench(name: str, tris: np.ndarray, repeat: int) -> dict:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        bvh = build_bvh(tris)
        times.append(time.perf_counter() - t0)
    best = min(times)
    leaves = bvh.num_leaves
    return {
        "scene": name,
        "triangles": int(len(tris)),
        "seconds": best,
        "triangles_per_second": len(tris) / best,
        "nodes": bvh.num_nodes,
        "leaves": leaves,
        "mean_leaf_size": len(tris) / max(leaves, 1),
        "max_leaf_size": int(bvh.count.max()),
        "depth": bvh.depth,
        "sah_cost": sah_cost(bvh),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--repeat", type=int, default=1, help="best of N builds")
    ap.add_argument("--mesh", type=Path, default=DRAGON, help="a real mesh to include if present")
    ap.add_argument("--out", type=Path, help="write the results as JSON here")
    args = ap.parse_args(argv)

    cases = [(f"soup {int(n):,}", lambda n=int(n): random_soup(n)) for n in args.sizes.split(",") if n]
    if args.mesh and args.mesh.is_file():
        cases.append((args.mesh.stem, lambda: load_mesh(args.mesh)))

    rows = []
    header = f"{'scene':<16}{'triangles':>11}{'seconds':>9}{'tris/s':>11}{'nodes':>10}{'leaves':>10}" \
             f"{'leaf avg':>9}{'max':>5}{'depth':>6}{'SAH':>8}"
    print(header)
    print("-" * len(header))
    for name, make in cases:
        r = bench(name, make(), args.repeat)
        rows.append(r)
        print(f"{r['scene']:<16}{r['triangles']:>11,}{r['seconds']:>9.2f}{r['triangles_per_second']:>11,.0f}"
              f"{r['nodes']:>10,}{r['leaves']:>10,}{r['mean_leaf_size']:>9.2f}{r['max_leaf_size']:>5}"
              f"{r['depth']:>6}{r['sah_cost']:>8.1f}", flush=True)

    if args.out:
        machine = {"platform": platform.platform(), "python": platform.python_version(),
                   "numpy": np.__version__, "cpus": os.cpu_count(), "processor": platform.processor()}
        write_json(args.out, {"machine": machine, "results": rows}, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
