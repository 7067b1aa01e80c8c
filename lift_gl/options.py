"""The renderer's implementation choices, in one frozen object (as pbrt-v4's PBRTOptions).

    options = parse_options(["bvh_width=4", "pixel_queue=on"])   # lift-gl render --option KEY=VALUE
    renderer = Renderer(scene, options=options)

An option chooses how a frame runs (the BVH's layout, where the traversal keeps its stack,
whether lanes take pixels from a queue, ...), never what a render converges to. Most are
"auto": `resolve` turns them into the choice for the device, a CPU rasterizer (Mesa llvmpipe)
or a GPU, and for the scene's tree and the plugin where those matter. That function is the
one place where the device decides; the measurements behind each rule are in docs/gpu.md and
docs/cpu-speed.md. `lift-gl render --explain` prints every resolved choice and why, and each
render's JSON records them (ResolvedOptions.record).
"""
from __future__ import annotations

import dataclasses
import difflib
from dataclasses import dataclass, field

from .errors import LiftError


class OptionError(LiftError):
    """A bad --option: an unknown key or a value the key does not allow."""


def _option(default, choices=None, help="", minimum=None, maximum=None, auto=False):
    """A field of Options: `choices` for a word, else a whole number in [minimum, maximum]
    (or "auto" where `auto`)."""
    return field(default=default, metadata={"choices": choices, "help": help, "minimum": minimum,
                                            "maximum": maximum, "auto": auto})


ON_OFF = ("on", "off")
AUTO = "auto"


@dataclass(frozen=True)
class Options:
    bvh_width: str = _option(AUTO, ("2", "4", "4q"),
                             "children per BVH node the shaders traverse: binary, 4-wide with float boxes, 4-wide "
                             "with 8-bit boxes (auto: 4 on GPUs, 4q on CPU rasterizers; motion blur, traced "
                             "instances and OpenCL plugins keep the binary tree)")
    bvh_slot_order: str = _option(AUTO, ("area", "build"),
                                  "the order of a 4-wide node's children: largest box first, or the collapse's "
                                  "own (auto: area on GPUs, build on CPU rasterizers)")
    bvh_builder: str = _option(AUTO, ("sah", "lbvh"),
                               "binned SAH in numpy, or the Morton-code LBVH through OpenCL (auto: lbvh from "
                               "1M triangles where pyopencl is installed)")
    bvh_stack: str = _option(AUTO, ("shared", "local"),
                             "where the BVH traversal keeps its stack: in shared memory (8x4 work groups), or in "
                             "a local array (8x8 groups on CPU rasterizers, 8x4 on GPUs) (auto: shared on GPUs, "
                             "but local for a queued megakernel; local on CPU rasterizers)")
    bvh_stack_entries: str = _option(AUTO, ("children", "groups"),
                                     "the 4-wide traversal's stack entries: a child left to visit, or a node with "
                                     "children left (auto: groups on GPUs where a stack of children needs more "
                                     "than 32 entries, but children for plugins with splats)")
    trace_paired: str = _option(AUTO, ON_OFF,
                                "a path vertex's shadow ray and next ray in one traversal loop (auto: on GPUs "
                                "for 4-wide trees of 8 levels or more)")
    pixel_queue: str = _option(AUTO, ON_OFF,
                               "a plugin that writes its paths as steps (pt) takes its next pixel from a queue as "
                               "its paths end (auto: on GPUs)")
    carry_paths: str = _option(AUTO, ("on", "off", "always"),
                               "with the pixel queue, paths still under way when it runs out go on in the next "
                               "frame; always: every path parks after its first vertex (tests) (auto: on GPUs for "
                               "trees of 16 levels or more without coherent sampling, else off)")
    gbuffer: str = _option(AUTO, ("raster", "traced"),
                           "the G-buffer rasterized, or ray cast, one camera ray a pixel (auto: traced on GPUs "
                           "with few raster units: H100, H200, A100, ...)")
    uniform_blocks: str = _option(AUTO, ON_OFF,
                                  "the small scene arrays in uniform blocks instead of storage buffers (auto: on "
                                  "CPU rasterizers, which read them faster)")
    light_selection: str = _option(AUTO, ("power", "tree"),
                                   "how next event estimation picks an emitter: by power alone, or by a light tree "
                                   "that weighs each light's distance and facing at the shading point (auto: the "
                                   "tree, but power for one flat emitter or one sphere, and with motion blur)")
    coherent_sampling: str = _option("off", ON_OFF,
                                     "the pixels of each work group's tile share their random numbers (bdpt: "
                                     "its camera subpaths'), the tiles moving every frame: unbiased per pixel, "
                                     "the noise correlated in blocks (denoisers keep it); 1.3-1.6x faster on GPUs")
    coherent_interleave: int = _option(1, help="with coherent_sampling: a tile's pixels are every k-th pixel of a "
                                               "block k tiles wide (interleaved sampling: neighbours independent)",
                                       minimum=1, maximum=8)
    realtime_model: str = _option("unet", ("unet", "rt"),
                                  "the network the glsl denoiser runs every frame (denoise every): the quality U-Net "
                                  "of final images (10.9 ms at 1080p on an H200), or the real-time rt (about 2.6 ms, a "
                                  "seventh of its work, with the previous frame as an input; above a-trous, below the "
                                  "unet in quality: docs/denoiser.md)")
    max_buffer_bytes: object = _option(AUTO, help="the largest scene storage buffer, in bytes: a scene that needs "
                                                  "more is split into several (auto: the GL's limit, "
                                                  "GL_MAX_SHADER_STORAGE_BLOCK_SIZE)",
                                       minimum=16, auto=True)

    def __post_init__(self):
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _checked(f, getattr(self, f.name)))

    def changed(self) -> dict:
        """The options set to something other than their default."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if getattr(self, f.name) != f.default}

    def as_pairs(self) -> list[str]:
        """KEY=VALUE for each changed option: what parse_options reads back (a child process's job)."""
        return [f"{k}={v}" for k, v in self.changed().items()]


OPTION_FIELDS = {f.name: f for f in dataclasses.fields(Options)}


def allowed(name: str) -> str:
    """What option `name` takes, in words (for errors and the help)."""
    meta = OPTION_FIELDS[name].metadata
    if meta["choices"] is not None:
        return ", ".join(meta["choices"] + ((AUTO,) if OPTION_FIELDS[name].default == AUTO else ()))
    bounds = f"a whole number from {meta['minimum']}" + (f" to {meta['maximum']}" if meta["maximum"] else "")
    return ("auto or " if meta["auto"] else "") + bounds


def _checked(f: dataclasses.Field, value):
    """The value of option f, normalised (words lower-case, numbers int), or OptionError."""
    meta = f.metadata
    text = str(value).strip().lower()
    if meta["choices"] is not None:
        if text in meta["choices"] or (text == AUTO and f.default == AUTO):
            return text
    elif text == AUTO and meta["auto"]:
        return AUTO
    elif not isinstance(value, (bool, float)):
        try:
            number = int(text.replace("_", ""))
        except ValueError:
            number = None
        if number is not None and number >= meta["minimum"] and (meta["maximum"] is None or number <= meta["maximum"]):
            return number
    raise OptionError(f"option {f.name}: {value!r} is not allowed; use {allowed(f.name)}")


def parse_options(pairs=(), base: Options | None = None) -> Options:
    """Options from KEY=VALUE strings (--option, repeatable; a later key wins), on top of `base`."""
    changes = {}
    for pair in pairs or ():
        key, sep, value = str(pair).partition("=")
        key = key.strip().lower()
        if not sep or not key:
            raise OptionError(f"--option expects KEY=VALUE, not {pair!r}")
        if key not in OPTION_FIELDS:
            close = difflib.get_close_matches(key, OPTION_FIELDS, n=1)
            hint = f"; did you mean {close[0]}?" if close else ""
            raise OptionError(f"unknown option {key!r}{hint} (options: {', '.join(OPTION_FIELDS)})")
        changes[key] = value.strip()
    return dataclasses.replace(base or Options(), **changes)


def add_option_argument(parser) -> None:
    """--option KEY=VALUE (repeatable) on a command's parser, every option listed under its help."""
    import argparse
    import textwrap

    def pair(text: str) -> str:   # checked as the command line is read, before any work
        try:
            parse_options([text])
        except OptionError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE", dest="options", type=pair,
                        help="how frames run (repeatable; the keys are listed below): e.g. bvh_width=4")
    lines = [textwrap.fill(f"{name} = {allowed(name)} (default {f.default}): {f.metadata['help']}", width=96,
                           initial_indent="  ", subsequent_indent="      ") for name, f in OPTION_FIELDS.items()]
    parser.epilog = "\n".join([parser.epilog or "", "options (--option KEY=VALUE; render --explain prints what "
                                                    "each one chose, and why):", *lines]).lstrip("\n")
    parser.formatter_class = argparse.RawDescriptionHelpFormatter


def from_args(args) -> Options:
    """The Options of a command's --option arguments (add_option_argument)."""
    return parse_options(getattr(args, "options", None) or ())


# ---- what the device, the scene and the plugin bring to the choice ----

@dataclass(frozen=True)
class Device:
    """The GL device: a CPU rasterizer (`software`: Mesa llvmpipe) or a GPU, and its name."""
    software: bool
    renderer: str = ""

    @classmethod
    def of(cls, ctx) -> "Device":
        from .gl.context import is_software

        return cls(software=is_software(ctx), renderer=str(ctx.info.get("GL_RENDERER", "")))

    @property
    def kind(self) -> str:
        return "a CPU rasterizer" if self.software else "a GPU"


@dataclass(frozen=True)
class TreeShape:
    """What the traversal of the scene's packed BVH needs (scene/pack.py PackedScene)."""
    width: int              # 2 or 4
    stack_bound: int = 0    # 4-wide: the deepest a stack of child entries can get
    levels: int = 0         # 4-wide: wide nodes on the longest root path
    nodes: int = 0

    @classmethod
    def of(cls, packed) -> "TreeShape":
        return cls(width=int(packed.bvh_width), stack_bound=int(packed.bvh_stack), levels=int(packed.bvh_levels),
                   nodes=int(packed.bvh_nodes.shape[0]))


@dataclass(frozen=True)
class Workload:
    """The scene and the plugin, where a choice depends on them."""
    language: str = "glsl"
    path_steps: bool = False       # the plugin's paths go a vertex at a time, from the G-buffer (pt)
    splats: bool = False
    motion: bool = False           # shaders compiled with motion blur
    instances: bool = False        # ... or with traced instances
    triangles: int = 0
    tree: TreeShape | None = None  # None: before the scene is packed
    one_flat_emitter: bool = True  # the emissive primitives are one sphere or lie in one plane, facing one way


# ---- the rules (measurements: docs/gpu.md, docs/cpu-speed.md) ----

# 4-wide trees made pt's trace 1.02-1.19x faster than the binary one on an H100 and 1.10-1.26x
# in CPU time on llvmpipe; 8-bit child boxes gained llvmpipe 1.06x more and cost the H100 7-35%.
GPU_WIDTH, CPU_WIDTH = "4", "4q"
# Largest box first made pt's trace on an H100 0.968x (dining room), 0.855x (Covered Dragon),
# 1.001x (classroom) against the collapse's order; on llvmpipe the classroom ran 4% slower
# with it (0.956x; the dining room 1.016x), and CPU rasterizers keep the build order.
GPU_SLOT_ORDER, CPU_SLOT_ORDER = "area", "build"
# Node groups ran pt's plain megakernel 1.41x (dining room), 1.15x (dragon) faster on an H100,
# the cornell-box's 16-entry stack 0.89x; bdpt (splats, subpaths in local memory) lost 0.31x;
# on llvmpipe (no shared memory) rays lost 0.78-0.99x.
GROUP_STACK_FROM = 32
# One loop for a vertex's two rays: 1.11x (classroom, 16 levels), 1.04x (dining room, 18),
# 0.92x (cornell-box, 4 levels) with the pixel queue on an H100; 5% slower on llvmpipe.
PAIRED_FROM_LEVELS = 8
# Carried paths, pt's frame on an H100 at 1080p against not carrying (pt's roulette / Lift's;
# benchmarks/results/gpu/pt_h100.json): dining room (17 levels) 1.02x / 1.12x, classroom (16)
# 1.00x / 1.02x; Covered Dragon (15) 0.87x / 0.89x, cornell-box (3) 0.85x / 0.93x, where the carry
# code costs more than the tail of long paths it saves (on the dragon a step of occupancy). With
# coherent sampling 0.39-0.96x in 7 cases of these 8 (coherent_h100.json).
CARRY_FROM_LEVELS = 16
# GPUs whose graphics units are few (NVIDIA's data-centre parts): an H100 rasterized the
# 36-triangle cornell-box at 1080p in 2.8 ms, a camera ray a pixel takes a fraction of that.
RASTER_POOR_GPUS = ("h100", "h200", "h800", "gh200", "a100", "a800")


def work_group(stack: str, device: Device) -> tuple[int, int]:
    """The trace programs' work-group shape for a stack kept `stack` (shared or local): 8x4, one
    warp, with a shared stack (sized to the group) and on GPUs (8x8 and 16x4 groups ran pt's
    trace 0.49-0.68x as fast on an H100: an SM holds fewer of their warps); 8x8 with a local
    stack on CPU rasterizers (llvmpipe runs a group as SIMD batches of 8 lanes)."""
    return (8, 4) if stack == "shared" or not device.software else (8, 8)


@dataclass(frozen=True)
class Choice:
    asked: object   # what the options said
    value: object   # what runs (None: the choice does not apply here)
    why: str = ""   # how auto chose, or why the value is not what was asked

    def text(self) -> str:
        """'auto -> 4q because ...', or the value asked for (and what it means here)."""
        value = "not used" if self.value is None else str(self.value)
        if self.asked == self.value:
            return value + (f" ({self.why})" if self.why else "")
        return f"{self.asked} -> {value}" + (f" because {self.why}" if self.why else "")


@dataclass(frozen=True)
class ResolvedOptions:
    """Every option's choice for one device, scene and plugin (resolve)."""
    options: Options
    device: Device
    choices: dict
    gbuffer_stack: str = "local"   # the ray-cast G-buffer's stack (bvh_stack's plain rule)

    def __getitem__(self, name: str):
        return self.choices[name].value

    def record(self) -> dict:
        """For a render's JSON: each option's value, what was asked and why (JSON types)."""
        return {name: {"value": c.value, "asked": c.asked, **({"why": c.why} if c.why else {})}
                for name, c in self.choices.items()}

    def explain(self) -> list[str]:
        return [f"  {name:<19} {c.text()}" for name, c in self.choices.items()]


def _auto(asked, device: Device, gpu, cpu, gpu_why: str, cpu_why: str) -> Choice:
    if asked != AUTO:
        return Choice(asked, asked)
    return Choice(asked, cpu, cpu_why) if device.software else Choice(asked, gpu, gpu_why)


def resolve(options: Options, device: Device, work: Workload = Workload()) -> ResolvedOptions:
    """Each option's choice: what was asked, or for auto this device's (and scene's, plugin's)."""
    o, c = options, {}
    binary_only = ("OpenCL plugins read the binary tree" if work.language == "opencl" else
                   "shaders with motion blur keep the binary tree" if work.motion else
                   "shaders with traced instances keep the binary tree" if work.instances else "")
    if binary_only:
        c["bvh_width"] = Choice(o.bvh_width, "2", binary_only)
    else:
        c["bvh_width"] = _auto(o.bvh_width, device, GPU_WIDTH, CPU_WIDTH,
                               "on GPUs the 4-wide tree traces faster, 8-bit boxes cost 7-35%",
                               "on CPU rasterizers the 4-wide tree with 8-bit boxes traces fastest")
    if c["bvh_width"].value != "2" and work.tree is not None and work.tree.width == 2:
        c["bvh_width"] = Choice(o.bvh_width, "2", "the 4-wide layout cannot hold this tree")
    wide = c["bvh_width"].value != "2"
    c["bvh_slot_order"] = _auto(o.bvh_slot_order, device, GPU_SLOT_ORDER, CPU_SLOT_ORDER,
                                "on GPUs shadow rays find occluders sooner in the largest box",
                                "llvmpipe traced the classroom 4% faster in the build order")
    if not wide:
        c["bvh_slot_order"] = Choice(o.bvh_slot_order, None, "the binary tree")
    c["bvh_builder"] = _builder(o.bvh_builder, work.triangles)
    queued = work.path_steps and work.language == "glsl"
    queue = _auto(o.pixel_queue, device, "on", "off", "on GPUs lanes would idle until their warp's longest path ends",
                  "CPU rasterizers' lanes lose little to long paths (one loop over a frame's samples instead)")
    if not queued and queue.value == "on":
        queue = Choice(o.pixel_queue, "off", "the plugin's paths are not written as steps (LIFT_PATH_STEPS) "
                                              "from the G-buffer")
    c["pixel_queue"] = queue
    queued = queue.value == "on"
    if o.bvh_stack != AUTO:
        c["bvh_stack"] = Choice(o.bvh_stack, o.bvh_stack)
    elif device.software:
        c["bvh_stack"] = Choice(AUTO, "local", "CPU rasterizers have no shared memory")
    elif queued:
        c["bvh_stack"] = Choice(AUTO, "local", "the queued megakernel ran 1.03-1.05x faster with it")
    else:
        c["bvh_stack"] = Choice(AUTO, "shared", "on GPUs a local stack array is slow memory")
    gbuffer_stack = o.bvh_stack if o.bvh_stack != AUTO else ("local" if device.software else "shared")
    c["bvh_stack_entries"] = _stack_entries(o.bvh_stack_entries, device, work, wide)
    c["trace_paired"] = _paired(o.trace_paired, device, work, wide)
    c["carry_paths"] = _carry(o.carry_paths, device, work, queued, o.coherent_sampling == "on")
    c["gbuffer"] = _gbuffer(o.gbuffer, device, work)
    c["light_selection"] = _light_selection(o.light_selection, work)
    c["uniform_blocks"] = _auto(o.uniform_blocks, device, "off", "on", "GPUs read storage buffers as fast",
                                "llvmpipe reads uniform blocks faster than storage buffers")
    if o.coherent_sampling == "on" and work.language != "glsl":
        c["coherent_sampling"] = Choice(o.coherent_sampling, "off", "an OpenCL plugin's kernel draws its own numbers")
    else:
        c["coherent_sampling"] = Choice(o.coherent_sampling, o.coherent_sampling)
    coherent = c["coherent_sampling"].value == "on"
    c["coherent_interleave"] = Choice(o.coherent_interleave, o.coherent_interleave if coherent else None,
                                      "" if coherent else "no coherent sampling")
    c["realtime_model"] = Choice(o.realtime_model, o.realtime_model)
    c["max_buffer_bytes"] = Choice(o.max_buffer_bytes, o.max_buffer_bytes,
                                   "the GL's limit" if o.max_buffer_bytes == AUTO else "")
    return ResolvedOptions(options, device, c, gbuffer_stack)


def _light_selection(asked: str, work: Workload) -> Choice:
    if asked != AUTO:
        return Choice(asked, asked)
    if work.one_flat_emitter:
        return Choice(asked, "power", "one flat emitter or one sphere: the tree would choose as power does")
    if work.motion:  # the tree's boxes and cones are the emitters' at shutter open
        return Choice(asked, "power", "motion blur: the tree's bounds would hold the emitters only at shutter open")
    return Choice(asked, "tree", "lights of different places or facings")


def _builder(asked: str, triangles: int) -> Choice:
    from .accel.cache import AUTO_LBVH_TRIANGLES, resolve_builder

    value = resolve_builder(asked, triangles)
    if asked != AUTO:
        return Choice(asked, value)
    if triangles < AUTO_LBVH_TRIANGLES:
        return Choice(asked, value, f"under {AUTO_LBVH_TRIANGLES:,} triangles the SAH tree is worth its build")
    if value == "lbvh":
        return Choice(asked, value, f"from {AUTO_LBVH_TRIANGLES:,} triangles the SAH build takes minutes")
    return Choice(asked, value, "pyopencl is not installed (pip install 'lift-gl[opencl]')")


def _stack_entries(asked: str, device: Device, work: Workload, wide: bool) -> Choice:
    from .accel.wide import stack_size

    tree = work.tree
    if not wide or (tree is not None and tree.width == 2):
        return Choice(asked, None, "the binary tree")
    if asked != AUTO:
        return _groups_fit(Choice(asked, asked), tree)
    if device.software:
        return Choice(asked, "children", "on CPU rasterizers node groups lose (no shared memory)")
    if work.splats:
        return Choice(asked, "children", "plugins with splats (bdpt) ran 3x slower with node groups")
    if tree is None:
        return Choice(asked, "children", "the tree is not built yet")
    need = stack_size(tree.stack_bound)
    if need > GROUP_STACK_FROM:
        return _groups_fit(Choice(asked, "groups", f"a stack of children would need {need} entries "
                                                   f"(over {GROUP_STACK_FROM})"), tree)
    return Choice(asked, "children", f"a stack of children needs {need} entries (at most {GROUP_STACK_FROM})")


def _groups_fit(choice: Choice, tree: TreeShape | None) -> Choice:
    """Node groups pack a node id in 24 bits and hold a level an entry: children where they cannot."""
    from .accel.wide import GROUP_MAX_NODES, STACK

    if choice.value != "groups" or tree is None or (0 < tree.levels <= STACK and tree.nodes < GROUP_MAX_NODES):
        return choice
    return Choice(choice.asked, "children", f"node groups cannot hold this tree ({tree.nodes:,} nodes, "
                                            f"{tree.levels} levels)")


def _paired(asked: str, device: Device, work: Workload, wide: bool) -> Choice:
    tree = work.tree
    if not wide or (tree is not None and tree.width == 2):
        return Choice(asked, None, "the binary tree")
    if asked != AUTO:
        return Choice(asked, asked)
    if device.software:
        return Choice(asked, "off", "on llvmpipe the one loop cost 5%")
    if tree is None:
        return Choice(asked, "off", "the tree is not built yet")
    if tree.levels >= PAIRED_FROM_LEVELS:
        return Choice(asked, "on", f"the tree has {tree.levels} levels (from {PAIRED_FROM_LEVELS} the one loop pays)")
    return Choice(asked, "off", f"the tree has {tree.levels} levels: short traversals, the loop's setup costs more")


def _carry(asked: str, device: Device, work: Workload, queued: bool, coherent: bool) -> Choice:
    if not queued:
        return Choice(asked, "off", "" if asked == "off" else "only the pixel queue's loop carries paths")
    if asked != AUTO:
        return Choice(asked, asked)
    if device.software:
        return Choice(asked, "off", "on CPU rasterizers lanes rarely see the queue run out")
    if coherent:
        return Choice(asked, "off", "with coherent sampling the carry code cost more than it saved")
    tree = work.tree
    if tree is None:
        return Choice(asked, "off", "the tree is not built yet")
    if tree.width == 2:
        return Choice(asked, "off", "measured faster on 4-wide trees only")
    if tree.levels >= CARRY_FROM_LEVELS:
        return Choice(asked, "on", f"the tree has {tree.levels} levels (from {CARRY_FROM_LEVELS} the frame's tail of "
                                   f"long paths is worth carrying)")
    return Choice(asked, "off", f"the tree has {tree.levels} levels: the carry code costs more than the tail it saves")


def _gbuffer(asked: str, device: Device, work: Workload) -> Choice:
    if asked != AUTO:
        return Choice(asked, asked)
    renderer = device.renderer.lower()
    poor = next((name for name in RASTER_POOR_GPUS if name in renderer), None)
    if not device.software and poor:
        return Choice(asked, "traced", f"this GPU ({poor.upper()}) has few raster units")
    return Choice(asked, "raster", "this device rasterizes fast enough")
