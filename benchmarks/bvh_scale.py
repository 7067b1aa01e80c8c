"""BVH builders at scale: build time, peak memory and tree quality for 1M-10M triangles, and
the trace time of each tree on a mesh scene, relative to the binned-SAH build.

    python benchmarks/bvh_scale.py [--sizes 1000000,5000000,10000000]
        [--builders sah,lbvh,lbvh+sah] [--trace-triangles 1000000] [--trace-size 64x64]
        [--trace-spp 4] [--repeat 3] [--json FILE] [--no-trace]

Headless (EGL llvmpipe here, EGL on the GPU machine). Meshes: the dragon of
../shared/assets/meshes (100k triangles; --mesh names another copy) subdivided twice (1.6M,
each triangle into four), copied as often as needed on a grid, each copy turned differently,
and cut to the size asked; an icosphere when the dragon is absent. Nothing is written but the
JSON. The LBVH rows need pyopencl and an OpenCL driver (PoCL); without them they report the
error and the rest goes on.

Also: --render N renders an N-triangle mesh and reports its buffers (a split scene on
llvmpipe); --split-bytes B adds the first builder's tree split into buffers of B bytes to
the trace comparison (the cost of the heap accessors).

Build: each (size, builder) runs in a child process of its own, so that its peak memory is
its own: `peak_build_bytes` is the growth of the resident set during the build (VmHWM after
resetting it, minus VmRSS before), on top of the triangle array itself. SAH cost: expected
box + triangle tests of a random ray that hits the root box (benchmarks/bvh_build.py), and
its ratio to the SAH build's of the same mesh.

Trace: the mesh of --trace-triangles, lit by a constant sky and rendered by `pt` at a small
size, once per builder, frames interleaved (--repeat rounds, best frame time of each); the
ratio is to the SAH tree's frame time, measured in the same rounds.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))
from lift_gl.report.records import write_json  # noqa: E402

DRAGON = REPO.parent / "shared" / "assets" / "meshes" / "dragon_100k.ply"
BUILDERS = ("sah", "lbvh", "lbvh+sah")


# ---------------------------------------------------------------- meshes
def _subdivide(t: np.ndarray) -> np.ndarray:
    """Every triangle into four (edge midpoints): the same surface, four times as dense."""
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    ab, bc, ca = (a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5
    return np.concatenate([np.stack(x, axis=1) for x in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])


def base_mesh(path: Path = DRAGON) -> tuple[np.ndarray, str]:
    """float32 (T, 3, 3) in a unit box, and its name."""
    import trimesh

    if path.is_file():
        m = trimesh.load(path, force="mesh", process=False)
        tris, name = np.asarray(m.vertices, np.float32)[np.asarray(m.faces)], f"{path.stem} x4^2"
        tris = _subdivide(_subdivide(tris))
    else:
        m = trimesh.creation.icosphere(subdivisions=8)   # 1.3M triangles
        tris, name = np.asarray(m.vertices, np.float32)[np.asarray(m.faces)], "icosphere(8)"
    lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    return ((tris - lo) / (hi - lo).max()).astype(np.float32), name


def make_mesh(n: int, path: Path = DRAGON) -> tuple[np.ndarray, str]:
    """n triangles: copies of base_mesh on a grid (spacing 0.8: neighbours interpenetrate),
    each turned about y by its own angle, cut to n."""
    base, name = base_mesh(path)
    copies = -(-n // len(base))
    side = int(np.ceil(np.sqrt(copies)))
    out = np.empty((copies * len(base), 3, 3), np.float32)
    for k in range(copies):
        a = 2.399963 * k   # golden angle: no two copies alike
        rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]], np.float32)
        shift = np.array([0.8 * (k % side), 0, 0.8 * (k // side)], np.float32)
        out[k * len(base):(k + 1) * len(base)] = (base - 0.5) @ rot.T + shift
    return out[:n], f"{name}, {copies} copies" if copies > 1 else name


# ---------------------------------------------------------------- one build (child process)
def _status_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    return -1


def build_one(n: int, builder: str, mesh: Path) -> dict:
    from bvh_build import sah_cost

    from lift_gl.accel.cache import build_with

    tris, name = make_mesh(n, mesh)
    if builder != "sah":   # OpenCL set-up and kernel compilation are not part of a build
        build_with(tris[:4096], builder)
    rss_before = _status_kib("VmRSS")
    try:   # reset the high-water mark to the current resident set (Linux >= 4.0)
        Path("/proc/self/clear_refs").write_text("5")
        hwm_reset = True
    except OSError:
        hwm_reset = False
    steps = {}
    t0, c0 = time.perf_counter(), time.process_time()
    if builder == "sah":
        bvh = build_with(tris, builder)
    else:   # the same build as build_with's, with the time of each step
        from lift_gl.accel.lbvh import build_lbvh

        bvh = build_lbvh(tris, refine=builder == "lbvh+sah", timings=steps)
    seconds, cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
    peak = _status_kib("VmHWM")
    return {"triangles": n, "mesh": name, "builder": builder, "seconds": seconds,
            "cpu_seconds": cpu_seconds,   # all threads (PoCL's too): less sensitive to load
            "step_seconds": steps,
            "peak_build_bytes": (peak - rss_before) * 1024 if hwm_reset else None,
            "peak_rss_bytes": peak * 1024, "input_bytes": int(tris.nbytes),
            "nodes": bvh.num_nodes, "leaves": bvh.num_leaves, "depth": bvh.depth,
            "mean_leaf_size": n / max(bvh.num_leaves, 1), "sah_cost": sah_cost(bvh),
            "load_average_1min": os.getloadavg()[0]}


def run_child(n: int, builder: str, mesh: Path) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", str(n), builder, "--mesh", str(mesh)],
                         capture_output=True, text=True)
    if out.returncode != 0:
        return {"triangles": n, "builder": builder, "error": out.stderr.strip().splitlines()[-1:]}
    return json.loads(out.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------- trace time
def mesh_scene(tris: np.ndarray):
    from lift_gl.scene.model import Camera, Environment, Material, Mesh, Scene

    lo, hi = tris.reshape(-1, 3).min(0).astype(np.float64), tris.reshape(-1, 3).max(0).astype(np.float64)
    centre, extent = (lo + hi) / 2, float((hi - lo).max())
    mesh = Mesh("mesh", tris.reshape(-1, 3).astype(np.float64), np.arange(3 * len(tris), dtype=np.int32).reshape(-1, 3), 0)
    camera = Camera(centre + np.array([0.35, 0.45, 1.1]) * extent, centre)
    return Scene(camera=camera, materials=[Material("m", base_color=np.array([0.7, 0.7, 0.7]))], meshes=[mesh],
                 environment=Environment(radiance=np.array([1.0, 1.0, 1.0])), max_depth=4)


def trace_times(n: int, builders, size, spp: int, repeat: int, mesh: Path, split_bytes: int | None = None) -> dict:
    """Frame times of each builder's tree; with split_bytes, also of the first builder's tree
    split across buffers of at most that many bytes (the cost of the heap accessors)."""
    import tempfile

    from lift_gl.accel.cache import BUILDER_ENV_VAR, ENV_VAR
    from lift_gl.limits import MAX_SSBO_ENV_VAR
    from lift_gl.renderer import Renderer

    tris, name = make_mesh(n, mesh)
    scene = mesh_scene(tris)
    del tris
    renderers = {}
    with tempfile.TemporaryDirectory() as cache:
        os.environ[ENV_VAR] = cache   # builds from scratch, and no big files left behind
        failed = {}
        for b in builders:
            os.environ[BUILDER_ENV_VAR] = b
            try:
                r = Renderer(scene, size=size, integrator="pt", seed=1)
            except Exception as exc:  # e.g. no pyopencl on this machine: report, go on
                failed[b] = f"{type(exc).__name__}: {exc}"
                continue
            r.render(spp=1)   # warm-up: shader compilation
            renderers[b] = r
        builders = [b for b in builders if b in renderers]
        if split_bytes:
            os.environ[BUILDER_ENV_VAR] = builders[0]
            os.environ[MAX_SSBO_ENV_VAR] = str(split_bytes)
            r = Renderer(scene, size=size, integrator="pt", seed=1)
            r.render(spp=1)
            renderers[f"{builders[0]} split in {r.buffers.plan.chunks}"] = r
            os.environ.pop(MAX_SSBO_ENV_VAR)
        os.environ.pop(BUILDER_ENV_VAR)
    best = {b: float("inf") for b in renderers}
    images = {}
    for _ in range(repeat):
        for b, r in renderers.items():   # interleaved: load changes hit every builder alike
            r.reset()
            t0 = time.perf_counter()
            images[b] = r.render(spp=spp)
            best[b] = min(best[b], (time.perf_counter() - t0) / spp)
    ref = images.get("sah", next(iter(images.values())))
    base = "sah" if "sah" in best else builders[0]
    out = {"triangles": n, "mesh": name, "size": list(size), "spp": spp, "repeat": repeat, "builders": {},
           "failed": failed}
    for b, r in renderers.items():
        out["builders"][b] = {"frame_ms": 1e3 * best[b], "relative_to": base, "relative": best[b] / best[base],
                              "bvh_depth": r.packed.bvh_depth, "nodes": int(r.packed.bvh_nodes.shape[0]),
                              "mean_abs_image_difference_to_sah": float(np.abs(images[b] - ref).mean()),
                              "gpu_buffer_bytes": int(sum(s for _, _, s in r.buffers.memory()))}
        r.release()
    return out


# ---------------------------------------------------------------- a big scene, rendered
def render_big(n: int, size, spp: int, mesh: Path, png: Path | None) -> dict:
    """Render the n-triangle mesh headless and report how its buffers were laid out: on
    llvmpipe (128 MiB a buffer) a scene over about 2 million triangles is split."""
    from lift_gl.image_io import write_image
    from lift_gl.renderer import Renderer

    tris, name = make_mesh(n, mesh)
    scene = mesh_scene(tris)
    del tris
    t0 = time.perf_counter()
    r = Renderer(scene, size=size, integrator="pt", seed=1)
    setup = time.perf_counter() - t0
    image = r.render(spp=spp)
    if png is not None:
        write_image(png, image)
    plan = r.buffers.plan
    out = {"triangles": n, "mesh": name, "size": list(size), "spp": spp, "setup_seconds": setup,
           "render_seconds": r.stats.render_seconds, "bvh_builder": r.packed.bvh_builder,
           "max_buffer_bytes": r.limits.max_ssbo_bytes, "split_chunks": plan.chunks,
           "gpu_buffers": [{"name": nm, "binding": b, "bytes": int(sz)} for nm, b, sz in r.buffers.memory()],
           "finite": bool(np.isfinite(image).all()), "mean": float(image.mean()),
           "explain": r.explain().splitlines()[-len(r.buffers.memory()) - 2:]}
    r.release()
    return out


# ---------------------------------------------------------------- main
def machine() -> dict:
    info = {"platform": platform.platform(), "python": platform.python_version(), "numpy": np.__version__,
            "cpus": os.cpu_count(), "load_average": list(os.getloadavg())}
    try:
        cpu = [ln for ln in Path("/proc/cpuinfo").read_text().splitlines() if ln.startswith("model name")]
        info["cpu"] = cpu[0].split(":", 1)[1].strip() if cpu else platform.processor()
        info["memory_gib"] = round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (OSError, ValueError):
        pass
    try:
        from lift_gl.opencl import describe_device

        info["opencl"] = describe_device()
    except Exception as exc:  # no pyopencl: the LBVH rows will say so
        info["opencl"] = f"unavailable: {exc}"
    return info


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000000,5000000,10000000")
    ap.add_argument("--builders", default=",".join(BUILDERS))
    ap.add_argument("--mesh", type=Path, default=DRAGON)
    ap.add_argument("--trace-triangles", type=int, default=1_000_000)
    ap.add_argument("--trace-size", default="64x64")
    ap.add_argument("--trace-spp", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3, help="trace rounds (best frame of each)")
    ap.add_argument("--no-trace", action="store_true")
    ap.add_argument("--no-builds", action="store_true", help="only the trace comparison")
    ap.add_argument("--split-bytes", type=int, help="trace also the first builder's tree split into buffers this big")
    ap.add_argument("--json", type=Path, help="write the results here")
    ap.add_argument("--render", type=int, metavar="TRIANGLES",
                    help="only render a mesh this big (--trace-size, --trace-spp) and report its buffers")
    ap.add_argument("--png", type=Path, help="with --render: write the image here")
    ap.add_argument("--child", nargs=2, metavar=("TRIANGLES", "BUILDER"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.child:
        print(json.dumps(build_one(int(args.child[0]), args.child[1], args.mesh)))
        return 0

    if args.render:
        w, h = (int(v) for v in args.trace_size.lower().split("x"))
        out = render_big(args.render, (w, h), args.trace_spp, args.mesh, args.png)
        out["machine"] = machine()
        print("\n".join(out["explain"]))
        print(f"{out['triangles']:,} triangles: set-up {out['setup_seconds']:.1f} s, {out['spp']} spp in "
              f"{out['render_seconds']:.1f} s, image finite: {out['finite']}")
        if args.json:
            write_json(args.json, out, indent=2)
        return 0

    builders = [b for b in args.builders.split(",") if b]
    sizes = [int(float(s)) for s in args.sizes.split(",") if s]
    args_text = [Path(a).name if os.path.isabs(a) else a for a in (argv or sys.argv[1:])]   # no machine paths
    result = {"machine": machine(), "command": " ".join([Path(sys.argv[0]).name, *args_text]),
              "builds": [], "trace": None}
    print(f"{'triangles':>11} {'builder':<9} {'seconds':>8} {'cpu s':>8} {'peak MiB':>9} {'nodes':>11} {'depth':>5} "
          f"{'leaf':>5} {'SAH':>7} {'SAH/sah':>8} {'time/sah':>8}")
    for n in (sizes if not args.no_builds else []):
        rows = {}
        for b in builders:
            r = run_child(n, b, args.mesh)
            rows[b] = r
            result["builds"].append(r)
        for b, r in rows.items():
            if "error" in r:
                print(f"{n:>11,} {b:<9} failed: {r['error']}")
                continue
            base = rows.get("sah", {})
            r["sah_cost_relative_to_sah"] = r["sah_cost"] / base["sah_cost"] if "sah_cost" in base else None
            r["time_relative_to_sah"] = r["seconds"] / base["seconds"] if "seconds" in base else None
            peak = r["peak_build_bytes"] / 2**20 if r["peak_build_bytes"] is not None else float("nan")
            rel = lambda v: f"{v:8.3f}" if v is not None else f"{'-':>8}"  # noqa: E731
            print(f"{n:>11,} {b:<9} {r['seconds']:>8.2f} {r['cpu_seconds']:>8.2f} {peak:>9,.0f} {r['nodes']:>11,} {r['depth']:>5} "
                  f"{r['mean_leaf_size']:>5.2f} {r['sah_cost']:>7.1f} {rel(r['sah_cost_relative_to_sah'])} "
                  f"{rel(r['time_relative_to_sah'])}", flush=True)
        if args.json:   # keep what is done if a later size fails
            write_json(args.json, result, indent=2)

    if not args.no_trace:
        w, h = (int(v) for v in args.trace_size.lower().split("x"))
        tr = trace_times(args.trace_triangles, builders, (w, h), args.trace_spp, args.repeat, args.mesh,
                         args.split_bytes)
        result["trace"] = tr
        print(f"\ntrace: {tr['triangles']:,} triangles ({tr['mesh']}), pt {w}x{h}, {tr['spp']} spp, best of {tr['repeat']}")
        for b, r in tr["builders"].items():
            print(f"  {b:<18} {r['frame_ms']:>9.1f} ms/frame  x{r['relative']:.3f} of {r['relative_to']}   depth {r['bvh_depth']}  "
                  f"GPU buffers {r['gpu_buffer_bytes'] / 2**20:,.1f} MiB")
    if args.json:
        write_json(args.json, result, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
