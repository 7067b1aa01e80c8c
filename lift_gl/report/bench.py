"""`lift-gl bench`: how fast each pass runs, for a set of scenes and resolutions.

    lift-gl bench SCENE... [--sizes 64x64,128x128,256x256] [--integrator pt] [--frames 16]
                  [--repeat 3] [--option KEY=VALUE ...] [--json FILE]

For each scene: its BVH build time (no cache) and, at each size:
- frame time: wall-clock time per frame, frames pipelined, GPU work finished (best of --repeat);
- per pass: the CPU clock between two ctx.finish() around the pass ("sync"), and the GL timer
  query around it ("query"). The table shows sync times: on Mesa llvmpipe timer queries miss
  some compute work (the accumulate pass reads ~0), so both are kept in the JSON;
- paths/s (one path per pixel sample) and rays/s: rays traced through the BVH per path,
  counted by a shader variant with LIFT_COUNT_RAYS in separate frames (so counting does not
  slow the timed ones); primary visibility from the raster G-buffer is not a traced ray.
A pass that exists only with some settings gets its column when it runs.
- denoiser time (--denoisers, default atrous): one denoiser run on the accumulated image, its
  unjittered G-buffer guides included, GPU work finished (best of --repeat x 3 runs); "none"
  leaves it out.
- on NVIDIA GPUs: frames until the SM clock has risen from idle before timing, and the clock
  each timed run ended at (`sm_clock` in the JSON; report/gpu_clock.py);
- how the frames ran: every option's choice (`options` in the JSON, lift_gl/options.py).
- with --interactive DENOISERS: the viewer's frame (temporal reprojection, the denoiser after
  every frame, a slowly turning camera), whole and per pass, for each denoiser
  (report/bench_interactive.py; `interactive` in the JSON).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from .bench_interactive import interactive_case
from .bench_interactive import table as interactive_table
from .gpu_clock import ClockReader, warm_up


def add_parser(subparsers) -> None:
    from ..arg_types import positive_int

    p = subparsers.add_parser("bench", help="frame time per pass, paths/s, rays/s and BVH build time, as a table and JSON",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="+", metavar="SCENE")
    p.add_argument("--sizes", default="64x64,128x128,256x256", help="comma-separated WxH")
    p.add_argument("--integrator", default="pt")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="plugin parameter")
    p.add_argument("--frames", type=positive_int, default=16, help="timed frames per measurement (default 16)")
    p.add_argument("--repeat", type=positive_int, default=3, help="frame time: best of this many measurements (default 3)")
    p.add_argument("--denoisers", default="atrous", metavar="LIST",
                   help="comma-separated denoisers to time (atrous, onnx, oidn), or none (default atrous)")
    p.add_argument("--interactive", metavar="LIST",
                   help="also time the viewer's frame (reprojection, denoised every frame, a turning camera) "
                        "with each of these comma-separated denoisers (atrous, glsl, ...)")
    p.add_argument("--plugins", action="append", default=[], metavar="DIR")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    p.add_argument("--json", type=Path, dest="json_path", help="also write the results here")
    from ..options import add_option_argument

    add_option_argument(p)
    p.set_defaults(func=cmd_bench)


class PassTimer:
    """One pass timed two ways: the CPU clock between ctx.finish() calls, and a GL timer query."""

    def __init__(self, ctx):
        from ..passes.common import GpuTimer

        self.ctx = ctx
        self.query = GpuTimer(ctx)
        self.sync_ns = 0
        self.count = 0

    def __enter__(self):
        self.ctx.finish()
        self._start = time.perf_counter_ns()
        self.query.__enter__()
        return self

    def __exit__(self, *exc):
        self.query.__exit__(*exc)
        self.ctx.finish()
        self.sync_ns += time.perf_counter_ns() - self._start
        self.count += 1
        return False

    @property
    def mean_ms(self) -> float:
        return self.sync_ns / max(self.count, 1) / 1e6


def bvh_build_seconds(scene) -> tuple[int, float]:
    """Triangles and the time to build their BVH from scratch (the on-disk cache bypassed)."""
    from ..accel.bvh import build_bvh

    if not scene.meshes:
        return 0, 0.0
    positions = np.concatenate([m.positions[m.indices] for m in scene.meshes]).astype(np.float32)
    start = time.perf_counter()
    build_bvh(positions)
    return len(positions), time.perf_counter() - start


def denoise_seconds(renderer, runs: int) -> float:
    """Best wall time of one denoiser run on the renderer's current accumulation."""
    times = []
    for _ in range(runs):
        before = renderer.stats.denoise_seconds
        renderer.run_denoiser()
        times.append(renderer.stats.denoise_seconds - before)
    return min(times)


# A timed run of frames counts as run at full clock when the SM clock read after it is within
# FULL_CLOCK of the GPU's maximum. A case whose runs all read lower gets up to EXTRA_RUNS more
# runs until one does, and its frame time is the best of those that do (else of all). On an H100
# the one case that needed it, the cornell-box, whose frames are short enough that the host's
# work between them leaves the GPU idle, stayed down anyway (720p: 780-960 MHz through six runs,
# NVML's reason "idle"; docs/gpu.md "Sixteenth session"): the readings say so in the record.
FULL_CLOCK = 0.95
EXTRA_RUNS = 4
WARM_STEP_S = 0.1


def growing_step(render_frames, first: int = 16, most: int = 1024, seconds: float = WARM_STEP_S,
                 now=time.perf_counter):
    """A warm-up step that renders (and finishes) frames, twice as many each time a step took
    less than `seconds`, up to `most`, so that the warm-up's own pauses between steps are short
    beside its GPU work however small the scene."""
    frames = [first]

    def step():
        start = now()
        render_frames(frames[0])
        if now() - start < seconds:
            frames[0] = min(2 * frames[0], most)
    return step


def more_runs(readings: list, peak, repeat: int) -> bool:
    """Whether bench_case times another run: none of the runs so far read at full clock (NVIDIA
    only: without readings never), and fewer than EXTRA_RUNS extra runs were made."""
    if not peak or not readings or any(m is None for m in readings):
        return False
    return not any(m >= FULL_CLOCK * peak for m in readings) and len(readings) < max(repeat, 1) + EXTRA_RUNS


def at_full_clock(seconds: list, readings: list, peak) -> list:
    """The runs' times that read at full clock, or all of them if none did (or no readings)."""
    kept = [s for s, m in zip(seconds, readings) if peak and m is not None and m >= FULL_CLOCK * peak]
    return kept or seconds


def bench_case(scene, size, integrator="pt", params=None, frames=16, repeat=3, backend="auto", plugin_dirs=(),
               denoisers=(), options=None) -> dict:
    """Timings of one scene at one size; see the module's docstring. `options`: lift_gl/options.py
    Options (None: the defaults)."""
    from ..frame_settings import DenoiseSettings
    from ..renderer import Renderer

    def make(**kw):
        r = Renderer(scene, size=size, integrator=integrator, params=params, backend=backend,
                     plugin_dirs=plugin_dirs, options=options, **kw)
        r.render(spp=r.samples_per_frame * 2)  # warm-up: shader JIT and first-use costs
        r.reset()
        return r

    renderer = make()
    spf = renderer.samples_per_frame
    buffers = renderer.buffers.memory()
    # An idle GPU runs at a low clock until kept busy (report/gpu_clock.py): frames until it
    # has risen, and the clock recorded after each timed run.
    clock = ClockReader(renderer.ctx.info.get("GL_RENDERER", ""))
    # steps of at least 16 frames and WARM_STEP_S: a step of a few frames of a small scene left
    # the GPU idle between calls, and its clock then stayed down
    warm = warm_up(growing_step(lambda n: (renderer.render(spp=n * spf), renderer.ctx.finish())), clock)
    trace = getattr(renderer, "trace", None)
    frame_seconds, frame_mhz, frame_reasons = [], [], []
    peak = clock.max_sm_mhz()
    while len(frame_seconds) < max(repeat, 1) or more_runs(frame_mhz, peak, repeat):
        renderer.reset()
        renderer.render(spp=frames * spf)
        frame_seconds.append(renderer.stats.render_seconds / renderer.stats.frames)
        frame_mhz.append(clock.sm_mhz())
        frame_reasons.append(clock.reasons())   # why the clock is held down, if it is (NVML's mask)
    frame_s = min(at_full_clock(frame_seconds, frame_mhz, peak))
    dropped = renderer.stats.dropped_samples
    # Per pass, synchronised: slower in total than pipelined frames, but each pass alone.
    renderer.reset()
    renderer.timers = {p.name: PassTimer(renderer.ctx) for p in renderer.passes}
    renderer.render(spp=frames * spf)
    pass_mhz = clock.sm_mhz()
    pass_sync = {name: t.mean_ms for name, t in renderer.timers.items() if t.count}
    pass_query = {name: t.query.mean_ms for name, t in renderer.timers.items() if t.count}
    choices = renderer.choices.record()   # how the frames ran (lift_gl/options.py)
    carry = getattr(trace, "carry", None) is not None   # paths carried into the next frame
    renderer.release()

    counting = make(count_rays=True)
    counted_frames = max(1, min(frames, 8))
    counting.render(spp=counted_frames * spf)
    paths = size[0] * size[1] * counting.stats.spp
    rays_per_path = counting.stats.rays / paths
    counting.release()

    denoise_ms = {}
    for name in denoisers:
        denoising = make(denoise=DenoiseSettings("final", name))
        denoising.render(spp=max(2, min(frames, 8)) * spf, final=False)  # both half-buffers hold samples
        denoise_ms[name] = 1e3 * denoise_seconds(denoising, 3 * max(repeat, 1))
        denoising.release()

    paths_per_second = size[0] * size[1] * spf / frame_s
    return {"size": list(size), "samples_per_frame": spf, "frames": frames, "repeat": repeat,
            "frame_ms": 1e3 * frame_s, "frame_ms_all": [1e3 * s for s in frame_seconds],
            "pass_ms_sync": pass_sync, "pass_ms_query": pass_query,
            "paths_per_second": paths_per_second, "rays_per_path": rays_per_path,
            "rays_per_second": paths_per_second * rays_per_path, "counted_paths": paths,
            "dropped_samples": dropped, "denoise_ms": denoise_ms,
            # every storage buffer of the scene: name, binding, bytes (split scenes: heap[k])
            "gpu_buffers": [{"name": n, "binding": b, "bytes": int(size)} for n, b, size in buffers],
            "gpu_buffer_bytes": int(sum(size for _, _, size in buffers)),
            "bvh_builder": renderer.packed.bvh_builder,
            # the tree traversed: children a node (2 or 4), its nodes and levels (4-wide: wide nodes)
            "bvh": {"width": int(renderer.packed.bvh_width), "quantized": bool(renderer.packed.bvh_quantized),
                    "nodes": int(renderer.packed.bvh_nodes.shape[0]), "levels": int(renderer.packed.bvh_levels)},
            "options": choices, "carry": carry,
            # NVIDIA only (else None): the SM clock after each timed run of frames and after
            # the per-pass run, and the warm-up before them
            "sm_clock": {"frames_mhz": frame_mhz, "frames_reasons": frame_reasons, "passes_mhz": pass_mhz,
                         "warm_up": warm}}


def clock_note(case: dict) -> str:
    """", SM clock 1980 MHz (max 1980)" from a case's record: the lowest clock its timed frames
    ended at; empty where there is no reading (no NVIDIA driver)."""
    clock = case.get("sm_clock") or {}
    readings = [m for m in clock.get("frames_mhz", []) if m]
    peak = (clock.get("warm_up") or {}).get("max_sm_mhz")
    if not readings:
        return ""
    return f", SM clock {min(readings)} MHz" + (f" (max {peak})" if peak else "")


def table(results: list[dict]) -> str:
    """A markdown table of the results (pass columns: those that ran, in frame order)."""
    passes = []
    for r in results:
        for name in r["pass_ms_sync"]:
            if name not in passes:
                passes.append(name)
    denoisers = []
    for r in results:
        denoisers += [name for name in r.get("denoise_ms", {}) if name not in denoisers]
    header = ["scene", "size", "triangles", "BVH build s"] + [f"{p} ms" for p in passes] + \
             ["frame ms", "Mpaths/s", "rays/path", "Mrays/s"] + [f"denoise {d} ms" for d in denoisers]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in results:
        cells = [r["scene_name"], "x".join(map(str, r["size"])), f"{r['triangles']:,}", f"{r['bvh_build_seconds']:.3f}"]
        cells += [f"{r['pass_ms_sync'][p]:.2f}" if p in r["pass_ms_sync"] else "–" for p in passes]
        cells += [f"{r['frame_ms']:.2f}", f"{r['paths_per_second'] / 1e6:.3f}", f"{r['rays_per_path']:.2f}",
                  f"{r['rays_per_second'] / 1e6:.3f}"]
        cells += [f"{r['denoise_ms'][d]:.2f}" if d in r.get("denoise_ms", {}) else "–" for d in denoisers]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def cmd_bench(args) -> int:
    from ..arg_types import check_output_file
    from ..atomic import write_text
    from ..cli import _settings, _size
    from ..options import from_args
    from ..errors import LiftError
    from ..gl.context import create_context
    from ..scene.loader import load_scene
    from .machine import describe_machine, machine_line

    try:
        sizes = [_size(text.strip()) for text in args.sizes.split(",")]
    except Exception as exc:
        raise LiftError(f"--sizes: {exc}") from None
    if args.frames < 1 or args.repeat < 1:
        raise LiftError("--frames and --repeat must be at least 1")
    if args.json_path:
        check_output_file(args.json_path, "--json")
    params = _settings(args.set, args.integrator)
    options = from_args(args)
    denoisers = [] if args.denoisers.strip() == "none" else [d.strip() for d in args.denoisers.split(",")]
    from ..denoise import DENOISERS

    interactive = [d.strip() for d in args.interactive.split(",")] if args.interactive else []
    for flag, names in (("--denoisers", denoisers), ("--interactive", interactive)):
        for name in names:
            if name not in DENOISERS:
                raise LiftError(f"{flag}: unknown denoiser {name!r}; choose among {', '.join(DENOISERS)}"
                                + (", or none" if flag == "--denoisers" else ""))
    machine = describe_machine(create_context(args.backend))
    print(f"machine: {machine_line(machine)}", flush=True)
    results, interactive_cases = [], []
    for path in args.scenes:
        start = time.perf_counter()
        scene = load_scene(path)
        load_seconds = time.perf_counter() - start
        triangles, build_seconds = bvh_build_seconds(scene)
        for size in sizes:
            case = bench_case(scene, size, args.integrator, params, args.frames, args.repeat, args.backend, args.plugins,
                              denoisers, options)
            case.update(scene=str(path), scene_name=Path(path).parent.name if Path(path).stem == "scene" else Path(path).stem,
                        triangles=triangles, spheres=len(scene.spheres), load_seconds=load_seconds,
                        bvh_build_seconds=build_seconds)
            results.append(case)
            print(f"{case['scene_name']} {size[0]}x{size[1]}: {case['frame_ms']:.2f} ms/frame, "
                  f"{case['paths_per_second'] / 1e6:.3f} Mpaths/s, {case['rays_per_path']:.2f} rays/path"
                  f"{clock_note(case)}", flush=True)
            for name in interactive:
                frame = interactive_case(scene, size, args.integrator, params, name, args.frames, args.repeat,
                                         args.backend, options)
                frame.update(scene=str(path), scene_name=case["scene_name"])
                interactive_cases.append(frame)
                print(f"  viewer's frame with {name}: {frame['frame_ms']:.2f} ms", flush=True)
    print()
    print(table(results))
    print(f"\n{args.integrator}; per-pass times: CPU clock between ctx.finish() calls (GL timer queries in the JSON); "
          f"frame ms: best of {args.repeat} x {args.frames} pipelined frames")
    if interactive_cases:
        print("\nThe viewer's frame (temporal reprojection, denoised every frame, a turning camera; per pass: "
              "GL timer queries):\n")
        print(interactive_table(interactive_cases))
    if args.json_path:
        write_text(args.json_path, json.dumps({"machine": machine, "integrator": args.integrator, "params": params,
                                               "options": options.changed(), "results": results,
                                               "interactive": interactive_cases}, indent=1))
    return 0
