"""GPU frame times per pass and ray throughput by ray kind, for the GPU machine.

    python benchmarks/gpu.py measure SCENE... [--sizes 1280x720,1920x1080] [--integrators pt,bdpt,pt:rr_depth=1]
                                     [--max-depth 32] [--frames 16] [--out FILE.json] [--label NAME]
                                     [--option KEY=A,B | --bvh-width 2,4 | ... [--split-rounds 2]]
    python benchmarks/gpu.py interactive SCENE... [--sizes 1920x1080] [--integrators pt,pt:rr_depth=1]
                                         [--denoisers atrous,glsl] [--frames 50] [--out FILE.json] [--md FILE.md]
    python benchmarks/gpu.py table FILE.json... [--md FILE.md]

`measure`, for each scene, integrator and size: lift-gl bench's numbers
(lift_gl/report/bench.py: pipelined frame time, each pass timed by a GL timer query and by
the CPU clock around ctx.finish(), rays per path counted by the LIFT_COUNT_RAYS variant), at
1 sample per pixel and path length --max-depth (the Lift paper's setting: 1 spp, 32).
Then, per scene and size, Mrays/s by ray kind, measured by a ray-casting shader of this file
that includes only lift/bvh.glsl (the traversal every plugin uses), one dispatch per kind,
each timed by a GL timer query:
  primary  - one closest-hit ray per pixel centre, camera to scene (coherent);
  shadow   - one any-hit ray from each primary hit to a random point on a random emissive
             triangle (trace_occluded), or, in a scene without one, along a cosine-distributed
             direction out to infinity (environment visibility);
  bounce   - one closest-hit ray from each primary hit in a cosine-distributed direction
             (incoherent: neighbouring pixels' rays diverge).
On a CPU rasterizer (llvmpipe) timer queries miss compute work, so there the CPU clock
between two ctx.finish() calls times each dispatch instead.

`lift_gl` is imported from $LIFT_GL_TREE when set (else this checkout), so one command can
measure two versions of the renderer, alternately, on the same machine:
    LIFT_GL_TREE=../base python benchmarks/gpu.py measure ... --label base --out base.json
`table` prints the results of one or more such files side by side (ratios to the first).
`interactive` times the viewer's frame (lift_gl/report/bench_interactive.py: temporal
reprojection, the denoiser after every frame, a slowly turning camera), whole and per pass.
`--option KEY=A,B` measures every case under each value of one of the renderer's options
(lift_gl/options.py, e.g. `--option gbuffer=raster,traced`), interleaved, and prints them side
by side; `--bvh-width 2,4`, `--bvh-stack-entries children,groups`, `--bvh-stack shared,local`
and `--carry-paths off,on` are the same for those options.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.environ.get("LIFT_GL_TREE") or str(Path(__file__).resolve().parent.parent))

# Lift (Soares et al. 2020), RTX 2070 with hardware ray tracing, 1920x1080, 1 spp, path
# length 32 (the paper's figures): frame ms by integrator and scene.
LIFT_PAPER_MS = {
    "pt": {"cornell-box": 4.8, "dining-room": 6.3, "classroom": 20.2},
    "bdpt": {"cornell-box": 20.8, "dining-room": 18.6, "classroom": 52.4},
}
LIFT_PAPER_SCENES = {"cornell-box": "Teapot Cornell Box", "dining-room": "Breakfast Room",
                     "classroom": "Japanese Classroom"}

RAY_KINDS = ("primary", "shadow", "bounce")
# The renderer's defines the ray-kind shader takes: spheres, and the BVH's layout and stack (accel/wide.py).
RAY_SHADER_DEFINES = ("HAS_SPHERES", "LIFT_BVH_WIDTH", "LIFT_BVH_QUANTIZED", "LIFT_BVH_STACK_SIZE",
                      "LIFT_BVH_GROUP_STACK", "LIFT_BVH_SHARED_DEPTH")

# Compiled by ray_program, in the trace pass's work-group shape and BVH stack placement.
RAY_SHADER = """
layout(local_size_x = LIFT_RAY_LOCAL_X, local_size_y = LIFT_RAY_LOCAL_Y) in;
#include "lift/bvh.glsl"

uniform vec3 u_cam_pos;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform vec3 u_cam_forward;
uniform float u_tan_half_fov;
uniform vec2 u_resolution;
uniform int u_kind;        // 0 primary, 1 shadow, 2 bounce
uniform uint u_seed;
uniform float u_eps;       // offset of secondary ray origins, scaled to the scene

// Two vec4 per pixel: the primary hit point (xyz) and prim (w bits, NO_HIT for a miss); the
// geometric normal (xyz) and the last secondary ray's outcome (w: 1 hit or blocked, 0 not).
// No atomics: the host counts rays and hits from this buffer (one atomic counter per ray
// serialises incoherent rays on a GPU and would be timed with them).
layout(std430, binding = 10) buffer PrimaryHits { vec4 primary_hits[]; };

uint pcg(uint v) {
    uint s = v * 747796405u + 2891336453u;
    uint w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}
float rnd(inout uint s) { s = pcg(s); return float(s >> 8) * (1.0 / 16777216.0); }

vec3 cosine_dir(vec3 n, inout uint s) {
    float u1 = rnd(s), u2 = rnd(s);
    float r = sqrt(u1), phi = 6.28318530718 * u2;
    vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0, 1, 0)) : cross(n, vec3(1, 0, 0)));
    vec3 b = cross(n, t);
    return normalize(r * cos(phi) * t + r * sin(phi) * b + sqrt(max(0.0, 1.0 - u1)) * n);
}

vec3 geometric_normal(uint prim, vec3 p) {
    if (prim >= u_num_triangles) return normalize(p - spheres[2u * (prim - u_num_triangles)].xyz);
    vec3 p0 = tri_pos[3u * prim].xyz;
    return normalize(cross(tri_pos[3u * prim + 1u].xyz - p0, tri_pos[3u * prim + 2u].xyz - p0));
}

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= uint(u_resolution.x) || px.y >= uint(u_resolution.y)) return;
    uint idx = px.y * uint(u_resolution.x) + px.x;
    uint s = pcg(idx ^ pcg(u_seed));
    if (u_kind == 0) {
        vec2 ndc = (vec2(px) + 0.5) / u_resolution * 2.0 - 1.0;
        float aspect = u_resolution.x / u_resolution.y;
        vec3 d = normalize(u_cam_forward + ndc.x * u_tan_half_fov * aspect * u_cam_right
                           + ndc.y * u_tan_half_fov * u_cam_up);
        Hit hit;
        bool found = trace_closest(Ray(u_cam_pos, d, 0.0, 1e30), hit);
        vec3 p = u_cam_pos + hit.t * d;
        vec3 n = found ? geometric_normal(hit.prim, p) : vec3(0.0);
        if (dot(n, d) > 0.0) n = -n;
        primary_hits[2u * idx] = vec4(p, uintBitsToFloat(found ? hit.prim : NO_HIT));
        primary_hits[2u * idx + 1u] = vec4(n, 0.0);
        return;
    }
    vec4 hp = primary_hits[2u * idx];
    if (floatBitsToUint(hp.w) == NO_HIT) return;
    vec3 n = primary_hits[2u * idx + 1u].xyz;
    vec3 o = hp.xyz + u_eps * n;
    if (u_kind == 1) {
        Ray r;
        if (u_num_lights > 0u) {
            uint light = floatBitsToUint(lights[min(uint(rnd(s) * float(u_num_lights)), u_num_lights - 1u)].x);
            vec3 q;
            if (light < u_num_triangles) {
                float a = sqrt(rnd(s)), b = rnd(s);
                vec3 p0 = tri_pos[3u * light].xyz, p1 = tri_pos[3u * light + 1u].xyz, p2 = tri_pos[3u * light + 2u].xyz;
                q = (1.0 - a) * p0 + a * (1.0 - b) * p1 + a * b * p2;
            } else {
                q = spheres[2u * (light - u_num_triangles)].xyz;
            }
            vec3 to = q - o;
            float dist = length(to);
            r = Ray(o, to / max(dist, 1e-20), 0.0, dist * (1.0 - 1e-4));
        } else {
            r = Ray(o, cosine_dir(n, s), 0.0, 1e30);
        }
        primary_hits[2u * idx + 1u].w = trace_occluded(r) ? 1.0 : 0.0;
    } else {
        Hit hit;
        bool found = trace_closest(Ray(o, cosine_dir(n, s), 0.0, 1e30), hit);
        primary_hits[2u * idx + 1u].w = found ? 1.0 : 0.0;
    }
}
"""


def bind_as_storage(renderer) -> None:
    """The scene's arrays as storage buffers, as the ray-kind shader declares them (it is
    compiled without the defines that move small arrays into uniform blocks on CPU
    rasterizers, so every version of bvh.glsl reads the same buffers)."""
    from lift_gl.passes.common import SCENE_BINDINGS

    renderer.buffers.bind()
    for name, binding in SCENE_BINDINGS.items():
        if name in renderer.buffers.buffers:  # `instances` exists only in instanced scenes
            renderer.buffers.buffers[name].bind_to_storage_buffer(binding)


def ray_program(ctx, defines: dict, include_dirs=(), label: str = "gpu.py ray kinds", stack: str | None = None):
    """The ray-kind shader, compiled as lift-gl's plain trace programs run on this GL: their
    work-group shape and BVH stack placement (lift_gl/options.py: on GPUs 8x4 with the stack in
    shared memory; `stack` shared or local instead). Returns (program, local size)."""
    from lift_gl.shaders import assemble, compile_compute
    try:
        from lift_gl.options import Device, Options, resolve, work_group
    except ImportError:   # a lift_gl of before the options ($LIFT_GL_TREE)
        from lift_gl.passes.trace import trace_layout
        local, shared = trace_layout(ctx)
    else:
        device = Device.of(ctx)
        stack = stack or resolve(Options(), device).gbuffer_stack
        local, shared = work_group(stack, device), stack == "shared"
    defines = dict(defines, LIFT_RAY_LOCAL_X=local[0], LIFT_RAY_LOCAL_Y=local[1])
    if shared:
        defines["LIFT_BVH_SHARED_STACK"] = local[0] * local[1]
    source = assemble(RAY_SHADER, defines, include_dirs=list(include_dirs), main_name=f"<{label}>")
    return compile_compute(ctx, source), local


def dispatch_groups(size, local) -> tuple[int, int, int]:
    (w, h), (lx, ly) = size, local
    return (w + lx - 1) // lx, (h + ly - 1) // ly, 1


def timed_dispatch(ctx, program, query, size, cpu: bool, cpu_clock=time.perf_counter_ns, local=(8, 8)) -> float:
    """Milliseconds of one dispatch of `program` (work groups of `local`) over `size` pixels: its
    GL timer query on a GPU; on a CPU rasterizer `cpu_clock` around it (the wall clock, or
    time.process_time_ns: the CPU time of all of this process's threads, whatever share of the
    cores the run got)."""
    ctx.finish()
    start = cpu_clock()
    with query:
        program.run(*dispatch_groups(size, local))
    ctx.finish()
    return ((cpu_clock() - start) if cpu else query.elapsed) / 1e6


def _gpu_clock():
    """lift_gl/report/gpu_clock.py's ClockReader and warm_up, this checkout's copy (a
    $LIFT_GL_TREE may be older than it)."""
    import importlib.util

    path = Path(__file__).resolve().parent.parent / "lift_gl" / "report" / "gpu_clock.py"
    spec = importlib.util.spec_from_file_location("_lift_gl_gpu_clock", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.ClockReader, module.warm_up


def warm_gpu(ctx, program, size, local, uniforms: dict) -> tuple:
    """Dispatch `program` (20 at a time) until an idle GPU's SM clock has risen
    (lift_gl/report/gpu_clock.py); the clock reader and what the warm-up did."""
    from lift_gl.passes.common import set_uniforms
    ClockReader, warm_up = _gpu_clock()

    clock = ClockReader(ctx.info.get("GL_RENDERER", ""))
    set_uniforms(program, uniforms)

    def step():
        for _ in range(20):
            program.run(*dispatch_groups(size, local))
        ctx.finish()
    return clock, warm_up(step, clock)


def _gbuffer_stack(renderer):
    """Where the renderer's plain programs keep their stack (its options' choice), or None."""
    choices = getattr(renderer, "choices", None)
    return getattr(choices, "gbuffer_stack", None)


def ray_throughput(renderer, size, repeat: int = 8) -> dict:
    """Mrays/s of each ray kind (see the module docstring) for the renderer's scene and
    camera at `size`: the best of `repeat` dispatches (after one warm-up)."""
    from lift_gl.gl.context import is_software
    from lift_gl.passes.camera import camera_uniforms
    from lift_gl.passes.common import set_uniforms

    ctx = renderer.ctx
    defines = {k: v for k, v in renderer.defines.items() if k in RAY_SHADER_DEFINES}
    program, local = ray_program(ctx, defines, stack=_gbuffer_stack(renderer))
    w, h = size
    hits = ctx.buffer(reserve=32 * w * h)
    hits.bind_to_storage_buffer(10)
    bind_as_storage(renderer)
    p = renderer.packed
    extent = float(np.max(p.bounds[1] - p.bounds[0])) or 1.0
    uniforms = dict(renderer.scene_uniforms, **camera_uniforms(renderer.camera, size),
                    u_eps=1e-4 * extent, u_seed=0)
    cpu = is_software(ctx)
    query = ctx.query(time=True)
    clock, warm = warm_gpu(ctx, program, size, local, dict(uniforms, u_kind=0, u_seed=0))
    out = {}
    for kind_index, kind in enumerate(RAY_KINDS):
        best = None
        for rep in range(repeat + 1):
            set_uniforms(program, dict(uniforms, u_kind=kind_index, u_seed=rep))
            ms = timed_dispatch(ctx, program, query, size, cpu, local=local)
            if rep == 0:
                continue  # warm-up
            if best is None or ms < best:
                best = ms
        # The shadow and bounce kinds start from the primary hits of the last primary dispatch.
        rows = np.frombuffer(hits.read(), np.float32).reshape(-1, 2, 4)
        hit = rows[:, 0, 3].view(np.uint32) != 0xFFFFFFFF
        rays = w * h if kind == "primary" else int(hit.sum())
        hits_of_kind = int(hit.sum()) if kind == "primary" else int((rows[hit, 1, 3] > 0.5).sum())
        out[kind] = {"rays": rays, "hits": hits_of_kind, "ms": best,
                     "mrays_per_s": rays / max(best * 1e6, 1) * 1e3, "sm_mhz": clock.sm_mhz()}
    out["primary"]["warm_up"] = warm
    for b in (hits, program):
        b.release()
    return out


def ray_throughput_interleaved(renderers, size, repeat: int = 8) -> list[dict]:
    """ray_throughput for several renderers (one scene under several BVHs), dispatch by
    dispatch in turn (A B, B A, ...), so that a busy machine slows each alike: per renderer and
    kind the median and best dispatch time. On a CPU rasterizer a dispatch is timed by the
    process's CPU time (llvmpipe's threads included): on shared cores its wall time is bimodal,
    as other jobs take the rasterizer's threads, and Mrays/s then means per CPU-second."""
    from lift_gl.gl.context import is_software
    from lift_gl.passes.camera import camera_uniforms
    from lift_gl.passes.common import set_uniforms

    w, h = size
    setups = []
    for r in renderers:
        defines = {k: v for k, v in r.defines.items() if k in RAY_SHADER_DEFINES}
        program, local = ray_program(r.ctx, defines, stack=_gbuffer_stack(r))
        extent = float(np.max(r.packed.bounds[1] - r.packed.bounds[0])) or 1.0
        uniforms = dict(r.scene_uniforms, **camera_uniforms(r.camera, size), u_eps=1e-4 * extent)
        setups.append((r, program, r.ctx.buffer(reserve=32 * w * h), uniforms))
    ctx = renderers[0].ctx
    cpu = is_software(ctx)
    query = ctx.query(time=True)
    r0, program0, hits0, uniforms0 = setups[0]
    bind_as_storage(r0)
    hits0.bind_to_storage_buffer(10)
    clock, warm = warm_gpu(ctx, program0, size, local, dict(uniforms0, u_kind=0, u_seed=0))
    out = [{} for _ in renderers]
    for kind_index, kind in enumerate(RAY_KINDS):
        times = [[] for _ in renderers]
        for rep in range(repeat + 1):
            turn = range(len(setups)) if rep % 2 == 0 else range(len(setups) - 1, -1, -1)
            for i in turn:
                r, program, hits, uniforms = setups[i]
                bind_as_storage(r)
                hits.bind_to_storage_buffer(10)
                # every renderer's rep-th dispatch of a kind casts the same rays (same seed)
                set_uniforms(program, dict(uniforms, u_kind=kind_index, u_seed=rep))
                # on a CPU rasterizer: the CPU time of all of this process's threads (the
                # rasterizer's work however the shared cores were scheduled)
                ms = timed_dispatch(ctx, program, query, size, cpu, cpu_clock=time.process_time_ns, local=local)
                if rep:  # rep 0 warms up
                    times[i].append(ms)
        for i, (r, program, hits, uniforms) in enumerate(setups):
            rows = np.frombuffer(hits.read(), np.float32).reshape(-1, 2, 4)
            hit = rows[:, 0, 3].view(np.uint32) != 0xFFFFFFFF
            rays = w * h if kind == "primary" else int(hit.sum())
            med, best = float(np.median(times[i])), float(np.min(times[i]))
            ms = med
            out[i][kind] = {"rays": rays, "hits": int(hit.sum()) if kind == "primary" else int((rows[hit, 1, 3] > 0.5).sum()),
                            "ms": ms, "median_ms": med, "best_ms": best, "all_ms": times[i],
                            "mrays_per_s": rays / max(ms, 1e-9) / 1e3, "sm_mhz": clock.sm_mhz()}
    for o in out:
        o["primary"]["warm_up"] = warm
    for _, program, hits, _ in setups:
        program.release()
        hits.release()
    return out


def ab_table(record: dict) -> str:
    """Markdown of an `ab` record: speed-up of each version over the first, by ray kind, and
    the first version's Mrays/s."""
    labels = [v[0] for v in record["variants"]]
    lines = [f"Machine: {record['gl']}. {record['reps']} interleaved dispatches a version; speed-up = median over "
             f"the rounds of {labels[0]}'s time / the version's in the same round (a GPU that changes its clocks "
             f"mid-run changes both alike); Mrays/s from the median time.", "",
             "| scene | size | triangles | " + " | ".join(f"{labels[0]} {k} Mrays/s" for k in RAY_KINDS) + " | "
             + " | ".join(f"{k} {lab}" for k in RAY_KINDS for lab in labels[1:]) + " |",
             "|" + "---|" * (3 + len(RAY_KINDS) * len(labels))]
    for c in record["results"]:
        w, h = c["size"]
        hits = c.get("primary_hits", {}).get(labels[0])  # secondary rays start from the primary hits
        rays = {"primary": w * h, "shadow": hits, "bounce": hits}
        cells = [c["scene_name"], f"{w}x{h}", f"{c['triangles']:,}"]
        cells += ["–" if rays[k] is None else _mrays(rays[k] / c["kinds"][k]["median_ms"][0] / 1e3) for k in RAY_KINDS]
        cells += [f"{paired_speedup(c['kinds'][k]['ms'], j):.3f}" for k in RAY_KINDS for j in range(1, len(labels))]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def paired_speedup(times: list[list[float]], j: int) -> float:
    """Median over the rounds of version 0's time / version j's time in the same round."""
    return float(np.median(np.asarray(times[0]) / np.asarray(times[j])))


def ab(args) -> int:
    """Versions of lift/bvh.glsl against each other in one process, dispatch by dispatch
    (A, B, A, B, ...), on the same scene buffers: on a busy machine (llvmpipe on shared
    cores) the load then hits every version alike, and the ratio of the medians holds even
    where single timings scatter by 2x. --variant LABEL=TREE:LAYOUT[:NAME,...] takes TREE/shaders/
    lift/bvh.glsl with the BVH as LAYOUT: binary (the builder's nodes, what lift-gl's bvh.glsl
    reads), records (benchmarks/bvh_records.py, what the gpu-speed experiments read), or 4 / 4q
    (that binary tree collapsed to the 4-wide layout, float or 8-bit child boxes: accel/wide.py,
    compiled with LIFT_BVH_WIDTH 4), and the NAMEs #defined (a define of that TREE's bvh.glsl).
    Every version runs in the trace pass's work-group shape and stack placement (ray_program).
    Every version must find the same primary hits and block the same shadow rays."""
    from lift_gl.cli import _size
    from lift_gl.gl.context import create_context, describe, is_software
    from lift_gl.passes.camera import camera_uniforms
    from lift_gl.passes.common import set_uniforms
    from lift_gl.renderer import Renderer
    from lift_gl.scene.loader import load_scene

    from bvh_records import gpu_nodes  # benchmarks/: the records experiment
    from lift_gl.accel.wide import wide_layout

    variants = []
    for text in args.variant:
        label, rest = text.split("=", 1)
        tree, layout, *names = rest.split(":")
        if layout not in ("binary", "records", "4", "4q") or len(names) > 1:
            raise SystemExit(f"--variant {text}: expected LABEL=TREE:binary|records|4|4q[:NAME,...]")
        extra = {n.strip(): True for n in (names[0].split(",") if names else []) if n.strip()}
        variants.append((label, Path(tree), layout, extra))
    ctx = create_context(args.backend)
    cpu = is_software(ctx)
    query = ctx.query(time=True)
    from lift_gl.options import Options
    print(f"{describe(ctx)}; {len(variants)} versions, {args.reps} interleaved dispatches each per kind", flush=True)
    results = []
    record = {"gl": describe(ctx), "variants": [[v[0], v[2], sorted(v[3])] for v in variants], "reps": args.reps,
              "results": results}
    for path in args.scenes:
        scene = load_scene(path)
        for size in [_size(s.strip()) for s in args.sizes.split(",")]:
            # the versions compared here read the binary tree (or records made from it): no
            # 4-wide collapse (accel/wide.py) for this renderer's scene
            r = Renderer(scene, size=size, integrator="pt", backend=args.backend, options=Options(bvh_width="2"))
            defines = {k: v for k, v in r.defines.items() if k in ("HAS_SPHERES",)}
            progs, nodes = [], []
            for label, tree, layout, extra in variants:
                layout_defines = {}
                if layout == "binary":
                    data = r.packed.bvh_nodes
                elif layout == "records":
                    data = gpu_nodes(r.packed.bvh_nodes)
                else:  # the 4-wide layouts of the same tree (the triangles keep their order)
                    wide = wide_layout(r.packed.bvh_nodes, layout)
                    if wide is None:
                        raise SystemExit(f"{path}: its tree has no {layout} layout (accel/wide.py)")
                    data = wide.rows
                    layout_defines = {"LIFT_BVH_WIDTH": 4, **({"LIFT_BVH_QUANTIZED": True} if wide.quantized else {})}
                prog, local = ray_program(ctx, dict(defines, **layout_defines, **extra), include_dirs=[tree / "shaders"],
                                          label=f"gpu.py ray kinds, {label}")
                progs.append(prog)
                nodes.append(ctx.buffer(np.ascontiguousarray(data).tobytes()))

            w, h = size
            hits = ctx.buffer(reserve=32 * w * h)
            bind_as_storage(r)
            hits.bind_to_storage_buffer(10)
            extent = float(np.max(r.packed.bounds[1] - r.packed.bounds[0])) or 1.0
            uniforms = dict(r.scene_uniforms, **camera_uniforms(r.camera, size), u_eps=1e-4 * extent)
            case = {"scene_name": scene_name(path), "size": list(size), "triangles": r.packed.num_triangles,
                    "local_size": list(local), "kinds": {}}
            for kind_index, kind in enumerate(RAY_KINDS):
                times = [[] for _ in variants]
                for rep in range(args.reps + 1):
                    for i, prog in enumerate(progs if rep % 2 == 0 else progs[::-1]):
                        i = i if rep % 2 == 0 else len(progs) - 1 - i
                        nodes[i].bind_to_storage_buffer(0)
                        set_uniforms(prog, dict(uniforms, u_kind=kind_index, u_seed=rep))
                        # on a CPU rasterizer: the process's CPU time (ray_throughput_interleaved says why)
                        ms = timed_dispatch(ctx, prog, query, size, cpu, cpu_clock=time.process_time_ns, local=local)
                        if rep:
                            times[i].append(ms)
                if kind == "primary":
                    # Every version must find the same primary hits (up to a few rays through
                    # edges): one that misread the BVH would be fast and wrong.
                    case["primary_hits"] = {}
                    for (label, *_), prog, buf in zip(variants, progs, nodes):
                        buf.bind_to_storage_buffer(0)
                        set_uniforms(prog, dict(uniforms, u_kind=0, u_seed=0))
                        prog.run(*dispatch_groups(size, local))
                        rows = np.frombuffer(hits.read(), np.float32).reshape(-1, 2, 4)
                        case["primary_hits"][label] = int((rows[:, 0, 3].view(np.uint32) != 0xFFFFFFFF).sum())
                if kind == "shadow":
                    # and block the same shadow rays, cast from the same primary hits (those of
                    # the primary check's last version: the shadow kind writes only the outcome)
                    case["shadow_blocked"] = {}
                    for (label, *_), prog, buf in zip(variants, progs, nodes):
                        buf.bind_to_storage_buffer(0)
                        set_uniforms(prog, dict(uniforms, u_kind=kind_index, u_seed=0))
                        prog.run(*dispatch_groups(size, local))
                        rows = np.frombuffer(hits.read(), np.float32).reshape(-1, 2, 4)
                        hit = rows[:, 0, 3].view(np.uint32) != 0xFFFFFFFF
                        case["shadow_blocked"][label] = int((rows[hit, 1, 3] > 0.5).sum())
                med = [float(np.median(t)) for t in times]
                case["kinds"][kind] = {"ms": times, "median_ms": med,
                                       "speedup_vs_first": [med[0] / m for m in med]}
            results.append(case)
            print(f"{case['scene_name']} {w}x{h}: primary hits {case['primary_hits']}; "
                  f"shadow rays blocked {case.get('shadow_blocked')}", flush=True)
            print(f"{case['scene_name']} {w}x{h}: " + "; ".join(
                f"{k} " + ", ".join(f"{v[0]} {m:.3f} ms" for v, m in zip(variants, c["median_ms"]))
                for k, c in case["kinds"].items()), flush=True)
            for b in (*progs, *nodes, hits):
                b.release()
            r.release()
            if args.out:
                args.out.write_text(json.dumps(record, indent=1))
    show_table(ab_table(record), args.md)
    return 0


def show_table(text: str, md: Path | None) -> None:
    """Print a markdown table, and write it to `md` too when given (--md)."""
    print(text)
    if md:
        md.write_text(text + "\n")


def portable(path) -> str:
    """A scene path as the results keep it: from scenes_lift/ or scenes/ on, never a path of
    the machine that ran the benchmark."""
    text = str(path)
    for marker, prefix in (("scenes_lift/", "../shared/scenes_lift/"), ("scenes/", "scenes/")):
        if marker in text:
            return prefix + text.rsplit(marker, 1)[1]
    return Path(text).name


def scene_name(path: str) -> str:
    p = Path(path)
    return p.parent.name if p.stem == "scene" else p.stem


def measure(args) -> int:
    import lift_gl
    from lift_gl.cli import _size
    from lift_gl.gl.context import create_context, describe
    from lift_gl.renderer import Renderer
    from lift_gl.report.bench import bench_case
    from lift_gl.report.configurations import parse_spec
    from lift_gl.report.machine import describe_machine, machine_line
    from lift_gl.scene.loader import load_scene

    sizes = [_size(s.strip()) for s in args.sizes.split(",")]
    # each item a plugin with optional settings, as lift-gl compare takes them (pt:rr_depth=1),
    # checked before anything runs
    integrators = [s.strip() for s in args.integrators.split(",") if s.strip() not in ("", "none")]
    from lift_gl.errors import LiftError
    try:
        specs = {integrator: parse_spec(integrator) for integrator in integrators}
    except LiftError as exc:
        raise SystemExit(f"--integrators: {exc}") from None
    ctx = create_context(args.backend)
    machine = describe_machine(ctx)
    from lift_gl.gl.context import is_software
    machine["software_gl"] = bool(is_software(ctx))
    print(f"machine: {machine_line(machine)}; {describe(ctx)}; lift_gl from {Path(lift_gl.__file__).parent.parent}",
          flush=True)

    # --option KEY=A,B: the same cases under each value of one of the renderer's options
    # (lift_gl/options.py), the values interleaved case by case (A B, then B A: drift hits both
    # alike), one record per value and round, merged by best_of like repeated runs; --bvh-width
    # and the others name an option.
    from lift_gl.options import Options, parse_options

    chosen = [(key, value) for key, value in (("bvh_width", args.bvh_width),
                                              ("bvh_stack_entries", args.bvh_stack_entries),
                                              ("bvh_stack", args.bvh_stack),
                                              ("carry_paths", args.carry_paths),
                                              *_option_axis(args.option)) if value]
    if len(chosen) > 1:
        raise SystemExit("--bvh-width, --bvh-stack-entries, --bvh-stack, --carry-paths, --option: one at a time")
    axis, values = chosen[0] if chosen else ("", "")
    splits = [v.strip() for v in values.split(",") if v.strip()] or [None]

    def options_of(v):
        return Options() if v is None else parse_options([f"{axis}={v}"])

    for v in splits:
        options_of(v)   # a bad value stops here, before any case
    rounds = args.split_rounds if splits[0] is not None else 1
    runs = {(v, k): {"label": " ".join(s for s in (args.label, f"{axis}={v or 'default'}" if v is not None else "") if s),
                     "machine": machine,
                     "gl": describe(ctx), "max_depth": args.max_depth, "option": {axis: v} if v is not None else {},
                     "round": k, "results": []}
            for v in splits for k in range(rounds)}

    def out_path(v):
        if v is None or args.out is None:
            return args.out
        # a setting's ',', '=' and ':' become '_' (file names of letters, digits, '.', '-' and '_')
        tag = re.sub(r"[^A-Za-z0-9.-]", "_", v or "default")
        return args.out.with_name(f"{args.out.stem}.{axis}-{tag}{args.out.suffix}")

    def save():  # after every case: a run cut short by a time limit keeps what it measured
        for v in splits:
            if out_path(v) is not None:
                out_path(v).parent.mkdir(parents=True, exist_ok=True)
                recs = [runs[v, k] for k in range(rounds)]
                out_path(v).write_text(json.dumps(recs[0] if len(recs) == 1 else best_of(recs), indent=1))

    def orders():
        for k in range(rounds):
            yield from ((v, k) for v in (splits if k % 2 == 0 else splits[::-1]))

    for path in args.scenes:
        start = time.perf_counter()
        scene = load_scene(path)
        load_s = time.perf_counter() - start
        name = scene_name(path)
        for size in sizes:
            if args.rays and splits[0] is not None:
                # one renderer per setting, their dispatches interleaved (ray_throughput_interleaved)
                renderers, setup = [], []
                for v in splits:
                    start = time.perf_counter()
                    renderers.append(Renderer(scene, size=size, integrator="pt", backend=args.backend,
                                              options=options_of(v)))
                    setup.append(time.perf_counter() - start)
                for v, r, setup_s, rays in zip(splits, renderers, setup,
                                               ray_throughput_interleaved(renderers, size, args.ray_repeat)):
                    runs[v, 0]["results"].append({
                        "kind": "rays", "scene_name": name, "scene": portable(path), "size": list(size),
                        "triangles": r.packed.num_source_triangles or r.packed.num_triangles,
                        "triangle_rows": r.packed.num_triangles, "bvh_nodes": int(r.packed.bvh_nodes.shape[0]),
                        "bvh_depth": r.packed.bvh_depth, "setup_seconds": setup_s, "rays": rays,
                        "ray_times": "median of interleaved dispatches: GPU timer query, or on a CPU "
                                     "rasterizer the process's CPU time (all threads)"})
                    print(f"{name} {size[0]}x{size[1]} rays [{axis}={v or 'default'}, {args.ray_repeat} interleaved]: " + ", ".join(
                        f"{k_} {x['mrays_per_s']:.2f} Mrays/s ({x['ms']:.3f} ms)" for k_, x in rays.items()) + _clock_text(rays), flush=True)
                for r in renderers:
                    r.release()
                save()
            elif args.rays:
                for v, k in orders():
                    start = time.perf_counter()
                    r = Renderer(scene, size=size, integrator="pt", backend=args.backend, options=options_of(v))
                    setup_s = time.perf_counter() - start
                    rays = ray_throughput(r, size, args.ray_repeat)
                    runs[v, k]["results"].append({
                        "kind": "rays", "scene_name": name, "scene": portable(path), "size": list(size),
                        "triangles": r.packed.num_source_triangles or r.packed.num_triangles,
                        "triangle_rows": r.packed.num_triangles, "bvh_nodes": int(r.packed.bvh_nodes.shape[0]),
                        "bvh_depth": r.packed.bvh_depth, "setup_seconds": setup_s, "rays": rays})
                    r.release()
                    save()
                    tag = f" [{axis}={v or 'default'}]" if v is not None else ""
                    print(f"{name} {size[0]}x{size[1]} rays{tag}: " + ", ".join(
                        f"{k_} {x['mrays_per_s']:.1f} Mrays/s ({x['ms']:.3f} ms)" for k_, x in rays.items()) + _clock_text(rays), flush=True)
            for integrator in integrators:
                plugin, settings = specs[integrator]
                for v, k in orders():
                    tag = f" [{axis}={v or 'default'}]" if v is not None else ""
                    try:
                        case = bench_case(scene, size, plugin, {"max_depth": args.max_depth, **settings}, args.frames,
                                          args.repeat, args.backend, options=options_of(v))
                    except LiftError as exc:  # e.g. bdpt refuses an environment map
                        print(f"{name} {size[0]}x{size[1]} {integrator}{tag}: not run: {str(exc).splitlines()[0]}",
                              flush=True)
                        runs[v, k]["results"].append({"kind": "skipped", "scene_name": name, "size": list(size),
                                                      "integrator": integrator, "reason": str(exc)})
                        save()
                        continue
                    case.update(kind="frame", scene_name=name, scene=portable(path), integrator=integrator,
                                plugin=plugin, settings=settings, triangles=scene.triangle_count, load_seconds=load_s)
                    runs[v, k]["results"].append(case)
                    save()
                    print(f"{name} {size[0]}x{size[1]} {integrator}{tag}: {case['frame_ms']:.2f} ms/frame "
                          f"(carry {case.get('carry')}); passes "
                          "(query) " + ", ".join(f"{k_} {x:.3f}" for k_, x in case["pass_ms_query"].items())
                          + _clock_text(case), flush=True)
    save()
    records = [runs[v, 0] if rounds == 1 else best_of([runs[v, k] for k in range(rounds)]) for v in splits]
    print(render_tables(records))
    return 0


def _option_axis(text: str | None) -> list:
    """--option KEY=a,b as an axis (key, values)."""
    if not text:
        return []
    key, sep, values = text.partition("=")
    if not sep or not key.strip() or not values.strip():
        raise SystemExit(f"--option: KEY=value,value, not {text!r}")
    return [(key.strip(), values)]


def _lowest_mhz(record: dict) -> int | None:
    """The lowest SM clock reading of a frame case (its timed runs) or of a ray-kind record's
    `rays` (after each kind); None where there is none (no NVIDIA driver, an older lift_gl)."""
    if "sm_clock" in record:
        readings = record["sm_clock"].get("frames_mhz") or []
    else:
        readings = [x.get("sm_mhz") for x in record.values() if isinstance(x, dict)]
    readings = [m for m in readings if m]
    return min(readings) if readings else None


def _clock_text(record: dict) -> str:
    mhz = _lowest_mhz(record)
    return "" if mhz is None else f"; SM clock {mhz} MHz"


def _mrays(value: float) -> str:
    return f"{value:.0f}" if value >= 100 else f"{value:.2g}" if value < 1 else f"{value:.1f}"


def _frame_key(r):
    return (r["scene_name"], tuple(r["size"]), r["integrator"])


def render_tables(records: list[dict]) -> str:
    """Markdown: frame table (per-pass GPU ms by timer query) and ray table; with several
    records, one column group per record and the ratio of each to the first."""
    labels = [r.get("label") or f"run{i}" for i, r in enumerate(records)]
    gpu = "GPU timer queries" if not records[0]["machine"].get("software_gl") else "CPU clock (llvmpipe)"
    lines = [f"Machine: {records[0]['gl']}; path length {records[0]['max_depth']}, 1 spp; "
             f"pass times: {gpu}. Runs: {', '.join(labels)}.", ""]
    frames = [{_frame_key(r): r for r in rec["results"] if r["kind"] == "frame"} for rec in records]
    keys = list(frames[0])
    head = ["scene", "size", "integrator", "triangles"]
    # a [prepass] plugin's first pass (bdpt's light pass) beside its trace pass (the camera pass)
    prepass = any("prepass" in r["pass_ms_sync"] for t in frames for r in t.values())
    for label in labels:
        head += [f"{label} gbuffer ms"] + ([f"{label} prepass ms"] if prepass else []) + \
                [f"{label} trace ms", f"{label} frame ms", f"{label} Mrays/s"]
    if len(records) > 1:
        head += [f"{'prepass + ' if prepass else ''}trace {lab}/{labels[0]}" for lab in labels[1:]]
    head += ["Lift paper ms (RTX 2070)"]
    clocked = any(_lowest_mhz(r) for t in frames for r in t.values())
    head += ["SM MHz (lowest)"] if clocked else []
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key in keys:
        first = frames[0][key]
        cells = [key[0], f"{key[1][0]}x{key[1][1]}", key[2], f"{first['triangles']:,}"]
        for table in frames:
            r = table.get(key)
            if r is None:
                cells += ["–"] * (5 if prepass else 4)
                continue
            q = r["pass_ms_query"] if not records[0]["machine"].get("software_gl") else r["pass_ms_sync"]
            cells += [f"{q.get('gbuffer', 0):.3f}"] + ([f"{q['prepass']:.3f}" if "prepass" in q else "–"] if prepass else []) + \
                     [f"{q.get('trace', 0):.3f}", f"{r['frame_ms']:.3f}", _mrays(r['rays_per_second'] / 1e6)]
        for table in frames[1:]:
            r = table.get(key)
            qa = first["pass_ms_query"] if not records[0]["machine"].get("software_gl") else first["pass_ms_sync"]
            qb = None if r is None else (r["pass_ms_query"] if not records[0]["machine"].get("software_gl") else r["pass_ms_sync"])
            traced = lambda q: q["trace"] + q.get("prepass", 0.0)  # a [prepass] plugin's light pass counts with its trace
            cells.append("–" if qb is None else f"{traced(qb) / traced(qa):.3f}")
        paper = LIFT_PAPER_MS.get(first.get("plugin", key[2]), {}).get(key[0]) if key[1] == (1920, 1080) else None
        cells.append("–" if paper is None else f"{paper}")
        if clocked:
            cells.append(" / ".join(str(_lowest_mhz(t[key]) or "–") if key in t else "–" for t in frames))
        lines.append("| " + " | ".join(cells) + " |")
    rays = [{(r["scene_name"], tuple(r["size"])): r for r in rec["results"] if r["kind"] == "rays"} for rec in records]
    if rays[0]:
        how = next((r["ray_times"] for r in rays[0].values() if r.get("ray_times")), "best of the dispatches")
        lines += ["", f"Mrays/s by ray kind (ray-casting shader over lift/bvh.glsl, {how}):", ""]
        head = ["scene", "size", "triangles"]
        for label in labels:
            head += [f"{label} {k}" for k in RAY_KINDS]
        if len(records) > 1:
            head += [f"{k} {lab}/{labels[0]}" for lab in labels[1:] for k in RAY_KINDS]
        clocked = any(_lowest_mhz(r["rays"]) for t in rays for r in t.values())
        head += ["SM MHz (lowest)"] if clocked else []
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for key, first in rays[0].items():
            cells = [key[0], f"{key[1][0]}x{key[1][1]}", f"{first['triangles']:,}"]
            for table in rays:
                r = table.get(key)
                cells += ["–"] * 3 if r is None else [_mrays(r['rays'][k]['mrays_per_s']) for k in RAY_KINDS]
            for table in rays[1:]:
                r = table.get(key)
                for k in RAY_KINDS:
                    cells.append("–" if r is None else
                                 f"{r['rays'][k]['mrays_per_s'] / first['rays'][k]['mrays_per_s']:.3f}")
            if clocked:
                cells.append(" / ".join(str(_lowest_mhz(t[key]["rays"]) or "–") if key in t else "–" for t in rays))
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def best_of(records: list[dict]) -> dict:
    """Several runs of the same label merged: each case's fastest (for interleaved repeats);
    a case missing from some runs (cut short) keeps the runs that have it."""
    software = records[0]["machine"].get("software_gl")
    cases: dict = {}
    for rec in records:
        for r in rec["results"]:
            if r["kind"] in ("frame", "rays"):
                key = (r["kind"], r["scene_name"], tuple(r["size"]), r.get("integrator"))
                cases.setdefault(key, []).append(r)
    results = []
    for (kind, *_), alts in cases.items():
        if kind == "frame":
            results.append(min(alts, key=lambda a: a["pass_ms_sync" if software else "pass_ms_query"]["trace"]))
        else:
            results.append(dict(alts[0], rays={k: max((a["rays"][k] for a in alts), key=lambda v: v["mrays_per_s"])
                                               for k in RAY_KINDS}))
    return dict(records[0], results=results, runs=len(records))


def table_cmd(args) -> int:
    by_label: dict[str, list] = {}
    for f in args.files:
        rec = json.loads(Path(f).read_text())
        if "variants" in rec:  # an `ab` record
            show_table(ab_table(rec), args.md)
            return 0
        by_label.setdefault(rec.get("label") or f, []).append(rec)
    records = [best_of(recs) for recs in by_label.values()]
    show_table(render_tables(records), args.md)
    return 0


def interactive(args) -> int:
    """The viewer's frame (lift_gl/report/bench_interactive.py) for each scene, integrator,
    denoiser and size, whole and per pass: the table printed, JSON and markdown written."""
    import lift_gl
    from lift_gl.cli import _size
    from lift_gl.gl.context import create_context, describe
    from lift_gl.options import Options, parse_options
    from lift_gl.report.bench_interactive import interactive_case, table
    from lift_gl.report.configurations import parse_spec
    from lift_gl.report.machine import describe_machine, machine_line
    from lift_gl.scene.loader import load_scene

    sizes = [_size(s.strip()) for s in args.sizes.split(",")]
    specs = [parse_spec(s.strip()) for s in args.integrators.split(",") if s.strip()]
    options = parse_options(args.option) if args.option else Options()
    ctx = create_context(args.backend)
    machine = describe_machine(ctx)
    print(f"machine: {machine_line(machine)}; {describe(ctx)}; lift_gl from {Path(lift_gl.__file__).parent.parent}",
          flush=True)
    record = {"label": args.label, "machine": machine, "gl": describe(ctx), "max_depth": args.max_depth,
              "options": args.option or [], "cases": []}
    for path in args.scenes:
        scene = load_scene(path)
        for (plugin, settings) in specs:
            for size in sizes:
                for denoiser in [d.strip() for d in args.denoisers.split(",")]:
                    case = interactive_case(scene, size, plugin, {"max_depth": args.max_depth, **settings}, denoiser,
                                            args.frames, args.repeat, args.backend, options)
                    case.update(scene=portable(path), scene_name=scene_name(str(path)),
                                spec=":".join([plugin] + [f"{k}={v}" for k, v in settings.items()]))
                    if not args.explain:
                        case.pop("explain", None)
                    record["cases"].append(case)
                    print(f"{case['scene_name']} {case['spec']} {size[0]}x{size[1]} {denoiser}: "
                          f"{case['frame_ms']:.2f} ms {case['pass_ms']}", flush=True)
                    if args.out:  # after every case: a run cut short keeps what it measured
                        args.out.write_text(json.dumps(record, indent=1) + "\n")
    text = table(record["cases"])
    show_table(text, args.md)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("measure")
    m.add_argument("scenes", nargs="+")
    m.add_argument("--sizes", default="1280x720,1920x1080")
    m.add_argument("--integrators", default="pt,bdpt",
                   help="comma-separated, each with optional :NAME=VALUE settings (pt,pt:rr_depth=1); none: only the ray kinds")
    m.add_argument("--max-depth", type=int, default=32)
    m.add_argument("--frames", type=int, default=16)
    m.add_argument("--repeat", type=int, default=2)
    m.add_argument("--ray-repeat", type=int, default=8)
    m.add_argument("--no-rays", dest="rays", action="store_false")
    m.add_argument("--backend", default="auto")
    m.add_argument("--label", default="")
    m.add_argument("--out", type=Path)
    m.add_argument("--option", help="KEY=a,b: every case measured under each value of the renderer's option KEY "
                   "(lift_gl/options.py), interleaved; --out FILE.json becomes FILE.KEY-VALUE.json per value")
    m.add_argument("--bvh-width", help="comma-separated bvh_width values (2,4,4q): as --option bvh_width=...")
    m.add_argument("--bvh-stack-entries", help="comma-separated bvh_stack_entries values (children,groups): as --option")
    m.add_argument("--bvh-stack", help="comma-separated bvh_stack values (shared,local,auto: where the trace pass "
                   "keeps its stack): as --option")
    m.add_argument("--carry-paths", help="comma-separated carry_paths values (off,on: paths under way when a frame's "
                   "pixel queue runs out go on in the next frame): as --option")
    m.add_argument("--split-rounds", type=int, default=2, help="with --option: rounds, in alternating order")
    m.set_defaults(func=measure)
    v = sub.add_parser("ab", help="versions of bvh.glsl against each other, interleaved in one process")
    v.add_argument("scenes", nargs="+")
    v.add_argument("--variant", action="append", required=True, metavar="LABEL=TREE:binary|records|4|4q[:NAME,...]")
    v.add_argument("--sizes", default="160x90")
    v.add_argument("--reps", type=int, default=15)
    v.add_argument("--backend", default="auto")
    v.add_argument("--out", type=Path)
    v.add_argument("--md", type=Path)
    v.set_defaults(func=ab)
    i = sub.add_parser("interactive", help="the viewer's frame per pass (reprojection, denoised every frame)")
    i.add_argument("scenes", nargs="+")
    i.add_argument("--sizes", default="1920x1080")
    i.add_argument("--integrators", default="pt", help="comma-separated, each with :NAME=VALUE settings")
    i.add_argument("--denoisers", default="atrous,glsl")
    i.add_argument("--max-depth", type=int, default=32)
    i.add_argument("--frames", type=int, default=50)
    i.add_argument("--repeat", type=int, default=3)
    i.add_argument("--option", action="append", metavar="KEY=VALUE", help="a renderer option (lift_gl/options.py)")
    i.add_argument("--backend", default="auto")
    i.add_argument("--label", default="")
    i.add_argument("--explain", action="store_true", help="keep each renderer's --explain text in the JSON")
    i.add_argument("--out", type=Path)
    i.add_argument("--md", type=Path)
    i.set_defaults(func=interactive)
    t = sub.add_parser("table")
    t.add_argument("files", nargs="+")
    t.add_argument("--md", type=Path)
    t.set_defaults(func=table_cmd)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
