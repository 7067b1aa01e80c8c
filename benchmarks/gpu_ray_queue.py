"""How much of a GPU's bounce-ray time is lanes waiting for the busiest lane of their warp:
benchmarks/gpu.py's bounce rays (cosine-distributed from the camera rays' hits, the closest hit
through lift/bvh.glsl's 4-wide traversal), cast two ways over the same primary hits:

- `plain`: one ray an invocation (gpu.py's ray-kind shader), so a warp runs until its
  busiest ray is done;
- `queue`: each invocation takes its pixels from a queue (one atomicAdd a ray) *inside* the
  traversal loop: a lane whose ray is done starts the next at once (Aila and Laine 2009's
  persistent while-while with dynamic fetch), so lanes do not wait for each other.

The answers are the same ray for ray (checked each dispatch). The ratio bounds what a path
tracer's megakernel could gain by not waiting for its warp's busiest traversal (docs/gpu.md,
"Measuring"; the dining room's rays run at a SIMD efficiency of 0.29). The megakernel cannot
take it as is: its next ray needs the shading of the last hit, which this loop does not do.

    python benchmarks/gpu_ray_queue.py SCENE... [--size 1920x1080] [--reps 9] [--json FILE]

Scenes with spheres, motion blur or instances are skipped (the queued loop traverses the
4-wide triangle tree only). On llvmpipe, whose work groups run a few at a time, the first
invocations drain the queue and may pass its limit of 65535 iterations a loop, which ends an
invocation mid-ray: a few answers then differ there (counted); GPUs have no such limit.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import gpu as gpu_bench  # noqa: E402
from lift_gl.report.records import write_json  # noqa: E402

QUEUE_BINDING = 11

# Inserted before the ray-kind shader's main(): the bounce kind with the queue.
QUEUED_BOUNCE = """
layout(std430, binding = 11) buffer RayQueue { uint ray_next; };

// The next pixel with a primary hit, from the queue (n_pix when there is none left).
uint lift_next_bounce_pixel(uint n_pix) {
    uint idx = atomicAdd(ray_next, 1u);
    while (idx < n_pix && floatBitsToUint(primary_hits[2u * idx].w) == NO_HIT) idx = atomicAdd(ray_next, 1u);
    return idx;
}

// gpu.py's bounce rays, each lane taking its next pixel inside the traversal loop as soon as
// its ray is done: lift_bvh_closest's while-while loop (its loops: lift/bvh.glsl's
// LIFT_BVH4_DESCEND and LIFT_BVH4_CLOSEST_LEAF) with the ray set up in it.
void queued_bounce_rays() {
    uint n_pix = uint(u_resolution.x) * uint(u_resolution.y);
    Ray ray;
    vec3 inv;
    uvec3 near;
    LiftRayShear shear;
    float t = 0.0;
    bool found = false;
    uint prim;        // the hit's row and barycentrics (LIFT_BVH4_CLOSEST_LEAF): not needed here
    vec2 bary_out;
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint cur = 0u;
    uint idx = n_pix;
    bool busy = false;
    while (true) {
        if (!busy) {
            if (idx < n_pix) primary_hits[2u * idx + 1u].w = found ? 1.0 : 0.0;
            idx = lift_next_bounce_pixel(n_pix);
            if (idx >= n_pix) break;
            uint s = pcg(idx ^ pcg(u_seed));   // main()'s random numbers for this pixel
            vec3 n = primary_hits[2u * idx + 1u].xyz;
            ray = Ray(primary_hits[2u * idx].xyz + u_eps * n, vec3(0.0), 0.0, 1e30);
            ray.dir = cosine_dir(n, s);
            inv = lift_bvh_inv_dir(ray.dir);
            near = lift_bvh4_near_rows(inv);
            shear = lift_ray_shear(ray.dir);
            t = ray.tmax;
            found = false;
            sp = 0;
            cur = 0u;
            busy = true;
        }
        bool at_leaf = true;
        LIFT_BVH4_DESCEND(at_leaf)
        if (at_leaf) LIFT_BVH4_CLOSEST_LEAF
        if (sp == 0) busy = false;
        else LIFT_BVH4_POP(cur)
    }
}

void main() {
    if (u_kind == 2) { queued_bounce_rays(); return; }
    ray_kind_main();
}
"""


def queued_source() -> str:
    """gpu.py's ray-kind shader with its main() renamed and the queued bounce kind added."""
    text = gpu_bench.RAY_SHADER
    if text.count("void main() {") != 1:
        raise RuntimeError("gpu.py's RAY_SHADER changed: one main() expected")
    return text.replace("void main() {", "void ray_kind_main() {") + QUEUED_BOUNCE


def measure(path: str, size, reps: int, backend: str = "auto") -> dict | None:
    from lift_gl.gl.context import is_software
    from lift_gl.passes.camera import camera_uniforms
    from lift_gl.passes.common import set_uniforms
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene
    from lift_gl.shaders import assemble, compile_compute

    scene = load_scene(path)
    r = Renderer(scene, size=size, integrator="pt", backend=backend)
    try:
        d = r.defines
        if d.get("LIFT_BVH_WIDTH") != 4 or "HAS_SPHERES" in d or "HAS_MOTION" in d or "HAS_INSTANCES" in d:
            print(f"(skipped {path}: needs the 4-wide tree of triangles only)")
            return None
        ctx = r.ctx
        defines = {k: v for k, v in d.items() if k in gpu_bench.RAY_SHADER_DEFINES}
        plain, local = gpu_bench.ray_program(ctx, defines)
        # the queued program in the same shape and stack placement as ray_program's
        queued_defines = dict(defines, LIFT_RAY_LOCAL_X=local[0], LIFT_RAY_LOCAL_Y=local[1])
        if r.choices["bvh_stack"] == "shared":
            queued_defines["LIFT_BVH_SHARED_STACK"] = local[0] * local[1]
        queued = compile_compute(ctx, assemble(queued_source(), queued_defines, main_name="<queued bounce rays>"))
        w, h = size
        hits = ctx.buffer(reserve=32 * w * h)
        hits.bind_to_storage_buffer(10)
        queue = ctx.buffer(reserve=4)
        queue.bind_to_storage_buffer(QUEUE_BINDING)
        gpu_bench.bind_as_storage(r)
        extent = float(np.max(r.packed.bounds[1] - r.packed.bounds[0])) or 1.0
        uniforms = dict(r.scene_uniforms, **camera_uniforms(r.camera, size), u_eps=1e-4 * extent, u_seed=0)
        cpu = is_software(ctx)
        query = ctx.query(time=True)
        clock, warm = gpu_bench.warm_gpu(ctx, plain, size, local, dict(uniforms, u_kind=0))
        set_uniforms(plain, dict(uniforms, u_kind=0))
        gpu_bench.timed_dispatch(ctx, plain, query, size, cpu, local=local)   # the primary hits
        rows = np.frombuffer(hits.read(), np.float32).reshape(-1, 2, 4)
        rays = int((rows[:, 0, 3].view(np.uint32) != 0xFFFFFFFF).sum())
        times = {"plain": [], "queue": []}
        mismatches = 0
        for rep in range(reps + 1):
            answers = {}
            for way in (("plain", "queue") if rep % 2 == 0 else ("queue", "plain")):
                program = plain if way == "plain" else queued
                set_uniforms(program, dict(uniforms, u_kind=2, u_seed=rep))
                if way == "queue":
                    ctx.memory_barrier()
                    queue.write(b"\0\0\0\0")
                ms = gpu_bench.timed_dispatch(ctx, program, query, size, cpu, cpu_clock=time.process_time_ns,
                                              local=local)
                ctx.memory_barrier()
                answers[way] = np.frombuffer(hits.read(), np.float32).reshape(-1, 2, 4)[:, 1, 3].copy()
                if rep:
                    times[way].append(ms)
            mismatches += int((answers["plain"] != answers["queue"]).sum())
        out = {"scene": path, "size": list(size), "gl": ctx.info.get("GL_RENDERER", ""), "rays": rays,
               "sm_mhz": clock.sm_mhz(), "warm_up": warm, "mismatched_answers": mismatches}
        for way, t in times.items():
            out[way] = {"ms": t, "median_ms": float(np.median(t)),
                        "mrays_per_s": rays / max(float(np.median(t)), 1e-9) / 1e3}
        out["queue_speedup"] = out["plain"]["median_ms"] / out["queue"]["median_ms"]
        for b in (hits, queue, plain, queued):
            b.release()
        return out
    finally:
        r.release()


def main(argv=None) -> int:
    from lift_gl.cli import _size

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--reps", type=int, default=9)
    ap.add_argument("--backend", default="auto")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    size = _size(args.size)
    results = []
    print("| scene | bounce rays | plain ms (Mrays/s) | queued ms (Mrays/s) | queued speed-up | answers that differ |")
    print("|---|---|---|---|---|---|")
    for path in args.scenes:
        if not Path(path).exists():
            print(f"(skipped: {path} does not exist)")
            continue
        r = measure(path, size, args.reps, args.backend)
        if r is None:
            continue
        results.append(r)
        print(f"| {gpu_bench.scene_name(path)} | {r['rays']:,} | {r['plain']['median_ms']:.3f} ({r['plain']['mrays_per_s']:,.0f}) "
              f"| {r['queue']['median_ms']:.3f} ({r['queue']['mrays_per_s']:,.0f}) | {r['queue_speedup']:.2f}x "
              f"| {r['mismatched_answers']} |", flush=True)
    if args.json:
        write_json(args.json, results, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
