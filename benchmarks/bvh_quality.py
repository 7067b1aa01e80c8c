"""How good the SAH BVH of a scene is, and whether more bins or split triangles would help:
triangle sizes against the scene, nodes, depth, leaf sizes, SAH cost (lift_gl.accel.bvh) and
how much sibling boxes add up to over their parent's (overlap), for builds with several bin
counts and split settings (accel/presplit.py resolve_splits), with each build's CPU time,
peak memory (tracemalloc: numpy's arrays included) and GPU bytes of its tree and triangle rows.

    python benchmarks/bvh_quality.py SCENE|MESH.ply... [--bins 32,128,auto] [--splits off,auto] [--json FILE]

Scenes that do not exist are skipped with a note (the ../shared scenes are not everywhere).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bvh_build import load_mesh, sah_cost  # noqa: E402

ROW_BYTES = 3 * 48 + 8   # GPU bytes of one triangle row: positions, normals, uvs (vec4 x 3 each), info


def _areas(b) -> np.ndarray:
    e = np.maximum(b.bmax.astype(np.float64) - b.bmin, 0)
    return e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]


def _triangles(path: str) -> np.ndarray:
    if Path(path).suffix.lower() in (".ply", ".obj", ".stl"):
        return load_mesh(Path(path))
    from lift_gl.scene.loader import load_scene

    scene = load_scene(path)
    return np.concatenate([m.positions[m.indices] for m in scene.meshes]).astype(np.float32)


def scene_quality(path: str, bin_counts, split_values=("off",)) -> dict:

    from lift_gl.accel import cache as cache_mod
    from lift_gl.accel.presplit import resolve_splits

    tris = _triangles(path)
    points = tris.reshape(-1, 3)
    diag = float(np.linalg.norm(points.max(0) - points.min(0)))
    extent = np.linalg.norm(tris.max(1) - tris.min(1), axis=1) / diag  # each triangle's box diagonal
    out = {"scene": Path(path).parent.name if Path(path).stem == "scene" else Path(path).stem,
           "triangles": int(len(tris)),
           "extent_over_scene": {"median": float(np.median(extent)), "p99": float(np.quantile(extent, 0.99)),
                                 "max": float(extent.max()), "over_1pct": int((extent > 0.01).sum()),
                                 "over_10pct": int((extent > 0.1).sum())},
           "builds": []}
    for bins, splits in ((b, s) for b in bin_counts for s in split_values):
        if True:
            tracemalloc.start()
            start = time.process_time()
            b = cache_mod.build_with(tris, "sah", resolve_splits(splits), bins=bins)   # accel/cache.py
            cpu = time.process_time() - start
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            leaves = b.count[b.count > 0]
            area = _areas(b)
            interior = np.nonzero(b.count == 0)[0]
            child = b.first[interior]
            overlap = (area[child] + area[child + 1]) / np.maximum(area[interior], 1e-30)
            rows = int(b.order.size)
            out["builds"].append({"bins": bins, "splits": splits, "cpu_s": cpu, "peak_mib": peak / 2**20,
                                  "rows": rows, "rows_over_triangles": rows / max(len(tris), 1),
                                  "gpu_mib": (b.num_nodes * 32 + rows * ROW_BYTES) / 2**20,
                                  "nodes": b.num_nodes, "depth": b.depth,
                                  "leaves": int(len(leaves)), "tris_per_leaf": float(leaves.mean()),
                                  "sah_cost": sah_cost(b),
                                  "children_over_parent_area_median": float(np.median(overlap)),
                                  "children_over_parent_area_p90": float(np.quantile(overlap, 0.9))})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--bins", default="32,128", help="comma-separated bin counts (8 to 256) or auto (32, and 128 "
                    "for the top nodes where that lowers the SAH cost)")
    ap.add_argument("--splits", default="off", help="comma-separated split settings (accel/presplit.py), e.g. off,auto")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    results = []
    for p in args.scenes:
        if not Path(p).exists():
            print(f"skipped (not here): {p}", file=sys.stderr)
            continue
        results.append(scene_quality(p, [b.strip() for b in args.bins.split(",")], args.splits.split(",")))
    print("| scene | triangles | tri extent / scene: median, p99 | tris > 1% / > 10% of it | bins | splits "
          "| rows / triangles | nodes | depth | tris/leaf | SAH cost | children/parent area (median, p90) "
          "| build CPU s | peak MiB | GPU MiB (nodes + rows) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        e = r["extent_over_scene"]
        for b in r["builds"]:
            print(f"| {r['scene']} | {r['triangles']:,} | {e['median']:.2g}, {e['p99']:.2g} | {e['over_1pct']:,} / "
                  f"{e['over_10pct']:,} | {b['bins']} | {b['splits']} | {b['rows_over_triangles']:.3f} | "
                  f"{b['nodes']:,} | {b['depth']} | {b['tris_per_leaf']:.2f} | "
                  f"{b['sah_cost']:.1f} | {b['children_over_parent_area_median']:.2f}, "
                  f"{b['children_over_parent_area_p90']:.2f} | {b['cpu_s']:.2f} | {b['peak_mib']:.0f} | "
                  f"{b['gpu_mib']:.1f} |")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
