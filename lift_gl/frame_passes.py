"""The passes a renderer's frame may have, chosen by its settings: for each, how it is made and
what --explain says it is there for. The frame graph (passes/graph.py) orders them from their
declarations and makes only those that the asked resources need.

    G-buffer -> trace [-> reduced -> upsample] [-> reproject] -> accumulate   every frame
    [G-buffer guides ->] denoise, tonemap                                      on demand
"""
from __future__ import annotations

from .options import work_group
from .passes.accumulate import AccumulatePass
from .passes.denoise import DenoisePass
from .passes.gbuffer import GBufferPass, TracedGBufferPass
from .passes.graph import Node
from .passes.prepass import PrepassPass, prepass_layout
from .passes.reduced_trace import ReducedTracePass
from .passes.reproject import ReprojectPass
from .passes.tonemap import TonemapPass
from .passes.trace import TracePass
from .passes.upsample import UpsamplePass
from .temporal import history_cap

# What each frame adds to; what a denoiser makes; what the screen shows (display()).
FRAME, DENOISED, DISPLAY, NOISY_DISPLAY = "accumulation", "denoised", "display", "noisy display"
# What the G-buffer's guides give the denoiser and the AOVs (albedo, normal, depth).
GUIDES = ("albedo", "normal_depth")


def frame_nodes(r, plugin=None, params=None, choices=None) -> list[Node]:
    """The passes renderer `r`'s settings may use, in their order; `plugin`, `params` and
    `choices` in place of r's (a hot reload tries them before it keeps them)."""
    plugin = plugin or r.plugin
    params = r.params if params is None else params
    choices = choices or r.choices
    nodes = [gbuffer_node(r, choices)]
    if plugin.prepass is not None:   # a [prepass] plugin: its function for every pixel sample, before the trace
        nodes.append(Node("prepass", PrepassPass, lambda: make_prepass(r, plugin, params, choices),
                          why=lambda made: prepass_why(plugin, made)))
    nodes.append(trace_node(r, plugin, params, choices))
    if plugin.reduced is not None:   # a [reduced] plugin (hybrid): traced at reduced resolution, upsampled
        nodes += [Node("reduced", ReducedTracePass, lambda: make_reduced(r, plugin, params, choices),
                       why=lambda made: reduced_why(r)),
                  Node("upsample", UpsamplePass, lambda: UpsamplePass(r.ctx, r.size, r.defines),
                       why=lambda made: upsample_why(r))]
    if r.temporal.reproject:
        nodes.append(Node("reproject", ReprojectPass, lambda: ReprojectPass(r.ctx, r.size),
                          why=lambda made: reproject_why(r)))
    nodes.append(Node("accumulate", AccumulatePass, lambda: AccumulatePass(r.ctx, r.size),
                      uses=("history",) if r.temporal.reproject else (), why=lambda made: accumulate_why(r)))
    if r.denoise.on:
        nodes.append(Node("denoise", DenoisePass, lambda: make_denoise(r), why=lambda made: denoise_why(r, made)))
    nodes += [Node("tonemap", TonemapPass, lambda: TonemapPass(r.ctx, r.size), uses=("denoised",) if r.denoise.on
                   else (), why="a display image was asked for (PNG or screen)"),
              Node("tonemap_noisy", TonemapPass, lambda: TonemapPass(r.ctx, r.size), outputs=(NOISY_DISPLAY,),
                   why="the noisy mean beside the denoised image (the viewer's split view)")]
    return nodes


def asked(r) -> tuple[str, ...]:
    """The resources renderer `r` wants from the start: the accumulation, and the denoised image."""
    return (FRAME, DENOISED) if r.denoise.on else (FRAME,)


# ---- the G-buffer ----
def gbuffer_node(r, choices) -> Node:
    motion_vectors = r.temporal.reproject
    traced = choices["gbuffer"] == "traced"
    return Node("gbuffer", TracedGBufferPass if traced else GBufferPass,
                lambda: make_gbuffer(r, choices, motion_vectors),
                uses=("motion",) if motion_vectors else (), why=lambda made: gbuffer_why(r, made))


def make_gbuffer(r, choices, motion_vectors: bool):
    """The raster G-buffer, or on GPUs with few raster units its ray-cast equivalent
    (passes/gbuffer.py; the option gbuffer), each with motion vectors where the frame reprojects."""
    if choices["gbuffer"] == "traced":
        return TracedGBufferPass(r.ctx, r.size, r.defines, stack=choices.gbuffer_stack,
                                 motion_vectors=motion_vectors)
    p = r.packed
    return GBufferPass(r.ctx, r.size, r.defines, p.num_world_triangles, p.num_spheres,
                       motion_vectors=motion_vectors, instance_draws=p.instance_draws, raster_rows=p.raster_rows)


def gbuffer_why(r, made) -> str:
    traced = "; ray cast, one camera ray a pixel (the option gbuffer)" if isinstance(made, TracedGBufferPass) else ""
    if r.temporal.reproject:
        return ("the reproject pass needs its motion vectors and the previous frame's normal and depth "
                "(temporal = reproject)" + ("; the plugin also takes its first hit from it"
                                            if r.plugin.primary == "gbuffer" else ""))
    if r.plugin.primary == "gbuffer":
        return "the plugin takes its first hit from the raster G-buffer (primary = \"gbuffer\")" + traced
    what = "the denoiser's guides" if r.denoise.on else "an AOV"
    return f"{what} (albedo, normal, depth), through the pixel centres" + traced


# ---- the plugin's passes ----
def trace_node(r, plugin, params, choices) -> Node:
    if plugin.language == "opencl":
        from .passes.trace_cl import OpenCLTracePass as kind   # pyopencl only when such a plugin runs
    else:
        kind = TracePass
    uses = (("visibility",) if plugin.primary == "gbuffer" else ()) + (("prepass",) if plugin.prepass else ())
    return Node("trace", kind, lambda: make_trace(r, plugin, params, choices), uses=uses,
                why=lambda made: f"runs {plugin.entry}" + trace_device(plugin, made))


def make_trace(r, plugin, params, choices):
    defines = r.plugin_defines(plugin, params, choices)
    if plugin.prepass is not None:
        defines.update(plugin_prepass_layout(r, defines, plugin, params, choices).defines())
    if plugin.language == "opencl":
        from .passes.trace_cl import OpenCLTracePass

        return OpenCLTracePass(r.ctx, r.size, plugin, defines, r.buffers)
    return TracePass(r.ctx, r.size, plugin, defines, choices)


def plugin_prepass_layout(r, defines, plugin, params, choices):
    """Where the prepass's storage goes, for r's image and samples a frame (passes/prepass.py);
    `defines` the plugin's programs'."""
    return prepass_layout(r.ctx, plugin, params, r.size, defines, work_group(choices["bvh_stack"], choices.device),
                          r.samples_per_frame)


def make_prepass(r, plugin, params, choices):
    defines = r.plugin_defines(plugin, params, choices)
    layout = plugin_prepass_layout(r, defines, plugin, params, choices)
    return PrepassPass(r.ctx, r.size, plugin, defines, choices, layout)


def prepass_why(plugin, made) -> str:
    layout = made.layout
    return (f"runs {plugin.prepass.function}() for every pixel sample before the trace pass ([prepass] in "
            f"plugin.toml): {layout.entries} uvec4s a pixel sample in {layout.buffers} storage buffer"
            f"{'s' if layout.buffers > 1 else ''}, read by the trace pass")


def make_reduced(r, plugin, params, choices):
    return ReducedTracePass(r.ctx, r.size, plugin, r.plugin_defines(plugin, params, choices))


def trace_device(plugin, trace) -> str:
    """How the trace program runs: the megakernel's queue and carried paths, or OpenCL."""
    if plugin.language != "opencl":
        queue = ("its lanes taking their next pixel from a queue as their paths end"
                 if getattr(trace, "pixel_queue", None) is not None else "")
        carry = getattr(trace, "carry", None)
        if carry is not None:
            queue += (f"; paths under way when the queue runs out go on in the next frame "
                      f"({carry.buffer.size / 2**20:.1f} MiB for them)")
        return f" (megakernel, {queue})" if queue else ""
    from .opencl import describe_device

    return f" as an OpenCL kernel on {describe_device()}; G-buffer read back, frame written to GL"


def reduced_setting(r, name: str):
    return r.plugin.reduced.value(name, r.params)


def reduced_why(r) -> str:
    scale = reduced_setting(r, "scale")
    return f"runs {r.plugin.reduced.function}() for 1 pixel in {scale}x{scale} (the plugin's [reduced] table)"


def upsample_why(r) -> str:
    return ("joint bilateral upsampling of the reduced estimate, guided by normal and depth "
            f"(normal_power {reduced_setting(r, 'normal_power')}, depth_sigma {reduced_setting(r, 'depth_sigma')}), "
            "added to the frame")


# ---- accumulation ----
def reproject_why(r) -> str:
    t = r.temporal
    return ("temporal = reproject: runs ONLY on frames where the camera or an object moved since the last frame: "
            "the history seen from the new camera (motion vectors, bilinear taps rejected by depth and normal), "
            f"capped at {history_cap(t.min_blend, r.samples_per_frame):g} samples (min blend {t.min_blend:g})"
            + (f", clamped to the frame's neighbourhood (+-{t.clamp_sigma:g} sigma: BIASED)" if t.clamp_sigma > 0
               else ""))


def accumulate_why(r) -> str:
    return ("still camera: exact running mean (compensated sum), and the difference of two halves of the frames "
            "for the error estimate, and luminance moments"
            + ("; after a reprojection it adds the frame to the reprojected history" if r.temporal.reproject else ""))


# ---- the denoiser ----
def make_denoise(r) -> DenoisePass:
    """The denoise pass of r.denoise; a numpy denoiser (onnx, oidn, glsl: model loading) is made
    once and kept in r.numpy_denoiser across resizes."""
    settings = r.denoise
    if settings.denoiser == "atrous":
        from .errors import DenoiserError
        from .passes.atrous import AtrousSettings

        try:
            atrous = AtrousSettings(**settings.options)
        except (TypeError, ValueError) as exc:
            raise DenoiserError(f"à-trous settings: {exc}") from None
        return DenoisePass(r.ctx, r.size, "atrous", settings=atrous)
    options = dict(settings.options)
    if settings.denoiser == "glsl":  # its shaders run in the renderer's context, not a second one
        from .denoise.glsl_denoiser import DEFAULT_MODEL, model_file

        options.setdefault("ctx", r.ctx)
        options.setdefault("ensemble", 1)  # the texture road runs the network once (passes/denoise.py)
        every = model_file(r.choices["realtime_model"])
        options.setdefault("model_path", every if settings.mode == "every" else DEFAULT_MODEL)
        if r.numpy_denoiser is not None and r.numpy_denoiser.model_path != options["model_path"]:
            r.numpy_denoiser = None  # the mode changed the network (realtime_model)
    if r.numpy_denoiser is None:
        from .denoise import get_denoiser

        r.numpy_denoiser = get_denoiser(settings.denoiser, **options)
    return DenoisePass(r.ctx, r.size, settings.denoiser, numpy_denoiser=r.numpy_denoiser)


def denoise_why(r, made) -> str:
    mode = r.denoise.mode
    when = "after every frame" if mode == "every" else "once at the end of each render() call (the final frame)"
    if r.denoise.denoiser == "atrous":
        s = made.atrous.settings
        how = (f"à-trous on the GPU: mean / albedo, {s.iterations} iterations of SVGF edge-stopping "
               f"(sigma luminance {s.sigma_luminance} x sqrt(variance from the half-buffers), normal "
               f"{s.sigma_normal}, depth {s.sigma_depth}), x albedo")
    elif made.net is not None:  # the glsl network on the renderer's textures
        net = made.net.net
        how = f"the network {net.model_path.name} in GLSL, no readback"
    else:
        how = f"{r.denoise.denoiser} on the CPU: mean, albedo, normal, depth and variance read back, result uploaded"
    from .frame import frame_guides  # frame.py imports this module

    guides = ("the frame's own G-buffer (jittered as its samples)" if frame_guides(r)
              else "a G-buffer through the pixel centres")
    chosen = f" (denoiser auto: {r.denoise_choice})" if r.denoise_choice else ""
    return f"--denoise {mode}{chosen}: {how}, {when}; guides from {guides}"
