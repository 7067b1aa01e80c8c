"""Import time of scenes, split into parse, mesh load, images, BVH build, and the rest of the
packing for the GPU; cold (an empty BVH cache) and cached (the BVH read from the cache).

    python benchmarks/import_times.py [SCENE ...] [--repeat 3] [--out FILE.json]

Default scenes: Lift's three pbrt scenes. Each measurement runs in a fresh process with
LIFT_GL_CACHE_DIR pointing at a temporary folder: the first run builds the BVH ("cold"),
later runs read it ("cached"). Times are wall clock inside the process, after Python's own
imports (reported separately); the OS file cache is warm after the first run, so "cold"
means cold for lift-gl's BVH cache, not for the disk. With --repeat N the median of N-1
cached runs is reported.

    parse        reading the scene file itself (load_scene minus the two below)
    mesh load    PLY/OBJ files through trimesh, cleaned, transformed
    images       textures and environment maps read from disk
    bvh          build_bvh_cached: the SAH build (cold) or the cache read (cached)
    pack rest    the other GPU arrays: triangles, lights, materials, textures, env CDFs
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
DEFAULT = ["scenes_lift/cornell-box/scene.pbrt", "scenes_lift/dining-room/scene.pbrt",
           "scenes_lift/classroom/scene.pbrt"]


def child(scene_path: str) -> None:
    """Time one import in this (fresh) process; print JSON."""
    t0 = time.perf_counter()
    import warnings

    import trimesh  # noqa: F401  (heavy; counted in python_imports)

    from lift_gl.scene import mesh_io, mitsuba_loader, pack, pbrt_loader, texture_files
    from lift_gl.scene.loader import load_scene
    imports = time.perf_counter() - t0
    spent = {"mesh load": 0.0, "images": 0.0, "bvh": 0.0}

    def timed(kind, fn):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[kind] += time.perf_counter() - start
        return wrapper

    for module in (pbrt_loader, mitsuba_loader, mesh_io):
        if hasattr(module, "load_mesh_file"):
            module.load_mesh_file = timed("mesh load", module.load_mesh_file)
    for module in (pbrt_loader, mitsuba_loader, texture_files):
        if hasattr(module, "read_environment_image"):
            module.read_environment_image = timed("images", module.read_environment_image)
    texture_files.TextureLibrary.load = timed("images", texture_files.TextureLibrary.load)
    pack.build_bvh_cached = timed("bvh", pack.build_bvh_cached)

    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(scene_path)
    loaded = time.perf_counter() - start
    start = time.perf_counter()
    packed = pack.pack_scene(scene)
    packing = time.perf_counter() - start
    print(json.dumps({
        "python_imports": imports, "parse": loaded - spent["mesh load"] - spent["images"],
        "mesh load": spent["mesh load"], "images": spent["images"], "bvh": spent["bvh"],
        "pack rest": packing - spent["bvh"], "total": loaded + packing,
        "triangles": packed.num_triangles, "textures": len(scene.textures),
    }))


def measure(scene_path: Path, cache: Path) -> dict:
    env = dict(os.environ, LIFT_GL_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, __file__, "--child", str(scene_path)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenes", nargs="*")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--shared", type=Path, default=SHARED)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child)
        return
    scenes = [Path(s) for s in args.scenes] or [args.shared / s for s in DEFAULT]
    import platform
    rows = []
    keys = ("parse", "mesh load", "images", "bvh", "pack rest", "total")
    print(f"machine: {platform.node()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    print(f"{'scene':<28} {'triangles':>9}  run     " + "".join(f"{k:>10}" for k in keys) + "   (seconds)")
    for path in scenes:
        with tempfile.TemporaryDirectory() as cache:
            runs = [measure(path, Path(cache)) for _ in range(max(args.repeat, 2))]
        cold, cached = runs[0], runs[1:]
        median = {k: sorted(r[k] for r in cached)[len(cached) // 2] for k in keys + ("python_imports",)}
        name = f"{path.parent.name}/{path.name}"
        for label, r in (("cold", cold), ("cached", median)):
            print(f"{name:<28} {cold['triangles']:>9}  {label:<7} " + "".join(f"{r[k]:>10.3f}" for k in keys))
        rows.append({"scene": str(path), "triangles": cold["triangles"], "cold": cold, "cached_median": median})
    if args.out:
        args.out.write_text(json.dumps({"machine": platform.node(), "rows": rows}, indent=2))


if __name__ == "__main__":
    main()
