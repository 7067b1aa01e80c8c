"""Trace pass: runs a plugin's radiance estimate for every pixel.

inputs:  scene buffers, camera, G-buffer visibility (plugins with primary = "gbuffer")
outputs: frame (RGBA32F: sum of this frame's valid samples in rgb, their count in a);
         stats[0] counts samples dropped because they were NaN or infinite;
         stats[2..3] count the rays traced (64 bits), with LIFT_COUNT_RAYS defined;
         with `splats = true` in the manifest, the frame also receives the splats
         (passes/splat.py), and stats[1] counts splats dropped as NaN or infinite;
         stats[4] counts pixel-frames whose paths the driver's loop limit cut short

Mesa's llvmpipe ends every loop of a shader invocation once 65535 loop iterations have run
in it, all loops together (BVH traversal steps, bounces, the sample loop), and says nothing:
a path of 1000 bounces through a deep BVH silently loses its tail. A probe loop after the
samples cannot run once that budget is spent, which is how the host notices and counts it.

The host writes main(): the pixel loop, per-sample seeds, the primary hit (rebuilt exactly
from the G-buffer's primitive id, or traced from the camera), the NaN/Inf guard, the output.
With primary = "camera" it also picks each sample's point on the lens and, in scenes with
motion (HAS_MOTION), its moment in the shutter interval (g_ray_time, lift/bvh.glsl).
The plugin writes only `vec3 radiance(Ray ray, Hit hit, inout Rng rng)`. A plugin that also
defines LIFT_PATH_STEPS (pt: PathState, path_start, path_step, path_radiance) lets main() run
the several samples of a frame (samples_per_frame > 1, G-buffer primary) as one loop over
their vertices, each lane starting its next sample when its path ends: on a CPU rasterizer
the 8 lanes of a SIMD batch otherwise wait for the longest path of the batch, sample after
sample (docs/cpu-speed.md). The samples and their random numbers are the same either way.

How the program runs is the options' choice (lift_gl/options.py, resolved for the device):
- bvh_stack: the BVH traversal stack in shared memory with 8x4 work groups
  (LIFT_BVH_SHARED_STACK, shaders/lift/bvh.glsl), or in a local array (8x8 groups on CPU
  rasterizers); on an H100 shared stacks in 8x4 groups made pt's trace 2.6-3.6x faster than
  8x8 groups with local stacks (docs/gpu.md).
- pixel_queue: a plugin with LIFT_PATH_STEPS runs a megakernel whose lanes take their next
  pixel from a queue as soon as their pixel's paths end (path regeneration, LIFT_PIXEL_QUEUE),
  instead of idling until the longest path of their warp ends: the same image.
- carry_paths: that megakernel is built with the carry code (paths under way when the queue
  runs out go on in the next frame's dispatch, passes/carry.py); `faster` builds it on a
  render's first frame that may park and times the two in blocks of frames (CarryTuning),
  keeping the faster.
"""
from __future__ import annotations

import re
import time

import moderngl

from .. import shaders
from ..errors import ShaderError
from ..options import Device, Options, ResolvedOptions, Workload, resolve, work_group
from ..plugins import GLSL_TYPES, Plugin
from .carry import CARRY_TUNING_FRAMES, CarriedPaths, CarryTuning
from .common import LOCAL_SIZE, coherent_sampling_source, groups, set_uniforms, tile_dispatch_size
from .splat import SplatBuffer, splat_defines

# The carry code is timed (CarryTuning) from TUNING_DELAY_S after the first frame: an idle GPU's
# clock takes a few hundred milliseconds to rise (report/gpu_clock.py), and a choice timed
# from a first frame at the idle clock kept the slower way. Where NVML reads the SM clock
# (report/gpu_clock.py), a frame is timed only once the clock is at TUNING_CLOCK of its
# maximum, waiting at most TUNING_CLOCK_WAIT_S: with the delay alone one process of four still
# timed the dining room's first frames at 2-4x their steady time.
TUNING_DELAY_S = 0.3
TUNING_CLOCK = 0.9
TUNING_CLOCK_WAIT_S = 3.0
_PATH_STEPS = re.compile(r"^\s*#\s*define\s+LIFT_PATH_STEPS\b", re.M)

MAIN_TEMPLATE = """
#if defined(LIFT_SPLATS) && !defined(LIFT_SPLATS_CAS)
#extension GL_NV_shader_atomic_float : require
#endif
layout(local_size_x = {local_x}, local_size_y = {local_y}) in;
#include "lift/host.glsl"
#include "lift/splat.glsl"
layout(rgba32f, binding = 0) uniform writeonly image2D u_frame_out;
#ifdef PRIMARY_GBUFFER
uniform usampler2D u_visibility;
#endif
uniform uint u_frame;
uniform uint u_seed;
uniform uint u_samples;
uniform uint u_sample_base;  // samples per pixel of this frame's stream accumulated before it
uniform uint u_stream;       // which half of the frames (error estimate) this one belongs to
uniform vec2 u_jitter;  // this frame's subpixel offset (G-buffer primary)
#if !defined(PRIMARY_GBUFFER) && defined(HAS_PIXEL_FILTER)
#include "lift/pixel_filter.glsl"
#endif

// ---- plugin parameters ----
{params}
#ifdef LIFT_COHERENT_SAMPLING
// Coherent sampling gives `rng` to the pixels of a tile alike; this holds the pixel's own
// numbers for the sample radiance() is called for (set by lift_sample_rng), for a plugin that
// wants some draws unshared: bdpt's light subpaths. Not for path_step(), which may resume
// another pixel's path.
Rng lift_own_rng;
#endif
// ---- plugin ----
#include "{entry}"
// ---- host ----
#ifdef PRIMARY_GBUFFER
#include "lift/primary_hit.glsl"
#endif

{rng_key}
// The random numbers of this frame's sample s of a pixel.
Rng lift_sample_rng(ivec2 pixel, uint s) {{
#ifdef LIFT_COHERENT_SAMPLING
    lift_own_rng = rng_init_pixel_sample(uvec2(pixel), u_frame, s, u_sample_base + s, u_seed ^ 0x68bc21ebu, u_stream);
#endif
    return rng_init_pixel_sample(lift_rng_key(uvec2(pixel)), u_frame, s, u_sample_base + s, u_seed, u_stream);
}}

// A sample's radiance into its pixel's sum; a NaN or Inf one is dropped and counted, never
// averaged in.
void lift_add_sample(vec3 L, inout vec3 sum, inout float valid) {{
    if (lift_is_finite(L)) {{
        sum += L;
        valid += 1.0;
    }} else {{
        atomicAdd(stats[0], 1u);
    }}
}}

// What an invocation reports once, at its end: its rays (LIFT_COUNT_RAYS: a 64-bit count in two
// words, a carry into stats[3] when stats[2] wraps around) and whether the driver's loop budget
// cut its loops short (see lift_gl/passes/trace.py; a loop's first iteration always runs, so the
// probe needs two to tell: kept, but counted and reported).
void lift_report_invocation() {{
#ifdef LIFT_COUNT_RAYS
    if (lift_rays_traced > 0u) {{
        uint before = atomicAdd(stats[2], lift_rays_traced);
        if (before > 0xffffffffu - lift_rays_traced) atomicAdd(stats[3], 1u);
    }}
#endif
    uint probe = 0u;
    for (uint i = 0u; i < u_samples + 1u; ++i) probe += 1u;
    if (probe < u_samples + 1u) atomicAdd(stats[4], 1u);
}}

#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS) && defined(LIFT_PIXEL_QUEUE)
// Path regeneration (LIFT_PIXEL_QUEUE, GPUs; lift_gl/passes/trace.py): a lane takes its next
// pixel from this queue as soon as its pixel's paths have ended, instead of idling until the
// longest path of its warp ends. Pixels are numbered tile by tile (one work group's shape), so
// a warp's first 32 are one tile. The host zeroes the queue before each dispatch.
layout(std430, binding = 13) coherent buffer LiftPixelQueue {{ uint lift_queue_next; }};

#ifdef LIFT_CARRY_PATHS
// Paths carried into the next frame (LIFT_CARRY_PATHS; lift_gl/passes/carry.py). Once the
// queue has run out, a lane whose path is still under way parks it in one half of this buffer
// and ends, instead of the frame waiting while the longest paths run alone on a few lanes. The
// next frame's lanes resume the parked paths before they take new pixels, run each to its end
// (a resumed path is never parked again) and write what they finish to u_late_out, with this
// frame's tag in u_late_tag_out; the accumulation adds a late texel whose tag is the frame's
// (an older one is stale: nothing clears the image) to the frame: per pixel, samples and
// their count (alpha), so a sample that lands a frame late is counted once, and the mean stays
// exact.
struct LiftParkedPath {{ PathState path; Rng rng; ivec2 pixel; uint s; Ray primary_ray; Hit primary_hit; }};
layout(std430, binding = 15) coherent buffer LiftCarry {{
    uint lift_carry_count[2];  // paths parked in each half (may pass the capacity: the extra ones ran on)
    uint lift_carry_next[2];   // the next one to resume
    LiftParkedPath lift_carried[];
}};
layout(rgba32f, binding = 1) uniform writeonly image2D u_late_out;
layout(r32ui, binding = 2) uniform writeonly uimage2D u_late_tag_out;
uniform uint u_late_tag;        // this frame's tag (the host's frame count since the carry began, from 1)
uniform uint u_carry_side;      // this frame parks into half u_carry_side and resumes the other's
uniform uint u_park;            // 0: every path runs to its end (a render's last frame)
// Paths a half holds: the host sizes the buffer without knowing PathState's layout.
uint lift_carry_capacity() {{ return uint(lift_carried.length()) / 2u; }}
// A resumed path's pixel: its samples and this frame's tag.
void lift_store_late(ivec2 pixel, vec3 sum, float valid) {{
    imageStore(u_late_out, pixel, vec4(sum, valid));
    imageStore(u_late_tag_out, pixel, uvec4(u_late_tag));
}}
#ifdef LIFT_CARRY_PARK_ALWAYS
#define LIFT_QUEUE_RAN_OUT true   // carry_paths=always: every new path parks after its first vertex (tests)
#else
#define LIFT_QUEUE_RAN_OUT (lift_queue_next >= items)
#endif
#endif

void lift_trace_pixel_queue() {{
    const uint tile_w = {local_x}u, tile_h = {local_y}u, group = tile_w * tile_h;
    uvec2 tiles = lift_tile_groups(ivec2(u_resolution), uvec2(tile_w, tile_h));   // (moved, interleaved: coherent sampling)
    uint items = tiles.x * tiles.y * group;
#ifdef HAS_MOTION
    g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
    ivec2 pixel = ivec2(0);
    Ray primary_ray;
    Hit primary_hit;
    Rng rng;
    PathState path;
    uint s = 0u;
    vec3 sum = vec3(0.0);
    float valid = 0.0;
    bool busy = false;  // a pixel taken whose samples are not all done
    bool late = false;  // that pixel's sample was parked in the previous frame: its samples go to u_late_out
    while (true) {{
#ifdef LIFT_CARRY_PATHS
        // (the parked count read at every take: reading it once a lane, with a flag once the
        // list was taken, ran the trace 1.03-1.3x slower on an H100, docs/gpu.md)
        if (!busy) {{
            uint side = 1u - u_carry_side;
            uint parked = min(lift_carry_count[side], lift_carry_capacity());
            if (lift_carry_next[side] < parked) {{
                uint k = atomicAdd(lift_carry_next[side], 1u);
                if (k < parked) {{
                    LiftParkedPath c = lift_carried[side * lift_carry_capacity() + k];
                    path = c.path;
                    rng = c.rng;
                    pixel = c.pixel;
                    s = c.s;
                    primary_ray = c.primary_ray;
                    primary_hit = c.primary_hit;
                    sum = vec3(0.0);
                    valid = 0.0;
                    late = true;
                    busy = true;
                }}
            }}
        }}
#endif
        if (!busy) {{
            late = false;
            uint item = atomicAdd(lift_queue_next, 1u);
            if (item >= items) break;
            uint tile = item / group, lane = item % group;
            pixel = lift_tile_pixel(uvec2(tile % tiles.x, tile / tiles.x), uvec2(lane % tile_w, lane / tile_w),
                                    uvec2(tile_w, tile_h));
            if (!pixel_in_image(pixel)) continue;
            s = 0u;
            sum = vec3(0.0);
            valid = 0.0;
            if (u_samples == 0u) {{
                imageStore(u_frame_out, pixel, vec4(0.0));
                continue;
            }}
            // the megakernel's samples of this pixel, in its order: the same sums
            primary_ray = camera_ray(vec2(pixel) + u_jitter);
            primary_hit = gbuffer_hit(pixel, primary_ray);
            rng = lift_sample_rng(pixel, 0u);
            path = path_start(primary_ray, primary_hit);
            busy = true;
        }}
        if (path_step(path, rng)) {{
#ifdef LIFT_CARRY_PATHS
            if (u_park != 0u && !late && LIFT_QUEUE_RAN_OUT) {{
                uint k = atomicAdd(lift_carry_count[u_carry_side], 1u);
                if (k < lift_carry_capacity()) {{
                    lift_carried[u_carry_side * lift_carry_capacity() + k] =
                        LiftParkedPath(path, rng, pixel, s, primary_ray, primary_hit);
                    imageStore(u_frame_out, pixel, vec4(sum, valid));  // the samples it finished
                    busy = false;
                    break;
                }}
            }}
#endif
            continue;
        }}
        lift_add_sample(path_radiance(path), sum, valid);
        ++s;
        if (s < u_samples) {{
            rng = lift_sample_rng(pixel, s);
            path = path_start(primary_ray, primary_hit);
            continue;
        }}
#ifdef LIFT_CARRY_PATHS
        if (late) lift_store_late(pixel, sum, valid);
        else
#endif
        imageStore(u_frame_out, pixel, vec4(sum, valid));
        busy = false;
    }}
#ifdef LIFT_LOOP_LIMITED
    // Still busy: the driver's loop limit ended the loop (llvmpipe: 65535 iterations an
    // invocation; lift_report_invocation counts it). The samples done so far, as the plain
    // megakernel keeps them. (Every pixel is taken: a dispatch has a lane for each, and a
    // lane takes its first pixel before its loop can run out.) Only where a driver cuts
    // loops: on an H100 this one store made the cornell-box's trace 1.7x slower.
#ifdef LIFT_CARRY_PATHS
    if (busy && late) lift_store_late(pixel, sum, valid);
    else
#endif
    if (busy) imageStore(u_frame_out, pixel, vec4(sum, valid));
#endif
}}
#endif

void main() {{
#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS) && defined(LIFT_PIXEL_QUEUE)
    lift_trace_pixel_queue();
    lift_report_invocation();
    return;
#endif
    ivec2 pixel = lift_tile_pixel(gl_WorkGroupID.xy, gl_LocalInvocationID.xy, gl_WorkGroupSize.xy);  // a group: a tile
    if (!pixel_in_image(pixel)) return;
    vec3 sum = vec3(0.0);
    float valid = 0.0;
#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS)
    // A plugin whose paths advance a vertex at a time: one loop over all the vertices of all
    // this frame's samples, a lane starting its next sample as soon as its path ends. (A loop
    // per sample keeps the SIMD lanes of a CPU rasterizer waiting for the longest path of
    // their batch.) The samples of a frame share its G-buffer hit, as in the loop below.
#ifdef HAS_MOTION
    g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
    Ray primary_ray = camera_ray(vec2(pixel) + u_jitter);
    Hit primary_hit = gbuffer_hit(pixel, primary_ray);
    uint s = 0u;
    Rng rng = lift_sample_rng(pixel, 0u);
    PathState path = path_start(primary_ray, primary_hit);
    while (s < u_samples) {{
        if (path_step(path, rng)) continue;
        lift_add_sample(path_radiance(path), sum, valid);
        ++s;
        rng = lift_sample_rng(pixel, s);
        path = path_start(primary_ray, primary_hit);
    }}
#else
    for (uint s = 0u; s < u_samples; ++s) {{
        Rng rng = lift_sample_rng(pixel, s);
        Ray ray;
        Hit hit;
#ifdef PRIMARY_GBUFFER
#ifdef HAS_MOTION
        g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
        ray = camera_ray(vec2(pixel) + u_jitter);
        hit = gbuffer_hit(pixel, ray);
#else
        vec2 subpixel = rng_next2(rng);
#ifdef HAS_PIXEL_FILTER
        subpixel = pixel_filter_offset(subpixel);  // drawn from the scene's pixel filter
#endif
        vec2 lens = rng_next2(rng);
#ifdef HAS_MOTION
        g_ray_time = rng_next(rng);  // uniform over the shutter: a box shutter
#endif
        ray = camera_ray_lens(vec2(pixel) + subpixel, lens);
        trace_closest(ray, hit);
#endif
        lift_add_sample(radiance(ray, hit, rng), sum, valid);
    }}
#endif
    lift_report_invocation();
    imageStore(u_frame_out, pixel, vec4(sum, valid));
}}
"""


PIXEL_QUEUE_BINDING = 13


def reset_pixel_queue(ctx: moderngl.Context, queue: moderngl.Buffer) -> None:
    """Zero the queue and bind it for the next dispatch. A barrier of every kind first: the
    write must not land before the previous dispatch's last take from the queue, nor may the
    next dispatch start while that one runs. (On an H100, a queue that each dispatch's last
    work group emptied itself ran some frames 4-15x slower, its resets landing in the middle of
    a dispatch; zeroed by the host after a buffer-update barrier only, a few hundred pixels of
    frames after the first kept the frame before's values, differently from run to run.)"""
    ctx.memory_barrier()
    queue.write(b"\0\0\0\0")
    queue.bind_to_storage_buffer(PIXEL_QUEUE_BINDING)


def path_steps(source_text: str) -> bool:
    """Whether a program's plugin advances its paths a vertex at a time (defines LIFT_PATH_STEPS)."""
    return _PATH_STEPS.search(source_text) is not None


def plugin_path_steps(plugin: Plugin, defines: dict) -> bool:
    """Whether the plugin's paths go a vertex at a time from the G-buffer, which the pixel
    queue needs (known from its source: assembled here to read it, the text only)."""
    if plugin.language != "glsl" or plugin.primary != "gbuffer":
        return False
    defines = dict(defines, PRIMARY_GBUFFER=True)
    return path_steps(shaders.assemble(generate_main(plugin), defines, include_dirs=[plugin.folder],
                                       main_name=f"<{plugin.name} host main>").text)


def param_declarations(plugin: Plugin) -> str:
    return "\n".join(f"uniform {GLSL_TYPES[p.type]} {p.name};  // {' '.join(p.help.split())}"
                     for p in plugin.params.values())


def generate_main(plugin: Plugin, local_size: tuple[int, int] = (LOCAL_SIZE, LOCAL_SIZE)) -> str:
    return MAIN_TEMPLATE.format(local_x=local_size[0], local_y=local_size[1], params=param_declarations(plugin),
                                rng_key=coherent_sampling_source(local_size),
                                entry=plugin.entry_path.as_posix())


def param_uniforms(plugin: Plugin, values: dict) -> dict:
    out = {}
    for name, p in plugin.params.items():
        value = values.get(name, p.default)
        out[name] = tuple(value) if p.type == "color" else value
    return out


class TracePass:
    name = "trace"
    inputs = ("scene", "camera", "visibility?")
    outputs = ("frame",)

    def __init__(self, ctx: moderngl.Context, size, plugin: Plugin, defines: dict,
                 choices: ResolvedOptions | None = None):
        """`choices`: the resolved options (lift_gl/options.py: pixel_queue, bvh_stack,
        carry_paths); None: the defaults, resolved for this device and plugin."""
        self.ctx = ctx
        self.size = size
        self.plugin = plugin
        if choices is None:
            choices = resolve(Options(), Device.of(ctx), Workload(path_steps=plugin_path_steps(plugin, defines),
                                                                   splats=plugin.splats))
        defines = dict(defines)
        if plugin.primary == "gbuffer":
            defines["PRIMARY_GBUFFER"] = True
        self.splats = None
        if plugin.splats:
            defines.update(splat_defines(ctx))
            self.splats = SplatBuffer(ctx, size)
            self.outputs = ("frame (with splats)",)
        # the megakernel's pixel queue (MAIN_TEMPLATE): a plugin whose paths go a vertex at a time
        queued = choices["pixel_queue"] == "on"
        if queued:
            defines["LIFT_PIXEL_QUEUE"] = True
            if choices.device.software:   # CPU rasterizers (llvmpipe) end long-running loops
                defines["LIFT_LOOP_LIMITED"] = True
        # where the BVH stack lives (renderer.explain says it)
        self.shared_stack = choices["bvh_stack"] == "shared"
        self.local_size = work_group(choices["bvh_stack"], choices.device)
        if self.shared_stack:
            defines["LIFT_BVH_SHARED_STACK"] = self.local_size[0] * self.local_size[1]
        # paths still under way when the queue runs out go on in the next frame (passes/carry.py)
        self.carry = None
        carry = choices["carry_paths"] if queued else "off"
        carry_defines = dict(defines, LIFT_CARRY_PATHS=True)
        if carry == "always":
            carry_defines["LIFT_CARRY_PARK_ALWAYS"] = True
        if carry in ("on", "always"):
            defines = carry_defines
            self.carry = self._carried_paths()
        # faster: the megakernel with the carry code is built on a render's first frame that may
        # park, and the two are timed on the frames after it (run, CarryTuning)
        self.carry_tuning = CarryTuning(carry_defines) if carry == "faster" else None
        self.carry_tuned_ms = None     # once chosen: each way's frame ms (CarryTuning.frame_ms)
        self.carry_tuning_blocks_ms = None   # and each of its blocks' (CarryTuning.block_ms)
        self.carry_fallback = None     # why the carry code could not be timed
        self._resumed = False          # the last dispatch resumed parked paths (late)
        self._carry_leaving = False    # the plain megakernel was kept: the carry buffers go next frame
        self.defines = defines         # what the megakernel was built with (benchmarks rebuild it from them)
        self.source = self._megakernel_source(defines)
        self.program = shaders.compile_compute(ctx, self.source)
        self.pixel_queue = ctx.buffer(reserve=4) if queued else None
        self.frame = ctx.texture(size, 4, dtype="f4")
        self._tuning_from = None  # when the carry code's timed frames may start (TUNING_DELAY_S)
        self._tuning_clock = None  # the GPU's SM clock reader (NVML), made when tuning starts
        self._clock_low_since = None  # when it first read low (TUNING_CLOCK_WAIT_S)

    @property
    def late(self):
        """Samples that landed a frame late (paths this frame resumed), which the accumulation
        adds to the frame: (image, tag image, this frame's tag), or None when it resumed none."""
        if self.carry is None or not self._resumed:
            return None
        return self.carry.late, self.carry.late_tag, self.carry.tag

    def _megakernel_source(self, defines: dict):
        """The megakernel's source with these defines (its work groups, the plugin's main)."""
        return shaders.assemble(generate_main(self.plugin, self.local_size), defines,
                                include_dirs=[self.plugin.folder], main_name=f"<{self.plugin.name} host main>")

    def _carried_paths(self) -> CarriedPaths:
        return CarriedPaths(self.ctx, self.size, int(self.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)))

    def discard_parked(self) -> None:
        """Forget the paths the last frame parked (the camera moved, accumulation restarted)."""
        if self.carry is not None:
            self.carry.discard()
        if self.carry_tuning is not None:
            self.carry_tuning.abort()

    def run(self, uniforms: dict, visibility=None, park: bool = False, frames_left: int | None = None) -> None:
        """One frame. `park`: paths still under way once the pixel queue has run out may be
        parked for the next frame's dispatch (passes/carry.py; where carrying is on), which
        must then be run with the same camera; the default runs every path to its end.
        `frames_left`: the render's frames from this one on, where known (a render too short to
        time the carry code does not build it)."""
        if self._carry_leaving:   # the carry code lost its timing: its buffers, once read
            self._carry_leaving = False
            self.carry.release()
            self.carry = None
        if self.carry_tuning is not None:
            self._run_carry_tuning(uniforms, visibility, park, frames_left)
            return
        self._run(uniforms, visibility, park)

    def _run_carry_tuning(self, uniforms: dict, visibility, park: bool, frames_left: int | None = None) -> None:
        """A frame while the carry code's worth is being timed (carry_paths=faster):
        frames that may park run in blocks of either megakernel (CarryTuning), a block's frames
        but its first and last timed between two finishes; the others, and those before the
        clock is up, run the plain one untimed (or the carrying one, to finish paths the frame
        before parked)."""
        t = self.carry_tuning
        too_short = t.program is None and frames_left is not None and frames_left < CARRY_TUNING_FRAMES
        if not park or too_short or (t.way is None and not self._ready_to_time()):
            t.abort()
            waiting = self.carry is not None and self.carry.parked
            self._run(uniforms, visibility, False, program=t.program if waiting else None)
            return
        if t.program is None:   # built now, and its first dispatch (first-use costs) untimed
            t.source = self._megakernel_source(t.defines)
            try:
                t.program = shaders.compile_compute(self.ctx, t.source)
            except ShaderError as exc:   # a driver that rejects the carry code: the plain megakernel stays
                self.carry_tuning = None
                self.carry_fallback = f"the megakernel with the carry code did not compile: {exc}"
                self._run(uniforms, visibility, False)
                return
            self.carry = self._carried_paths()
        if not t.warmed:
            t.warmed = True
            self._run(uniforms, visibility, False, program=t.program)
            return
        if t.way is None:
            t.start()
        last = t.last()
        self._run(uniforms, visibility, t.parks(park), program=t.program if t.way == "carry" else None)
        t.frames += 1
        if t.clock_due():
            self.ctx.finish()
            t.clock(time.perf_counter())
        if last and t.end():
            self._keep_carry(t)

    def _keep_carry(self, t: CarryTuning) -> None:
        """The faster way's megakernel becomes the trace program; the other's is released."""
        self.carry_tuning = None
        self.carry_tuned_ms = t.frame_ms()
        self.carry_tuning_blocks_ms = t.block_ms()   # for benchmarks
        if t.faster() == "carry":
            self.program.release()
            self.program, self.source, self.defines = t.program, t.source, t.defines
        else:   # every block ends with its paths done: nothing is parked now
            t.program.release()
            self._carry_leaving = True   # its late image still holds this frame's samples

    def _ready_to_time(self) -> bool:
        """Whether a tuning frame may be timed: TUNING_DELAY_S after the first, and the clock up."""
        if TUNING_DELAY_S > 0:
            now = time.perf_counter()
            if self._tuning_from is None:
                self._tuning_from = now + TUNING_DELAY_S
            if now < self._tuning_from:
                return False
        return self._clock_is_up()

    def _clock_is_up(self) -> bool:
        """Whether the SM clock reads at least TUNING_CLOCK of its maximum (true without NVML,
        and once it has read low for TUNING_CLOCK_WAIT_S)."""
        if self._tuning_clock is None:
            from ..report.gpu_clock import ClockReader
            self._tuning_clock = ClockReader(self.ctx.info.get("GL_RENDERER", ""))
        mhz, peak = self._tuning_clock.sm_mhz(), self._tuning_clock.max_sm_mhz()
        if mhz is None or not peak or mhz >= TUNING_CLOCK * peak:
            return True
        now = time.perf_counter()
        if self._clock_low_since is None:
            self._clock_low_since = now
        return now - self._clock_low_since >= TUNING_CLOCK_WAIT_S

    def _run(self, uniforms: dict, visibility, park: bool = False, program=None) -> None:
        """One dispatch: `program` a megakernel other than self.program (the carrying one while
        CarryTuning times it)."""
        self._resumed = False
        megakernel = program or self.program
        set_uniforms(megakernel, uniforms)
        sampler = megakernel.get("u_visibility", None) if visibility is not None else None
        if sampler is not None:
            visibility.use(location=0)
            sampler.value = 0
        self.frame.bind_to_image(0, read=False, write=True)
        if self.splats is not None:
            self.splats.bind()
        if self.pixel_queue is not None:
            reset_pixel_queue(self.ctx, self.pixel_queue)
        # the carrying megakernel: self.program where carrying is on, or the tuning's
        carries = self.carry is not None and (program is not None or self.carry_tuning is None)
        if carries:
            self.carry.before_dispatch(megakernel, park)
            self._resumed = self.carry.resumed
        megakernel.run(*groups(*tile_dispatch_size(self.defines, self.size, self.local_size), self.local_size))
        # The frame's image stores must be done before the accumulation loads them, and the next
        # frame's dispatch must not overwrite it under the accumulation: on an H100 the plain
        # megakernel without this barrier left a few thousand pixels of a 1080p frame after the
        # first with another value from run to run.
        self.ctx.memory_barrier()
        if self.splats is not None:
            self.splats.add_to(self.frame)

    def release(self) -> None:
        self.program.release()
        self.frame.release()
        if self.pixel_queue is not None:
            self.pixel_queue.release()
        if self.carry is not None:
            self.carry.release()
        if self.carry_tuning is not None and self.carry_tuning.program is not None:
            self.carry_tuning.program.release()
        if self.splats is not None:
            self.splats.release()
