"""The trace pass as a wavefront: a path vertex per dispatch, over the paths still alive.

The megakernel (passes/trace.py) runs a pixel's whole path in one invocation, so a GPU warp
runs until the longest of its 32 paths ends. A plugin that defines LIFT_PATH_STEPS (pt:
PathState, path_start, path_step, path_radiance) can instead be run a vertex at a time: its
own functions, unchanged, in one program with three modes:
  start - per pixel (tiles of the megakernel's work-group shape): the G-buffer's primary hit,
          the sample's Rng, path_start and the first `prefix` path_steps (the megakernel's
          loop, for the vertices before Russian roulette thins the paths: compacting there
          gains nothing and costs a slot's write and read a path);
  step  - one path_step for each path in the live queue;
  tail  - each path left in the queue run to its end (the megakernel's loop), so that a
          plugin's paths of any length finish after a fixed number of dispatches.
A path that survives its step stores its PathState and Rng in its pixel's slot of a storage
buffer and appends its pixel to the next queue (one atomic a subgroup with ARB_shader_ballot);
a path that ends adds its radiance to the frame where the megakernel would, with the same
NaN/Inf guard and counters. A one-invocation program turns the queue's length into the next
indirect dispatch (glDispatchComputeIndirect), so the CPU never waits (on an H100 an empty
step took 0.03 ms, its argument kernel 0.009 ms). Each sample of a frame is one such wave;
the samples, their random numbers and the order of their sums are the megakernel's, so the
images agree (bit for bit on llvmpipe, tests/test_wavefront.py, and on the H100).

The megakernel runs instead (TracePass keeps it) for plugins without LIFT_PATH_STEPS, with
primary = "camera" (their random numbers start before the path), with splats, and where the
slots would not fit one storage buffer (llvmpipe: 128 MiB, about 840k pixels for pt).
$LIFT_GL_WAVEFRONT = on | off | faster | auto picks; auto is off. Until the seventh session
auto on a GPU timed both ways on the first frames and kept the faster (on an H100 the
wavefront, 4 vertices in the start kernel and 4 step dispatches, was 1.13-1.27x faster on
Lift's cornell-box and classroom and the Covered Dragon, 0.94x on the dining room, docs/gpu.md
"A wavefront trace pass"); since the megakernel takes pixels from a queue as its lanes' paths
end (passes/trace.py), it matched or beat the wavefront on all four (0.99-1.12x), so the
megakernel is the default and `faster` keeps that timing. The images are the same either way.
"""
from __future__ import annotations

import re

import moderngl

from .. import shaders
from ..errors import LiftError
from ..env_settings import env_choice
from .common import coherent_sampling_source, groups, tile_dispatch_size

WAVEFRONT_ENV_VAR = "LIFT_GL_WAVEFRONT"
SLOTS_BINDING, QUEUES_BINDING, CONTROL_BINDING = 11, 12, 14
MODE_START, MODE_STEP, MODE_TAIL, MODE_PROBE = 0, 1, 2, 3
# Measured on the H100 over Lift's three scenes and the Covered Dragon (docs/gpu.md): 4 vertices
# in the start kernel (through pt's first Russian roulette) then 4 step dispatches did best
# (frame x 1.24 / 0.94 / 1.27 / 1.13; wave8p4 1.22 / 0.90 / 1.28 / 1.09; no prefix 1.00 / 0.86 / 1.13 / 1.05).
DEFAULT_STEPS = 4  # step dispatches before the tail
DEFAULT_PREFIX = 4  # path vertices the start kernel runs before the first compaction
MAX_GROUPS_X = 32768  # an indirect dispatch's groups, split over y beyond this (GL's minimum limit: 65535)
_PATH_STEPS = re.compile(r"^\s*#\s*define\s+LIFT_PATH_STEPS\b", re.M)

# glMemoryBarrier between the wave's dispatches: storage (slots, queues, counts), image (the
# frame, read back by the next sample's wave) and command (the indirect dispatch's arguments).
WAVE_BARRIERS = 0x2000 | 0x20 | 0x40

# The control buffer: the live queue's length, the next queue's, which half of the queue
# buffer is live, a pad, then the indirect dispatch's arguments (ARGS_SOURCE).
CONTROL_WORDS = 8
ARGS_OFFSET = 16

WAVE_TEMPLATE = """
#ifdef LIFT_WAVE_BALLOT
#extension GL_ARB_shader_ballot : require
#extension GL_ARB_gpu_shader_int64 : require
#endif
layout(local_size_x = {group}) in;
#include "lift/host.glsl"
layout(rgba32f, binding = 0) uniform image2D u_frame_out;  // read back between samples
uniform usampler2D u_visibility;
uniform uint u_frame;
uniform uint u_seed;
uniform uint u_samples;
uniform uint u_sample_base;
uniform uint u_stream;
uniform vec2 u_jitter;
uniform uint u_wave_mode;    // 0 start, 1 step, 2 tail, 3 probe (lift_gl/passes/wavefront.py)
uniform uint u_wave_sample;  // which sample of this frame the wave runs
#ifdef LIFT_WAVE_MODE
#define WAVE_MODE LIFT_WAVE_MODE  // a program for one mode (WavefrontTrace's split option)
#else
#define WAVE_MODE u_wave_mode
#endif
#define WAVE_PREFIX {prefix}u  // path_steps of the start kernel (a constant: prefix 1 is the plain start)

// ---- plugin parameters ----
{params}
// ---- plugin ----
#include "{entry}"
// ---- host ----
#include "lift/primary_hit.glsl"
{rng_key}

struct WaveSlot {{
    PathState path;
    Rng rng;
    uint cut;  // the driver's loop limit cut one of this pixel's dispatches short this frame
}};
layout(std430, binding = {slots}) buffer WaveSlots {{ WaveSlot wave_slots[]; }};
// Two queues in one buffer, its halves taking turns (wave_parity): the live one and the next.
layout(std430, binding = {queues}) buffer WaveQueues {{ uint wave_queues[]; }};
layout(std430, binding = {control}) buffer WaveControl {{ uint wave_count_in; uint wave_count_out; uint wave_parity; }};

// A place in the next queue for each invocation with `alive`; with ballots one atomic a subgroup.
uint wave_append(bool alive) {{
#ifdef LIFT_WAVE_BALLOT
    uvec2 want = unpackUint2x32(ballotARB(alive));
    uvec2 below = want & unpackUint2x32(gl_SubGroupLtMaskARB);
    uint total = uint(bitCount(want.x) + bitCount(want.y));
    uint base = 0u;
    uvec2 running = unpackUint2x32(ballotARB(true));
    uint leader = running.x != 0u ? uint(findLSB(running.x)) : 32u + uint(findLSB(running.y));
    if (gl_SubGroupInvocationARB == leader && total > 0u) base = atomicAdd(wave_count_out, total);
    base = readFirstInvocationARB(base);
    return base + uint(bitCount(below.x) + bitCount(below.y));
#else
    return alive ? atomicAdd(wave_count_out, 1u) : 0u;
#endif
}}

void main() {{
    if (WAVE_MODE == 3u) {{  // the host asks the slot's size: slot_stride()
        if (gl_LocalInvocationIndex == 0u) wave_count_in = uint(wave_slots.length());
        return;
    }}
    uvec2 size = uvec2(u_resolution);
    uint index;
    PathState path;
    Rng rng;
    uint cut = 0u;
    bool running = true;
#ifdef HAS_MOTION
    g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
    if (WAVE_MODE == 0u) {{
        // the megakernel's pixel tiles, so that neighbouring pixels share a subgroup
        // (moved and interleaved with coherent sampling)
        ivec2 place = lift_tile_pixel(gl_WorkGroupID.xy,
                                      uvec2(gl_LocalInvocationIndex % {tile_x}u, gl_LocalInvocationIndex / {tile_x}u),
                                      uvec2({tile_x}u, {tile_y}u));
        uvec2 pixel = uvec2(max(place, ivec2(0)));
        running = all(greaterThanEqual(place, ivec2(0))) && all(lessThan(pixel, size));
        index = pixel.y * size.x + pixel.x;
        if (running) {{
            Ray primary_ray = camera_ray(vec2(pixel) + u_jitter);
            Hit primary_hit = gbuffer_hit(ivec2(pixel), primary_ray);
            uint s = u_wave_sample;
            rng = rng_init_pixel_sample(lift_rng_key(pixel), u_frame, s, u_sample_base + s, u_seed, u_stream);
            path = path_start(primary_ray, primary_hit);
            if (s > 0u) cut = wave_slots[index].cut;
        }}
    }} else {{
        uint id = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * {group}u + gl_LocalInvocationIndex;
        running = id < wave_count_in;
        if (running) {{
            index = wave_queues[wave_parity * size.x * size.y + id];
            path = wave_slots[index].path;
            rng = wave_slots[index].rng;
            cut = wave_slots[index].cut;
        }}
    }}
    bool alive = false;
    if (running) {{
        uint vertices = 0u;
        do {{
            alive = path_step(path, rng);
            ++vertices;
        }} while (alive && (WAVE_MODE == 2u || (WAVE_MODE == 0u && vertices < WAVE_PREFIX)));
        // ---- the driver's loop budget (see lift_gl/passes/trace.py) ----
        uint probe = 0u;
        for (uint i = 0u; i < 2u; ++i) probe += 1u;
        if (probe < 2u) cut = 1u;
    }}
    uint place = wave_append(alive);
    if (!running) return;
    if (alive) {{
        wave_slots[index].path = path;
        wave_slots[index].rng = rng;
        wave_slots[index].cut = cut;
        wave_queues[(WAVE_MODE == 0u ? 0u : 1u - wave_parity) * size.x * size.y + place] = index;
    }} else {{
        ivec2 pixel = ivec2(index % size.x, index / size.x);
        vec4 sum = u_wave_sample == 0u ? vec4(0.0) : imageLoad(u_frame_out, pixel);
        vec3 L = path_radiance(path);
        if (lift_is_finite(L)) {{
            sum.rgb += L;
            sum.a += 1.0;
        }} else {{
            atomicAdd(stats[0], 1u);  // dropped and counted, never averaged in
        }}
        imageStore(u_frame_out, pixel, sum);
        if (u_wave_sample + 1u < u_samples) wave_slots[index].cut = cut;
        else if (cut != 0u) atomicAdd(stats[4], 1u);  // once a pixel-frame, as the megakernel counts
    }}
#ifdef LIFT_COUNT_RAYS
    if (lift_rays_traced > 0u) {{
        uint before = atomicAdd(stats[2], lift_rays_traced);
        if (before > 0xffffffffu - lift_rays_traced) atomicAdd(stats[3], 1u);
    }}
#endif
}}
"""

# The next dispatch: the queue just written becomes the live one, the next one starts empty.
ARGS_SOURCE = f"""
#version 430
layout(local_size_x = 1) in;
layout(std430, binding = {CONTROL_BINDING}) buffer WaveControl {{
    uint wave_count_in; uint wave_count_out; uint wave_parity; uint pad; uvec4 wave_dispatch; }};
uniform uint u_group;
uniform bool u_first;  // after the start kernel
void main() {{
    uint n = wave_count_out;
    uint groups = (n + u_group - 1u) / u_group;
    uint x = min(groups, {MAX_GROUPS_X}u);
    wave_count_in = n;
    wave_count_out = 0u;
    wave_parity = u_first ? 0u : 1u - wave_parity;  // the start kernel writes the first half
    wave_dispatch = uvec4(x, x == 0u ? 0u : (groups + x - 1u) / x, 1u, 0u);
}}
"""
assert ARGS_OFFSET == 16  # wave_dispatch's offset in the block above


class SlotsTooBig(LiftError):
    """The frame's path slots would not fit one storage buffer: the megakernel runs instead."""


def wavefront_mode(ctx: moderngl.Context) -> str:
    """$LIFT_GL_WAVEFRONT resolved: "on", "off" (auto: since the megakernel takes pixels from a
    queue as its paths end, passes/trace.py, it matched or beat the wavefront on all four scenes
    measured on an H100, docs/gpu.md), or "faster" (the trace pass times both ways on its first
    frames and keeps the faster, TracePass)."""
    mode = env_choice(WAVEFRONT_ENV_VAR, ("on", "off", "faster"))
    return "off" if mode == "auto" else mode


def path_steps(source_text: str) -> bool:
    """Whether a program's plugin advances its paths a vertex at a time (defines LIFT_PATH_STEPS)."""
    return _PATH_STEPS.search(source_text) is not None


def fallback_reason(plugin, source_text: str, defines: dict) -> str | None:
    """Why this program runs as the megakernel whatever the setting (None: it need not)."""
    if not path_steps(source_text):
        return f"plugin {plugin.name} does not define LIFT_PATH_STEPS"
    if plugin.primary != "gbuffer":
        return "primary = \"camera\": the random numbers of the camera ray come before the path"
    if plugin.splats:
        return "a plugin with splats"
    return None


class WavefrontTrace:
    """The wavefront executor of one trace program: fills `frame` as the megakernel would."""

    def __init__(self, ctx: moderngl.Context, size, plugin, defines: dict, params: str, local_size, steps=None,
                 ballot: bool | None = None, split: bool = False, prefix: int | None = None):
        """steps: step dispatches before the tail; prefix: path vertices (path_steps) the start
        kernel runs before its paths are compacted (at least 1); ballot: one atomic a
        subgroup for the queue (None: where the driver has ARB_shader_ballot and 64-bit
        integers); split: a program
        for each mode (start, step, tail) instead of one with the mode a uniform."""
        self.ctx = ctx
        self.size = size
        self.dispatch_size = tile_dispatch_size(defines, size, local_size)   # (coherent sampling's offset tiles)
        self.tile = local_size
        self.group = local_size[0] * local_size[1]
        self.steps = DEFAULT_STEPS if steps is None else int(steps)
        self.prefix = DEFAULT_PREFIX if prefix is None else int(prefix)
        if self.prefix < 1:
            raise LiftError(f"the wavefront's start kernel runs at least one path vertex, not {self.prefix}")
        defines = dict(defines)
        has_ballot = "GL_ARB_shader_ballot" in ctx.extensions and "GL_ARB_gpu_shader_int64" in ctx.extensions
        self.ballot = has_ballot if ballot is None else ballot and has_ballot
        if self.ballot:
            defines["LIFT_WAVE_BALLOT"] = True
        text = WAVE_TEMPLATE.format(group=self.group, tile_x=local_size[0], tile_y=local_size[1], params=params,
                                    rng_key=coherent_sampling_source(local_size), prefix=self.prefix,
                                    entry=plugin.entry_path.as_posix(), slots=SLOTS_BINDING,
                                    queues=QUEUES_BINDING, control=CONTROL_BINDING)
        self.source = shaders.assemble(text, defines, include_dirs=[plugin.folder],
                                       main_name=f"<{plugin.name} wavefront>")
        self.program = shaders.compile_compute(ctx, self.source)
        self.args = ctx.compute_shader(ARGS_SOURCE)
        self.args["u_group"].value = self.group
        self.slot_bytes = slot_stride(ctx, self.program)
        pixels = size[0] * size[1]
        limit = ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]
        if self.slot_bytes * pixels > limit:
            self.program.release()
            self.args.release()
            raise SlotsTooBig(f"{self.slot_bytes * pixels / 2**20:.0f} MiB of path slots ({self.slot_bytes} bytes a "
                              f"pixel) over the {limit / 2**20:.0f} MiB a storage buffer may hold here")
        # the programs of the start, step and tail modes
        self.modes = [self.program] * 3
        if split:
            self.program.release()
            self.modes = [shaders.compile_compute(ctx, shaders.assemble(
                text, dict(defines, LIFT_WAVE_MODE=f"{mode}u"), include_dirs=[plugin.folder],
                main_name=f"<{plugin.name} wavefront, mode {mode}>")) for mode in (MODE_START, MODE_STEP, MODE_TAIL)]
            self.program = None
        self.programs = list(dict.fromkeys(self.modes))
        self.slots = ctx.buffer(reserve=self.slot_bytes * pixels)
        self.queues = ctx.buffer(reserve=2 * 4 * pixels)
        self.control = ctx.buffer(reserve=4 * CONTROL_WORDS)  # zeros: the next queue starts empty

    @property
    def memory_bytes(self) -> int:
        return self.slots.size + self.queues.size + self.control.size

    def run(self, frame, samples: int, hook=None) -> None:
        """Few GL calls a step (the queue's halves and lengths change on the GPU): the CPU's
        commands keep ahead of short steps. hook(what, sample, step, dispatch), where given,
        makes each dispatch (benchmarks/gpu.py wavefront --profile times them)."""
        ctx, args = self.ctx, self.args
        start, step, tail = self.modes
        generic = start is step
        w, h = self.size
        frame.bind_to_image(0, read=True, write=True)
        self.slots.bind_to_storage_buffer(SLOTS_BINDING)
        self.queues.bind_to_storage_buffer(QUEUES_BINDING)
        self.control.bind_to_storage_buffer(CONTROL_BINDING)
        first = args["u_first"]
        dispatch = hook or (lambda what, s, k, go: go())
        for s in range(samples):
            for prog in self.programs:
                prog["u_wave_sample"].value = s
            if generic:
                start["u_wave_mode"].value = MODE_START
            dispatch("start", s, 0, lambda: start.run(*groups(*self.dispatch_size, self.tile)))
            for k in range(self.steps + 1):
                ctx.memory_barrier(WAVE_BARRIERS)
                if k < 2:
                    first.value = k == 0
                dispatch("args", s, k + 1, lambda: args.run(1, 1, 1))
                ctx.memory_barrier(WAVE_BARRIERS)
                prog = tail if k == self.steps else step
                if generic and (k == 0 or k == self.steps):
                    prog["u_wave_mode"].value = MODE_TAIL if k == self.steps else MODE_STEP
                dispatch("tail" if k == self.steps else "step", s, k + 1,
                         lambda: prog.run_indirect(self.control, ARGS_OFFSET))
            ctx.memory_barrier()  # all: the passes after this one read the frame as they like

    def release(self) -> None:
        for b in (*self.programs, self.args, self.slots, self.queues, self.control):
            b.release()


def slot_stride(ctx: moderngl.Context, program) -> int:
    """Bytes of one WaveSlot (the plugin's PathState, an Rng, a word) in std430. GLSL has no
    sizeof, so the program's probe mode writes the length() of the slot array over a buffer of
    known size, and the stride is the multiple of 4 that gives that length."""
    probe_bytes = 1 << 24
    probe = ctx.buffer(reserve=probe_bytes)
    out = ctx.buffer(reserve=4 * CONTROL_WORDS)
    probe.bind_to_storage_buffer(SLOTS_BINDING)
    out.bind_to_storage_buffer(CONTROL_BINDING)
    program["u_wave_mode"].value = MODE_PROBE
    program.run(1, 1, 1)
    ctx.memory_barrier()
    count = int.from_bytes(out.read()[:4], "little")
    probe.release()
    out.release()
    fits = [s for s in range(probe_bytes // (count + 1) + 1, probe_bytes // max(count, 1) + 1) if s % 4 == 0]
    if count <= 0 or len(fits) != 1:
        raise LiftError(f"the wavefront's slot array reported {count} slots in {probe_bytes} bytes")
    return fits[0]
