"""Whether a GL driver runs a compute dispatch while the one before it is still finishing.

    python benchmarks/gpu_overlap.py [--out FILE.json]

A path-tracing frame ends with a tail: its last paths run on a few lanes while the rest of the
GPU idles (docs/gpu.md, "Measuring"). Work that does not depend on those paths (the next
frame's G-buffer, this frame's predecessor's accumulation) could fill the idle lanes, if the
driver starts a dispatch before the previous one has ended. OpenGL allows that where no memory
barrier stands between them (the writes of one dispatch are visible to the next only after
glMemoryBarrier); whether a driver does it is what this measures.

Two synthetic programs: `tail`, one work group of 32 lanes running a long dependent loop (a
frame's last lone paths), and `bulk`, a dispatch over 2M invocations that fills every SM (a
G-buffer pass). Each order is timed by the CPU clock between two glFinish calls, 7 times
(medians): tail alone, bulk alone, tail then bulk with and without a barrier between them.
Without overlap tail + bulk costs the sum of the two; with it, about the larger.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from lift_gl.report.records import write_json  # noqa: E402

TAIL_SOURCE = """#version 430
layout(local_size_x = 32) in;
layout(std430, binding = 0) writeonly buffer Out { float out_tail[]; };
uniform uint u_iters;
void main() {
    float v = float(gl_GlobalInvocationID.x);
    for (uint i = 0u; i < u_iters; ++i) v = fma(v, 0.9999, 1.0);   // dependent: latency, one warp
    out_tail[gl_GlobalInvocationID.x] = v;
}
"""

BULK_SOURCE = """#version 430
layout(local_size_x = 64) in;
layout(std430, binding = 1) writeonly buffer Out { float out_bulk[]; };
uniform uint u_iters;
void main() {
    float a = float(gl_GlobalInvocationID.x), b = a * 0.5, c = a * 0.25, d = a * 0.125;
    for (uint i = 0u; i < u_iters; ++i) {   // four independent chains: throughput
        a = fma(a, 0.9999, 1.0); b = fma(b, 0.9999, 1.0); c = fma(c, 0.9999, 1.0); d = fma(d, 0.9999, 1.0);
    }
    out_bulk[gl_GlobalInvocationID.x] = a + b + c + d;
}
"""


def median_ms(ctx, run, reps: int) -> float:
    times = []
    for _ in range(reps + 1):
        ctx.finish()
        start = time.perf_counter()
        run()
        ctx.finish()
        times.append(1e3 * (time.perf_counter() - start))
    return float(np.median(times[1:]))   # the first: warm-up


def main(argv=None) -> int:
    from lift_gl.gl.context import create_context, describe

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tail-iters", type=int, default=400_000)
    ap.add_argument("--bulk-iters", type=int, default=2_000)
    ap.add_argument("--bulk-invocations", type=int, default=1 << 21)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--backend", default="auto")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    ctx = create_context(args.backend)
    tail, bulk = ctx.compute_shader(TAIL_SOURCE), ctx.compute_shader(BULK_SOURCE)
    tail["u_iters"].value = args.tail_iters
    bulk["u_iters"].value = args.bulk_iters
    out_tail, out_bulk = ctx.buffer(reserve=4 * 32), ctx.buffer(reserve=4 * args.bulk_invocations)
    out_tail.bind_to_storage_buffer(0)
    out_bulk.bind_to_storage_buffer(1)
    groups = args.bulk_invocations // 64

    def barrier():
        ctx.memory_barrier()

    cases = {
        "tail": lambda: tail.run(1),
        "bulk": lambda: bulk.run(groups),
        "tail, bulk": lambda: (tail.run(1), bulk.run(groups)),
        "tail, barrier, bulk": lambda: (tail.run(1), barrier(), bulk.run(groups)),
        "bulk, tail": lambda: (bulk.run(groups), tail.run(1)),
    }
    record = {"gl": describe(ctx), "args": {k: v for k, v in vars(args).items() if k != "out"}, "median_ms": {}}
    print(record["gl"], flush=True)
    for name, run in cases.items():
        record["median_ms"][name] = median_ms(ctx, run, args.reps)
        print(f"{name}: {record['median_ms'][name]:.3f} ms", flush=True)
    m = record["median_ms"]
    record["overlap_ms"] = m["tail"] + m["bulk"] - m["tail, bulk"]
    print(f"overlap without a barrier: {record['overlap_ms']:.3f} ms of the smaller {min(m['tail'], m['bulk']):.3f}")
    if args.out:
        write_json(args.out, record, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
