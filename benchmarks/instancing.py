"""Instances against the same scene flattened: build time, GPU memory, render time, and
the cost of moving one instance.

    python benchmarks/instancing.py [--grid 10] [--tris 10000] [--size 96x96] [--spp 2]
        [--repeat 5] [--json benchmarks/results/instancing_llvmpipe.json]
    python benchmarks/instancing.py --cornell [--repeat 8]    # ms/frame of scenes/cornell.toml only

The scene: a grid x grid field of one torus mesh (--tris triangles: 100 x 50 sections for 10k),
each copy turned and scaled differently, on a floor under a constant sky; once as instances
(one BLAS + a TLAS) and once flattened (every copy a world mesh, one BVH over all of them).

- build: CPU seconds (getrusage, user + system) of pack_scene with an empty BVH cache, best
  of --repeat; what a scene load costs before anything is drawn.
- GPU memory: the bytes of every scene storage buffer (SceneBuffers.memory(), as
  `lift-gl render --explain` lists them).
- render: `pt` at --size, --spp samples a frame, the two renderers' frames interleaved,
  best of --repeat (wall time: render() reads the image back, so the GPU has finished).
- move: CPU seconds to place one instance elsewhere (repack_instances: a new TLAS, no BVH
  build) against re-packing the flattened scene with that copy moved (its BVH rebuilt).

--cornell renders scenes/cornell.toml with `pt` and prints ms/frame and the image's sum; it
imports nothing of the instancing code, so running it with another checkout on PYTHONPATH
compares a scene without instances before and after the feature.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def torus_mesh(triangles: int):
    import trimesh

    from lift_gl.scene.model import Mesh

    minor = max(int(round(np.sqrt(triangles / 4))), 3)
    major = max(triangles // (2 * minor), 3)
    t = trimesh.creation.torus(0.35, 0.12, major_sections=major, minor_sections=minor)
    return Mesh("torus", t.vertices, t.faces, 0, normals=t.vertex_normals)


def field_scene(grid: int, triangles: int):
    from lift_gl.scene import primitives as prim
    from lift_gl.scene.model import Camera, Environment, Instance, Material, Scene

    rng = np.random.default_rng(5)
    materials = [Material("clay", base_color=np.array([0.75, 0.6, 0.5])),
                 Material("floor", base_color=np.array([0.5, 0.5, 0.5]))]
    floor = prim.quad_centered([0, 0, 0], [grid + 2.0, 0, 0], [0, 0, -(grid + 2.0)], 1)
    floor.name = "floor"
    instances = []
    for i in range(grid):
        for j in range(grid):
            m = prim.trs_matrix([i - (grid - 1) / 2, 0.3, j - (grid - 1) / 2], rng.uniform(0, 90, 3),
                                rng.uniform(0.7, 1.2))
            instances.append(Instance(0, m, name=f"torus {i},{j}"))
    camera = Camera(position=[0, 0.6 * grid, 0.9 * grid], target=[0, 0, 0])
    return Scene(camera, materials, [floor], environment=Environment(np.array([1.0, 1.0, 1.0])),
                 prototypes=[torus_mesh(triangles)], instances=instances)


def build_seconds(scene, repeat: int) -> tuple[float, object]:
    from lift_gl.scene.pack import pack_scene

    best, packed = np.inf, None
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as cache:  # no cached BVH: the build itself
            t0 = cpu_seconds()
            packed = pack_scene(scene, cache_dir=cache)
            best = min(best, cpu_seconds() - t0)
    return best, packed


def gpu_bytes(renderer) -> int:
    return int(sum(size for name, _, size in renderer.buffers.memory() if name != "stats"))


def frame_ms(renderers: dict, spp: int, repeat: int) -> dict:
    best = {k: np.inf for k in renderers}
    for r in renderers.values():
        r.render(spp=spp)  # compile, upload, warm up
    for _ in range(repeat):
        for key, r in renderers.items():
            r.reset()
            t0 = time.perf_counter()
            r.render(spp=spp)
            best[key] = min(best[key], 1e3 * (time.perf_counter() - t0))
    return best


def moved_one(scene):
    from lift_gl.scene import primitives as prim

    instances = list(scene.instances)
    lift = prim.translate_matrix([0.0, 0.5, 0.0])
    instances[0] = dataclasses.replace(instances[0], transform=lift @ instances[0].transform)
    return dataclasses.replace(scene, instances=instances)


def run(args) -> dict:
    from lift_gl.renderer import Renderer
    from lift_gl.scene.instances import flatten_instances
    from lift_gl.scene.pack import pack_scene, repack_instances

    size = tuple(int(v) for v in args.size.split("x"))
    scene = field_scene(args.grid, args.tris)
    flat = flatten_instances(scene)
    out = {"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
           "grid": args.grid, "instances": len(scene.instances), "mesh_triangles": len(scene.prototypes[0].indices),
           "size": list(size), "spp": args.spp, "repeat": args.repeat}
    out["build_cpu_s"] = {}
    packed = {}
    for key, s in (("instanced", scene), ("flattened", flat)):
        out["build_cpu_s"][key], packed[key] = build_seconds(s, args.repeat)
    out["triangles_on_gpu"] = {k: int(p.num_triangles) for k, p in packed.items()}
    out["bvh_nodes"] = {k: int(p.bvh_nodes.shape[0]) for k, p in packed.items()}
    out["bvh_builder"] = {k: p.bvh_builder for k, p in packed.items()}  # $LIFT_GL_BVH_BUILDER picks

    renderers = {"instanced": Renderer(scene, size=size, integrator="pt", seed=1),
                 "flattened": Renderer(flat, size=size, integrator="pt", seed=1)}
    out["renderer"] = renderers["instanced"].ctx.info.get("GL_RENDERER", "?")
    out["gpu_buffer_bytes"] = {k: gpu_bytes(r) for k, r in renderers.items()}
    out["gpu_buffers"] = {k: {name: size for name, _, size in r.buffers.memory()} for k, r in renderers.items()}
    out["frame_ms"] = frame_ms(renderers, args.spp, args.repeat)
    images = {k: r.render(spp=args.spp) for k, r in renderers.items()}
    out["image_rel_mean_abs_diff"] = float(np.abs(images["instanced"] - images["flattened"]).mean()
                                           / images["flattened"].mean())
    for r in renderers.values():
        r.release()

    moved = moved_one(scene)
    best_move, best_flat = np.inf, np.inf
    for _ in range(args.repeat):
        t0 = cpu_seconds()
        repack_instances(packed["instanced"], moved)
        best_move = min(best_move, cpu_seconds() - t0)
        with tempfile.TemporaryDirectory() as cache:
            t0 = cpu_seconds()
            pack_scene(flatten_instances(moved), cache_dir=cache)
            best_flat = min(best_flat, cpu_seconds() - t0)
    out["move_one_cpu_s"] = {"instanced": best_move, "flattened": best_flat}
    for k in ("build_cpu_s", "gpu_buffer_bytes", "frame_ms", "move_one_cpu_s"):
        out[k]["ratio"] = out[k]["instanced"] / out[k]["flattened"]
    return out


def cornell(args) -> dict:
    from lift_gl import load_scene
    from lift_gl.renderer import Renderer

    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(96, 96), integrator="pt", seed=1)
    best = frame_ms({"cornell": r}, args.spp, args.repeat)["cornell"]
    r.reset()
    image = r.render(spp=args.spp)
    r.release()
    return {"cornell_pt_ms": best, "image_sum": float(image.astype(np.float64).sum())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grid", type=int, default=10)
    ap.add_argument("--tris", type=int, default=10000)
    ap.add_argument("--size", default="96x96")
    ap.add_argument("--spp", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json")
    ap.add_argument("--cornell", action="store_true")
    args = ap.parse_args()
    out = cornell(args) if args.cornell else run(args)
    text = json.dumps(out, indent=1, default=lambda v: v if not isinstance(v, tuple) else list(v))
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")


if __name__ == "__main__":
    main()
