"""How many warps an NVIDIA SM runs at once for a compute program: what its registers allow.

    python benchmarks/gpu_occupancy.py [--out FILE.json]

NVIDIA's OpenGL reports neither a program's registers nor its occupancy (docs/gpu.md,
"Register pressure"). GL_NV_shader_thread_group tells a shader its SM (gl_SMIDNV) and its warp
(gl_ThreadInWarpNV, gl_WarpIDNV), and that is enough to count: lane 0 of each warp adds one to
its SM's counter when the warp starts (keeping the counter's largest value) and takes one off
at its end. A dispatch of far more warps than the GPU holds fills every SM to what the program's
registers, shared memory and work-group count allow before any warp ends, so the largest count
is the warps an SM held (OCCUPANCY_PROBE; benchmarks/gpu_pt_variants.py edits the same probe
into the trace programs as its occ_ variants).

This script calibrates the probe on synthetic programs whose live registers are known: K floats
kept live across a loop (each updated from its neighbour, so none can be dropped), in work groups
of 32 to 256 invocations. If the warps an SM holds follow 65536 / (32 x registers), the probe
reads registers; where they stop at a smaller number for every K, a work-group limit does.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from lift_gl.report.records import write_json  # noqa: E402

OCCUPANCY_BINDING = 20
OCCUPANCY_SMS = 256   # per-SM counters the probe's buffer holds
OCCUPANCY_WORDS = 3 * OCCUPANCY_SMS + 2


def occupancy_probe() -> tuple[str, str, str]:
    """GLSL of the probe (needs #extension GL_NV_shader_thread_group): code for a program's
    start, code for its end, and the buffer's declaration. Only per-SM atomics: one counter
    for a whole GPU made every warp wait its turn (a 1 ms dispatch took 72 ms) and let early
    warps end before late ones had counted themselves in."""
    sm = f"gl_SMIDNV % {OCCUPANCY_SMS}u"
    enter = ("    if (gl_ThreadInWarpNV == 0u) {\n"
             f"        uint occ_sm = {sm};\n"
             "        atomicMax(occ_peak[occ_sm], atomicAdd(occ_now[occ_sm], 1u) + 1u);\n"
             "        atomicMax(occ_warp_id[occ_sm], gl_WarpIDNV + 1u);\n"
             "        if (occ_sm == 0u) { occ_warps_per_sm = gl_WarpsPerSMNV; occ_sms = gl_SMCountNV; }\n"
             "    }\n")
    leave = f"    if (gl_ThreadInWarpNV == 0u) atomicAdd(occ_now[{sm}], 0xffffffffu);\n"
    decl = (f"layout(std430, binding = {OCCUPANCY_BINDING}) coherent buffer LiftOccupancy {{\n"
            f"    uint occ_now[{OCCUPANCY_SMS}]; uint occ_peak[{OCCUPANCY_SMS}]; uint occ_warp_id[{OCCUPANCY_SMS}];\n"
            "    uint occ_warps_per_sm; uint occ_sms; };\n")
    return enter, leave, decl


def occupancy_summary(words: np.ndarray) -> dict:
    """The probe's buffer: the warps each SM held at once (largest count) over the SMs that ran,
    and the largest warp slot id + 1 seen."""
    peak = words[OCCUPANCY_SMS:2 * OCCUPANCY_SMS]
    ids = words[2 * OCCUPANCY_SMS:3 * OCCUPANCY_SMS]
    ran = peak > 0
    return {"warps_per_sm_max": int(peak.max()) if ran.any() else 0,
            "warps_per_sm_min": int(peak[ran].min()) if ran.any() else 0,
            "warps_per_sm_mean": float(peak[ran].mean()) if ran.any() else 0.0, "sms_seen": int(ran.sum()),
            "warp_slot_max": int(ids.max()), "warps_per_sm_hw": int(words[3 * OCCUPANCY_SMS]),
            "sm_count": int(words[3 * OCCUPANCY_SMS + 1])}


def synthetic_source(live: int, local: int) -> str:
    """K = `live` floats kept live across a loop of u_iters rounds, in 1D work groups of `local`."""
    enter, leave, decl = occupancy_probe()
    update = "\n".join(f"        v{i} = fma(v{i}, 1.0001, v{(i + 1) % live});" for i in range(live))
    init = "\n".join(f"    float v{i} = float(gl_GlobalInvocationID.x + {i}u) * {1.0 + i / 1000.0};" for i in range(live))
    total = " + ".join(f"v{i}" for i in range(live))
    return f"""#version 430
#extension GL_NV_shader_thread_group : require
layout(local_size_x = {local}) in;
{decl}
layout(std430, binding = 1) writeonly buffer Out {{ float out_values[]; }};
uniform uint u_iters;
void main() {{
{enter}
{init}
    for (uint it = 0u; it < u_iters; ++it) {{
{update}
    }}
    out_values[gl_GlobalInvocationID.x] = {total};
{leave}
}}
"""


def measure(ctx, live: int, local: int, invocations: int, iters: int) -> dict:
    prog = ctx.compute_shader(synthetic_source(live, local))
    probe = ctx.buffer(reserve=4 * OCCUPANCY_WORDS)
    out = ctx.buffer(reserve=4 * invocations)
    prog["u_iters"].value = iters
    probe.bind_to_storage_buffer(OCCUPANCY_BINDING)
    out.bind_to_storage_buffer(1)
    prog.run(invocations // local)   # a first run: compile and first-use costs
    ctx.finish()
    probe.write(bytes(4 * OCCUPANCY_WORDS))
    start = time.perf_counter()
    prog.run(invocations // local)
    ctx.finish()
    ms = 1e3 * (time.perf_counter() - start)
    row = dict(occupancy_summary(np.frombuffer(probe.read(), np.uint32)), live_floats=live, local_size=local, ms=ms)
    for obj in (prog, probe, out):
        obj.release()
    return row


def main(argv=None) -> int:
    from lift_gl.gl.context import create_context, describe

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--live", default="8,32,64,96,112,120,128,136,160,200,240")
    ap.add_argument("--local", default="32,64,128,256")
    ap.add_argument("--invocations", type=int, default=1 << 21)
    ap.add_argument("--iters", type=int, default=2000)
    ap.add_argument("--backend", default="auto")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    ctx = create_context(args.backend)
    record = {"gl": describe(ctx), "rows": []}
    print(record["gl"], flush=True)
    print("| live floats | work group | warps/SM (max, min) | warp slots | ms |\n|---|---|---|---|---|")
    for local in (int(v) for v in args.local.split(",")):
        for live in (int(v) for v in args.live.split(",")):
            row = measure(ctx, live, local, args.invocations, args.iters)
            record["rows"].append(row)
            print(f"| {live} | {local} | {row['warps_per_sm_max']}, {row['warps_per_sm_min']} | {row['warp_slot_max']} "
                  f"| {row['ms']:.2f} |", flush=True)
            if args.out:
                write_json(args.out, record, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
