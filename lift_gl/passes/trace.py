"""Trace pass: runs a plugin's radiance estimate for every pixel.

inputs:  scene buffers, camera, G-buffer visibility (plugins with primary = "gbuffer")
outputs: frame (RGBA32F: sum of this frame's valid samples in rgb, their count in a);
         stats[0] counts samples dropped because they were NaN or infinite;
         stats[2..3] count the rays traced (64 bits), with LIFT_COUNT_RAYS defined;
         with `splats = true` in the manifest, the frame also receives the splats
         (passes/splat.py), and stats[1] counts splats dropped as NaN or infinite;
         stats[4] counts pixel-frames whose paths the driver's loop limit cut short

The program is shaders/lift/host_main.comp, the host's sample loop: the pixel, per-sample
seeds, the primary hit (rebuilt exactly from the G-buffer's primitive id, or traced from the
camera, with a point on the lens and a moment in the shutter interval), the call of the
plugin's `vec3 radiance(Ray ray, Hit hit, inout Rng rng)`, the NaN/Inf guard
(lift/sample_guard.glsl) and the output. Python generates only its head (generate_main): the
work group, the plugin's parameters as uniforms and the include of its entry file.

How the program runs is the options' choice, made once for the device, plugin and scene
(lift_gl/options.py resolve; `--explain` prints it):
- bvh_stack: the BVH traversal stack in shared memory with 8x4 work groups
  (LIFT_BVH_SHARED_STACK, shaders/lift/bvh.glsl), or in a local array (8x8 groups on CPU
  rasterizers);
- pixel_queue: a plugin with LIFT_PATH_STEPS takes its next pixel from a queue as soon as its
  pixel's paths end (LIFT_PIXEL_QUEUE, lift/host_pixel_queue.glsl): the same image;
- carry_paths: with the queue, paths under way when it runs out go on in the next frame's
  dispatch (LIFT_CARRY_PATHS, lift/host_carry.glsl; the buffers: passes/carry.py).
"""
from __future__ import annotations

import re

import moderngl

from .. import shaders
from ..options import Device, Options, ResolvedOptions, Workload, resolve, work_group
from ..plugins import GLSL_TYPES, Plugin
from .carry import CarriedPaths
from .common import LOCAL_SIZE, groups, set_uniforms, tile_dispatch_size
from .splat import SplatBuffer, splat_defines

# GL binding points of the trace program (shaders/lift/host_main.comp; the carry's: passes/carry.py)
FRAME_IMAGE_UNIT = 0          # u_frame_out
VISIBILITY_TEXTURE_UNIT = 0   # u_visibility
PIXEL_QUEUE_BINDING = 13      # LiftPixelQueue (lift/host_pixel_queue.glsl)

HOST_MAIN = "lift/host_main.comp"
_PATH_STEPS = re.compile(r"^\s*#\s*define\s+LIFT_PATH_STEPS\b", re.M)


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


def program_head(plugin: Plugin, local_size: tuple[int, int]) -> str:
    """What a trace program's host file follows: the library, the work group, the plugin's
    parameters and its entry file (shaders/lift/host_main.comp's header shows it)."""
    return "\n".join([
        f"// {plugin.name}: the head of a trace program (lift_gl/passes/trace.py program_head), then the host's file",
        '#include "lift/host.glsl"',
        f"layout(local_size_x = {local_size[0]}, local_size_y = {local_size[1]}) in;",
        "// ---- plugin parameters (plugin.toml) ----",
        param_declarations(plugin),
        "// ---- plugin ----",
        f'#include "{plugin.entry_path.as_posix()}"',
    ])


def generate_main(plugin: Plugin, local_size: tuple[int, int] = (LOCAL_SIZE, LOCAL_SIZE)) -> str:
    """The trace program's text: its generated head, then the host's sample loop."""
    return program_head(plugin, local_size) + f'\n// ---- host ----\n#include "{HOST_MAIN}"\n'


def param_uniforms(plugin: Plugin, values: dict) -> dict:
    out = {}
    for name, p in plugin.params.items():
        value = values.get(name, p.default)
        out[name] = tuple(value) if p.type == "color" else value
    return out


def host_defines(ctx, plugin: Plugin, defines: dict, choices: ResolvedOptions) -> tuple[dict, tuple[int, int]]:
    """The defines and work group that every program around a plugin's code shares (the trace
    pass's, the prepass's): the primary hit's source, the splat buffer, the BVH stack's place."""
    defines = dict(defines)
    if plugin.primary == "gbuffer":
        defines["PRIMARY_GBUFFER"] = True
    if plugin.splats:
        defines.update(splat_defines(ctx))
    local_size = work_group(choices["bvh_stack"], choices.device)
    if choices["bvh_stack"] == "shared":
        defines["LIFT_BVH_SHARED_STACK"] = local_size[0] * local_size[1]
    return defines, local_size


class TracePass:
    name = "trace"
    inputs = ("scene", "camera", "visibility?", "prepass?")
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
        defines, self.local_size = host_defines(ctx, plugin, defines, choices)
        self.splats = None
        if plugin.splats:
            self.splats = SplatBuffer(ctx, size)
            self.outputs = ("frame (with splats)",)
        queued = choices["pixel_queue"] == "on"
        if queued:
            defines["LIFT_PIXEL_QUEUE"] = True
            if choices.device.software:   # CPU rasterizers (llvmpipe) end long-running loops
                defines["LIFT_LOOP_LIMITED"] = True
        self.shared_stack = choices["bvh_stack"] == "shared"   # where the BVH stack lives (renderer.explain says it)
        # paths still under way when the queue runs out go on in the next frame (passes/carry.py)
        self.carry = None
        carry = choices["carry_paths"] if queued else "off"
        if carry in ("on", "always"):
            defines["LIFT_CARRY_PATHS"] = True
            if carry == "always":
                defines["LIFT_CARRY_PARK_ALWAYS"] = True
            self.carry = CarriedPaths(ctx, size, int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)))
        self._resumed = False          # the last dispatch resumed parked paths (late)
        self.defines = defines         # what the program was built with (benchmarks rebuild it from them)
        self.source = shaders.assemble(generate_main(plugin, self.local_size), defines, include_dirs=[plugin.folder],
                                       main_name=f"<{plugin.name} host main>")
        self.program = shaders.compile_compute(ctx, self.source)
        self.pixel_queue = ctx.buffer(reserve=4) if queued else None
        self.frame = ctx.texture(size, 4, dtype="f4")

    @property
    def late(self):
        """Samples that landed a frame late (paths this frame resumed), which the accumulation
        adds to the frame: (image, tag image, this frame's tag), or None when it resumed none."""
        if self.carry is None or not self._resumed:
            return None
        return self.carry.late, self.carry.late_tag, self.carry.tag

    def discard_parked(self) -> None:
        """Forget the paths the last frame parked (the camera moved, accumulation restarted)."""
        if self.carry is not None:
            self.carry.discard()

    def run(self, uniforms: dict, visibility=None, park: bool = False) -> None:
        """One frame. `park`: paths still under way once the pixel queue has run out may be
        parked for the next frame's dispatch (passes/carry.py; where carrying is on), which
        must then be run with the same camera; the default runs every path to its end."""
        self._resumed = False
        set_uniforms(self.program, uniforms)
        sampler = self.program.get("u_visibility", None) if visibility is not None else None
        if sampler is not None:
            visibility.use(location=VISIBILITY_TEXTURE_UNIT)
            sampler.value = VISIBILITY_TEXTURE_UNIT
        self.frame.bind_to_image(FRAME_IMAGE_UNIT, read=False, write=True)
        if self.splats is not None:
            self.splats.bind()
        if self.pixel_queue is not None:
            reset_pixel_queue(self.ctx, self.pixel_queue)
        if self.carry is not None:
            self.carry.before_dispatch(self.program, park)
            self._resumed = self.carry.resumed
        self.program.run(*groups(*tile_dispatch_size(self.defines, self.size, self.local_size), self.local_size))
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
        if self.splats is not None:
            self.splats.release()
