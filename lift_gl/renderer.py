"""Renderer: one scene, one integrator, one resolution; renders frames into an accumulation.

    scene = load_scene("scenes/cornell.toml")
    image = Renderer(scene, size=(256, 256), integrator="pt").render(spp=64)  # float32 HxWx3

A frame is: G-buffer (when the plugin takes its first hit from it) -> trace -> accumulate,
then, with a denoiser (`denoise="every"` after each frame, `"final"` at the end of each
`render()` call), unjittered G-buffer guides -> denoise. Only the passes the settings need are
created (see `explain()`).

Temporal reprojection (temporal="reproject", docs/temporal.md): moving the camera
(set_camera) or objects (update_scene) keeps the accumulation: on the next frame the
reproject pass carries it over to the new view before the frame is added; a still camera
keeps the exact running mean. temporal="reset" (the default) restarts accumulation instead.

Hot reload: `reload()` recompiles the plugin when its files changed; a broken edit raises
its error (file and line) and the last good program goes on rendering.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from .accel.cache import bins_for_one_build
from .accel.wide import STACK_DEFINES as BVH_STACK_DEFINES, stack_defines as bvh_stack_defines
from .denoise import BIASED as DENOISER_BIASED
from .denoise import DENOISERS, MODES as DENOISE_MODES
from .error_estimate import ErrorEstimate, estimate_error
from .errors import DenoiserError, LiftError
from .gl.context import create_context, describe, is_software
from .options import Device, Options, ResolvedOptions, TreeShape, Workload, resolve
from .passes.accumulate import AccumulatePass, half_sign
from .passes.camera import camera_uniforms, frame_jitter
from .passes.pixel_filter import filter_uniforms, filtered_jitter
from .passes.denoise import DenoisePass
from .limits import GlLimits, check_film, check_packed, check_triangle_count
from .passes.common import (COHERENT_DEFINE, INTERLEAVE_DEFINE, SCENE_BINDINGS, STAT_DROPPED, STAT_DROPPED_SPLATS,
                            STAT_LOOP_LIMITED, STAT_RAYS_HIGH, STAT_RAYS_LOW, GpuTimer, SceneBuffers, coherent_defines)
from .passes.gbuffer import GBufferPass, TracedGBufferPass
from .passes.reduced_trace import ReducedTracePass, block_offset
from .passes.reproject import ReprojectPass
from .passes.tonemap import TonemapPass
from .passes.trace import TracePass, param_uniforms, plugin_path_steps
from .passes.upsample import UpsamplePass
from .plugins import Plugin, find_plugin, load_manifest, param_defines
from .scene.features import SceneFeatures
from .scene.instances import flatten_instances, only_instances_moved
from .scene.model import PixelFilter, Scene
from .scene.pack import pack_materials, pack_scene, repack_instances
from .scene.validate import validate_scene
from .temporal import DEFAULT_MIN_BLEND, MODES, history_cap, motion_uniforms, objects_moved, previous_positions, same_camera
from .watch import FileWatcher

GBUFFER_AOVS = ("albedo", "normal", "depth")
# Views of the accumulation's internals (docs/temporal.md): history length (samples),
# the last reprojection's rejection mask, the frames' luminance variance, radiance / albedo.
AOVS = GBUFFER_AOVS + ("history", "rejection", "variance", "irradiance")
PREV_POSITIONS_BINDING = 17  # shaders/passes/motion_vectors.glsl
MODE_WORDS = {"every": "every frame", "final": "final frame"}
# Frames one render() call queues on the GPU before it waits for them (ctx.finish). On an H100
# (driver 580.159) 8192 frames of the dining room queued by one call came back black, with the
# pixel queue on or off, and so did the next renderer's image in that process; waiting every 64
# gave the right image. 2048 of its frames (7.5 s of work), the cornell-box's 8192 (3.4 s) and 96
# of bdpt's (64 a wait, 16 s) came back right: the cause is not known (docs/gpu.md "Ninth
# session"). CPU rasterizers did not show it.
MAX_QUEUED_FRAMES = 64
# A timed render, or one that reports progress, waits for the GPU to read the clock or report.
# Waiting after every frame costs a GPU the CPU's submission of the next (H100, pt, dining room
# at 1080p: 12.0 against 11.3 ms a frame for the same GPU time; docs/gpu.md "Tenth session"),
# which equal-time comparisons charged to the fastest integrators. Such a render queues, between
# waits, the frames that the frame time measured so far says take TIMED_WAIT_FRACTION of its
# time budget (PROGRESS_INTERVAL_S with progress), at least one and at most MAX_QUEUED_FRAMES:
# a timed render ends at most that fraction (and a frame) past its budget.
TIMED_WAIT_FRACTION = 0.02
PROGRESS_INTERVAL_S = 0.25


@dataclass
class RenderStats:
    frames: int = 0
    spp: int = 0
    dropped_samples: int = 0
    dropped_splats: int = 0  # plugins with splats = true: splats dropped as NaN/Inf
    loop_limited: int = 0  # pixel-frames whose paths the driver's loop limit cut short
    render_seconds: float = 0.0  # wall time of the frames, I/O excluded
    pass_ms: dict = field(default_factory=dict)  # mean GPU time per pass (with timers=True)
    rays: int = 0  # rays traced through the BVH (with count_rays=True)
    error: ErrorEstimate | None = None  # set by Renderer.estimate_error()
    reprojected: int = 0  # frames that began with a reprojection (temporal="reproject": something moved)
    denoiser: str | None = None  # e.g. "atrous, final frame"; None: not denoised
    denoise_runs: int = 0
    denoise_seconds: float = 0.0  # wall time of the denoiser runs (GPU work finished), inside render_seconds

    def summary(self) -> str:
        # The error estimate is the noisy mean's: the denoiser's bias is not in it.
        error = "" if self.error is None else f", est. rel. std. error {100 * self.error.rel_std_error:.2f}%"
        text = (f"{self.spp} spp in {self.render_seconds:.2f} s ({self.frames} frames){error}, "
                f"dropped NaN/Inf samples: {self.dropped_samples}"
                + (f", splats: {self.dropped_splats}" if self.dropped_splats else ""))
        if self.denoiser:
            text += (f"; denoised ({self.denoiser}, {self.denoise_runs} run{'s' if self.denoise_runs != 1 else ''}, "
                     f"{self.denoise_seconds:.3f} s; BIASED: error estimate is of the noisy mean)")
        if self.loop_limited:
            text += (f"; WARNING: in {self.loop_limited} pixel-frames the GL driver's loop limit "
                     "cut paths short (the image is too dark there: lower max_depth, or use a GPU)")
        return text


class Renderer:
    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, integrator: str = "pt",
                 backend: str = "auto", seed: int = 0, params: dict | None = None,
                 samples_per_frame: int | None = None, plugin_dirs=(), features: SceneFeatures | None = None,
                 timers: bool = False, count_rays: bool = False, ctx=None, temporal: str = "reset",
                 min_blend: float = DEFAULT_MIN_BLEND, clamp_sigma: float = 0.0, denoise: str = "off",
                 denoiser: str = "atrous", denoiser_options: dict | None = None, options: Options | None = None):
        """temporal: "reset" (a moved camera or object restarts accumulation) or "reproject"
        (the history is reprojected; min_blend: the least weight a moving frame gets;
        clamp_sigma > 0: clamp the history to the frame's neighbourhood, BIASED).
        denoise: "off", "every" (each frame) or "final" (end of each render()), with `denoiser`
        ("atrous", "onnx", "oidn", "glsl"; lift_gl.denoise): BIASED, labelled as such.
        options: how frames run (lift_gl/options.py: BVH layout, stack, pixel queue, coherent
        sampling, ...), "auto" ones resolved for this device (`choices`, printed by explain())."""
        if temporal not in MODES:
            raise ValueError(f"temporal must be one of {', '.join(MODES)}, not {temporal!r}")
        history_cap(min_blend, 1)  # validates min_blend
        if not clamp_sigma >= 0.0:
            raise ValueError(f"clamp_sigma must be >= 0, not {clamp_sigma!r}")
        self.temporal, self.min_blend, self.clamp_sigma = temporal, float(min_blend), float(clamp_sigma)
        self._frame_camera = self._frame_scene = None  # what the last frame saw (reproject)
        self._prev_positions = None  # the G-buffer's prev_positions SSBO (reproject)
        self._prev_positions_still = False  # whether it holds this scene's positions as they are
        if denoise not in DENOISE_MODES:
            raise DenoiserError(f"unknown denoise mode {denoise!r}; choose one of {', '.join(DENOISE_MODES)}")
        if denoiser not in DENOISERS:
            raise DenoiserError(f"unknown denoiser {denoiser!r}; choose one of {', '.join(DENOISERS)}")
        self.denoise_mode = denoise
        self.denoiser = denoiser
        self.denoiser_options = dict(denoiser_options or {})
        self._numpy_denoiser = None  # onnx / oidn: made once (model loading), kept across resizes
        self.scene = validate_scene(scene)
        self.size = tuple(int(v) for v in (size or scene.film_size))
        self.seed = int(seed)
        # A window hands in its own context (the viewer); otherwise a headless one.
        self.ctx = ctx if ctx is not None else create_context(backend)
        self.options = options if options is not None else Options()
        self.device = Device.of(self.ctx)
        # Hostile sizes are refused here, before any GPU (or BVH) memory is allocated.
        buffer_bytes = self.options.max_buffer_bytes
        self.limits = GlLimits.query(self.ctx, None if buffer_bytes == "auto" else buffer_bytes)
        check_film(self.size, self.limits, scene.path if size is None else None)
        check_triangle_count(scene.triangle_count, self.limits, scene.path)
        self.plugin = find_plugin(integrator, plugin_dirs)
        if self.plugin.language == "opencl" and scene.instances:
            # The OpenCL traversal (passes/trace_cl.py) has one level: instances become world meshes.
            scene = self.scene = flatten_instances(self.scene)
        self.param_overrides = dict(params or {})  # what the caller set; survives a reload
        self.params = self._resolve_params(self.param_overrides)
        self._fixed_features = features  # None: follow the scene (also after edits)
        self.features = features or SceneFeatures.of(scene)
        self.count_rays = count_rays
        self.packed = pack_scene(scene, **self._bvh_layout(self.features))
        self.choices = self._resolve(self.plugin, self.features, self.packed)
        check_packed(self.packed, self.limits, SCENE_BINDINGS, scene.path)
        # On a CPU rasterizer the small scene arrays go in uniform blocks, which llvmpipe reads
        # faster than storage buffers (docs/cpu-speed.md; the option uniform_blocks).
        uniform_blocks = self.choices["uniform_blocks"] == "on"
        block_bytes = int(self.ctx.info.get("GL_MAX_UNIFORM_BLOCK_SIZE", 0)) if uniform_blocks else 0
        self.buffers = SceneBuffers(self.ctx, self.packed, motion=self.features.motion, uniform_block_bytes=block_bytes,
                                    max_buffer_bytes=self.limits.max_ssbo_bytes,  # a big scene is split
                                    instances=self.features.instances)
        self.defines = self._shader_defines()
        env = scene.environment.radiance if scene.environment is not None else (0.0, 0.0, 0.0)
        self.scene_uniforms = self.buffers.uniforms(env)
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        uses_gbuffer = self.plugin.primary == "gbuffer"
        self.samples_per_frame = samples_per_frame or (1 if uses_gbuffer else 4)
        self._samples_per_frame_asked = samples_per_frame  # None: the default of the plugin's primary
        self.use_timers = timers
        self._create_passes()
        self.frame_index = 0
        self.stats = RenderStats(denoiser=self._denoiser_label())
        self.stream_spp = [0, 0]  # samples per pixel so far in each half's low-discrepancy stream
        self.reload_error: LiftError | None = None  # why the last reload failed, until one succeeds
        self.watcher = FileWatcher(self._watched_files())

    def _resolve(self, plugin: Plugin, features: SceneFeatures, packed=None) -> ResolvedOptions:
        """The options' choices for this device, plugin and scene (lift_gl/options.py); before
        the scene is packed (packed None) those that depend on its tree are provisional."""
        work = Workload(language=plugin.language, path_steps=plugin_path_steps(plugin, features.defines()),
                        splats=plugin.splats, motion=features.motion, instances=features.instances,
                        motion_vectors=self.temporal == "reproject", triangles=self.scene.triangle_count,
                        tree=TreeShape.of(packed) if packed is not None else None)
        return resolve(self.options, self.device, work)

    def _bvh_layout(self, features: SceneFeatures) -> dict:
        """pack_scene's BVH settings: the options' choices for this device, plugin and features."""
        choices = self._resolve(self.plugin, features)
        return {"bvh_width": choices["bvh_width"], "bvh_slot_order": choices["bvh_slot_order"],
                "bvh_builder": choices["bvh_builder"]}

    def _shader_defines(self) -> dict:
        # features, arrays in uniform blocks (CPU rasterizers), a big scene's split (scene/split.py)
        defines = dict(self.features.defines(), **self.buffers.defines(), **self.buffers.plan.defines())
        if self.packed.bvh_width != 2:  # the tree's layout (accel/wide.py)
            defines["LIFT_BVH_WIDTH"] = self.packed.bvh_width
            if self.packed.bvh_quantized:
                defines["LIFT_BVH_QUANTIZED"] = True
            defines.update(self._bvh_stack_defines())
            if self.choices["trace_paired"] == "on":
                defines["LIFT_TRACE_PAIRED"] = True
        if self.count_rays:  # compiled in only when asked: one more atomic per pixel and frame
            defines["LIFT_COUNT_RAYS"] = True
        return defines

    def _create_passes(self) -> None:
        """The passes this plugin and resolution need (programs come from the driver's cache on resize)."""
        uses_gbuffer = self.plugin.primary == "gbuffer"
        reproject = self.temporal == "reproject"  # motion vectors need the G-buffer, whatever the primary
        self.gbuffer = self._new_gbuffer(motion_vectors=reproject) if uses_gbuffer or reproject else None
        self.trace = self._create_trace(self.plugin, self.params)
        # A plugin with a [reduced] estimate (hybrid): traced at reduced resolution, upsampled into the frame.
        reduced = self.plugin.reduced is not None
        self.reduced = (ReducedTracePass(self.ctx, self.size, self.plugin, self._plugin_defines(self.plugin, self.params))
                        if reduced else None)
        self.upsample = UpsamplePass(self.ctx, self.size, self.defines) if reduced else None
        self.reproject = ReprojectPass(self.ctx, self.size) if reproject else None
        self.accumulate = AccumulatePass(self.ctx, self.size)
        self.denoise_pass = self._create_denoise_pass() if self.denoise_mode != "off" else None
        self._denoised_spp = None  # stats.spp when the denoised image was made (None: none is current)
        self.tonemap = None  # created on the first display() call: headless float output needs none
        self.tonemap_noisy = None  # display(source="noisy") while denoising: the viewer's split view
        self.timers = {p.name: self._timer() for p in self.passes} if self.use_timers else None

    def _new_gbuffer(self, motion_vectors: bool = False):
        """The raster G-buffer, or on GPUs with few raster units its ray-cast equivalent
        (passes/gbuffer.py; the option gbuffer); motion vectors only come from the raster."""
        if not motion_vectors and self.choices["gbuffer"] == "traced":
            return TracedGBufferPass(self.ctx, self.size, self.defines, stack=self.choices.gbuffer_stack)
        p = self.packed
        return GBufferPass(self.ctx, self.size, self.defines, p.num_world_triangles, p.num_spheres,
                           motion_vectors=motion_vectors, instance_draws=p.instance_draws, raster_rows=p.raster_rows)

    def _create_denoise_pass(self) -> DenoisePass:
        if self.denoiser == "atrous":
            from .passes.atrous import AtrousSettings

            try:
                settings = AtrousSettings(**self.denoiser_options)
            except (TypeError, ValueError) as exc:
                raise DenoiserError(f"à-trous settings: {exc}") from None
            return DenoisePass(self.ctx, self.size, "atrous", settings=settings)
        if self._numpy_denoiser is None:
            from .denoise import get_denoiser

            options = dict(self.denoiser_options)
            if self.denoiser == "glsl":  # its shaders run in the renderer's context, not a second one
                options.setdefault("ctx", self.ctx)
                options.setdefault("ensemble", 1)  # the texture road runs the network once (passes/denoise.py)
            self._numpy_denoiser = get_denoiser(self.denoiser, **options)
        return DenoisePass(self.ctx, self.size, self.denoiser, numpy_denoiser=self._numpy_denoiser)

    def set_denoise(self, mode: str | None = None, denoiser: str | None = None, options: dict | None = None) -> None:
        """Change the denoise mode, denoiser or its options (the viewer's F3 panel);
        accumulation goes on. A denoiser that cannot be made (a missing package, a bad
        option) raises DenoiserError and nothing changes."""
        mode = self.denoise_mode if mode is None else mode
        denoiser = self.denoiser if denoiser is None else denoiser
        options = self.denoiser_options if options is None else dict(options)
        if mode not in DENOISE_MODES:
            raise DenoiserError(f"unknown denoise mode {mode!r}; choose one of {', '.join(DENOISE_MODES)}")
        if denoiser not in DENOISERS:
            raise DenoiserError(f"unknown denoiser {denoiser!r}; choose one of {', '.join(DENOISERS)}")
        if (mode, denoiser, options) == (self.denoise_mode, self.denoiser, self.denoiser_options):
            return
        old = (self.denoise_mode, self.denoiser, self.denoiser_options, self._numpy_denoiser)
        if (denoiser, options) != (self.denoiser, self.denoiser_options):
            self._numpy_denoiser = None
        self.denoise_mode, self.denoiser, self.denoiser_options = mode, denoiser, options
        try:
            new_pass = self._create_denoise_pass() if mode != "off" else None
        except LiftError:
            self.denoise_mode, self.denoiser, self.denoiser_options, self._numpy_denoiser = old
            raise
        if self.denoise_pass is not None:
            self.denoise_pass.release()
        if old[3] is not None and old[3] is not self._numpy_denoiser and hasattr(old[3], "release"):
            old[3].release()  # glsl: its GL buffers and programs
        self.denoise_pass = new_pass
        self._denoised_spp = None
        if self.timers is not None and new_pass is not None:
            self.timers.setdefault("denoise", self._timer())
        self.stats.denoiser = self._denoiser_label()

    def _denoiser_label(self) -> str | None:
        return None if self.denoise_mode == "off" else f"{self.denoiser}, {MODE_WORDS[self.denoise_mode]}"

    # ---- settings ----
    def _resolve_params(self, overrides: dict) -> dict:
        values = self.plugin.defaults()
        if "max_depth" in self.plugin.params and self.scene.max_depth is not None:
            values["max_depth"] = self.plugin.params["max_depth"].parse(int(self.scene.max_depth))
        for name, value in overrides.items():
            if name not in self.plugin.params:
                from .errors import PluginError
                raise PluginError(f"plugin {self.plugin.name!r} has no parameter {name!r} "
                                  f"(it has: {', '.join(self.plugin.params) or 'none'})", self.plugin.manifest)
            values[name] = self.plugin.params[name].parse(value)
        return values

    def set_params(self, **values) -> None:
        """Change plugin parameters; accumulation restarts."""
        params = dict(self.params)
        for name, value in values.items():
            params[name] = self._resolve_params({name: value})[name]  # the others keep their values
        if param_defines(self.plugin, params) != param_defines(self.plugin, self.params):
            self._recompile_plugin(params)  # a compile-time parameter; if it fails, nothing changed
        self.params = params
        self.param_overrides.update(values)
        self.reset()

    def _recompile_plugin(self, params: dict) -> None:
        """New trace (and reduced) programs for these parameters; the other passes stay."""
        trace = self._create_trace(self.plugin, params)
        reduced = None
        if self.reduced is not None:
            try:
                reduced = ReducedTracePass(self.ctx, self.size, self.plugin, self._plugin_defines(self.plugin, params))
            except BaseException:
                trace.release()
                raise
            self.reduced.release()
        self.trace.release()
        self.trace, self.reduced = trace, reduced
        if self.timers is not None:
            for p in self.passes:
                self.timers.setdefault(p.name, self._timer())

    @property
    def camera(self):
        """The scene's camera in the GPU's coordinates (rebased as the scene is: scene/pack.py)."""
        return self.packed.to_gpu_camera(self.scene.camera)

    def set_camera(self, camera) -> None:
        """Look through another camera; only the camera uniforms change, accumulation
        restarts (temporal="reset") or is reprojected on the next frame ("reproject").

        The caller's Scene is not modified (two renderers may share one).
        """
        self.scene = dataclasses.replace(self.scene, camera=camera)
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        if self.temporal != "reproject":
            self.reset()

    def update_scene(self, scene: Scene, geometry: bool = True) -> None:
        """Show an edited scene (the viewer's live edits, lift_gl/scene/edit.py); the camera
        stays the one on screen, accumulation restarts; with temporal="reproject", objects
        that only moved keep their history (reprojected on the next frame), while any other
        change (materials, lights, environment, compiled features) restarts it.

        geometry=False (colours, roughness, emission): the materials buffer is rewritten, and
        the emitter table rebuilt when emission changed. geometry=True (objects moved or
        resized): the scene is re-packed and its BVH rebuilt. Either way only buffers whose
        contents changed are uploaded, and shaders are recompiled only when the scene's
        features change (a first rough material, a first emitter...).
        """
        materials = pack_materials(scene)
        old = self.packed.materials
        same_look = (materials.shape == old.shape and np.array_equal(materials, old)
                     and _environment(scene) == _environment(self.scene)
                     and len(scene.distant_lights) == len(self.scene.distant_lights) == 0
                     and len(scene.textures) == len(self.scene.textures) == 0)
        emission_changed = materials.shape != old.shape or not np.array_equal(materials[:, 1, :3], old[:, 1, :3])
        if self.plugin.language == "opencl" and scene.instances:
            scene = flatten_instances(scene)  # as __init__ does
        if geometry and not emission_changed and only_instances_moved(self.scene, scene):
            packed = repack_instances(self.packed, scene)  # a new TLAS; every BVH below it stays
        elif geometry or emission_changed:
            # a live edit waits for this build: one SAH build, without the second one with
            # finer bins at the top (which can double it for 1.5% of trace time)
            packed = pack_scene(scene, bvh_bins=bins_for_one_build(),
                                **self._bvh_layout(self._fixed_features or SceneFeatures.of(scene)))
        else:
            packed = dataclasses.replace(self.packed, materials=materials)
        self.scene = dataclasses.replace(scene, camera=self.scene.camera)
        self.packed = packed
        self.camera_uniforms = camera_uniforms(self.camera, self.size)  # the origin may have moved
        fixed = self._fixed_features
        self.buffers.instances = fixed.instances if fixed else packed.instances is not None  # HAS_INSTANCES
        self.uploaded = self.buffers.upload(packed)  # names of the buffers rewritten
        if isinstance(self.gbuffer, GBufferPass):  # a rebuilt BVH may store other triangle copies
            self.gbuffer.set_triangles(packed.num_world_triangles, packed.raster_rows)
            self.gbuffer.instance_draws = list(packed.instance_draws)
        env = scene.environment.radiance if scene.environment is not None else (0.0, 0.0, 0.0)
        self.scene_uniforms = self.buffers.uniforms(env)
        features = self._fixed_features or SceneFeatures.of(scene)
        if features != self.features:
            same_look = False
        self.features = features
        self.choices = self._resolve(self.plugin, features, packed)   # the new tree may want another stack
        defines = self._shader_defines()  # features, and arrays that moved into or out of uniform blocks
        if defines != self.defines:
            same_look = False  # new passes: their history starts empty
            self.defines = defines
            for p in self.passes:
                p.release()
            self._create_passes()
        self._prev_positions_still = False
        if not (self.temporal == "reproject" and same_look):
            self.reset()

    def resize(self, size: tuple[int, int]) -> None:
        """Render at another resolution: the scene stays uploaded, the passes are rebuilt,
        accumulation restarts."""
        size = tuple(int(v) for v in size)
        if size == self.size:
            return
        if min(size) <= 0:
            raise ValueError(f"resolution must be positive, not {size}")
        for p in self.passes:
            p.release()
        self.size = size
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        self._create_passes()
        self.reset()

    # ---- hot reload ----
    def _bvh_stack_defines(self, choices: ResolvedOptions | None = None) -> dict:
        """The 4-wide traversal's stack for this tree, device and plugin (the option
        bvh_stack_entries; accel/wide.stack_defines)."""
        p = self.packed
        return bvh_stack_defines(p.bvh_stack, p.bvh_levels, (choices or self.choices)["bvh_stack_entries"])

    def _plugin_defines(self, plugin: Plugin, params: dict, choices: ResolvedOptions | None = None) -> dict:
        """The scene's defines, the plugin's compile-time parameters (`define` in its manifest)
        and coherent sampling; the stack for this plugin (`choices`: a reloaded plugin's)."""
        choices = choices or self.choices
        defines = dict(self.defines)
        if self.packed.bvh_width != 2:
            for key in BVH_STACK_DEFINES:
                defines.pop(key, None)
            defines.update(self._bvh_stack_defines(choices))
        if plugin.language == "glsl":
            defines.update(coherent_defines(choices["coherent_sampling"], choices["coherent_interleave"] or 1))
        return dict(defines, **param_defines(plugin, params))

    def _create_trace(self, plugin: Plugin, params: dict, choices: ResolvedOptions | None = None):
        choices = choices or self.choices
        defines = self._plugin_defines(plugin, params, choices)
        if plugin.language == "opencl":
            from .passes.trace_cl import OpenCLTracePass  # pyopencl only when such a plugin runs

            return OpenCLTracePass(self.ctx, self.size, plugin, defines, self.buffers)
        return TracePass(self.ctx, self.size, plugin, defines, choices)

    def _watched_files(self) -> set:
        """The plugin's own files and every file its program included (the library's too)."""
        return set(self.plugin.source_files()) | {f for f in self.trace.source.files if f.is_file()}

    def reload(self, force: bool = False) -> bool:
        """Recompile the plugin if any of its files changed since the last call (always with
        `force`). True when a new program replaced the old one; accumulation then restarts.

        A broken edit (manifest or shader) raises its PluginError or ShaderError, which names
        the file and line, and the renderer keeps rendering with the last good program.
        `reload_error` keeps that error until an edit compiles; the same broken files are
        reported once, not on every call.
        """
        if not self.watcher.changed() and not force:
            return False
        try:
            plugin = load_manifest(self.plugin.folder)
            params = self._params_after_reload(plugin)
            choices = self._resolve(plugin, self.features, self.packed)   # its path steps or splats may have changed
            trace = self._create_trace(plugin, params, choices)
        except LiftError as exc:
            self.reload_error = exc
            raise
        self.trace.release()
        self.plugin, self.params, self.trace, self.reload_error = plugin, params, trace, None
        self.choices = choices
        if plugin.primary == "gbuffer" and self.gbuffer is None:
            self.gbuffer = self._new_gbuffer()
        elif plugin.primary == "camera" and self.gbuffer is not None and self.reproject is None:
            self.gbuffer.release()  # the plugin now traces its own camera rays
            self.gbuffer = None
        for stale in (getattr(self, "reduced", None), getattr(self, "upsample", None)):
            if stale is not None:
                stale.release()
        reduced = plugin.reduced is not None  # a [reduced] plugin (hybrid) brings its two passes
        self.reduced = (ReducedTracePass(self.ctx, self.size, plugin, self._plugin_defines(plugin, params))
                        if reduced else None)
        self.upsample = UpsamplePass(self.ctx, self.size, self.defines) if reduced else None
        self.samples_per_frame = self._samples_per_frame_asked or (1 if plugin.primary == "gbuffer" else 4)
        if self.timers is not None:
            for p in self.passes:
                self.timers.setdefault(p.name, self._timer())
        self.watcher.watch(self._watched_files())
        self.reset()
        return True

    def _params_after_reload(self, plugin: Plugin) -> dict:
        """The new manifest's defaults, with the caller's settings where they still apply."""
        old, self.plugin = self.plugin, plugin
        try:
            kept = {}
            for name, value in self.param_overrides.items():
                try:
                    kept[name] = self._resolve_params({name: value})[name]
                except LiftError:
                    pass  # the parameter is gone, or its new type or range rejects the value
            return {**self._resolve_params({}), **kept}
        finally:
            self.plugin = old

    @property
    def passes(self) -> list:
        return [p for p in (self.gbuffer, self.trace, self.reduced, self.upsample, self.reproject, self.accumulate,
                            getattr(self, "denoise_pass", None), self.tonemap, getattr(self, "tonemap_noisy", None))
                if p is not None]

    def _triangle_count(self) -> str:
        p = self.packed
        if p.raster_rows is None:
            return f"{p.num_triangles}"
        return (f"{p.num_source_triangles} ({p.num_triangles} stored: the BVH split large ones into "
                f"several references, accel/presplit.py)")

    def explain(self) -> str:
        lines = [f"device: {describe(self.ctx)}",
                 f"scene: {self._triangle_count()} triangles, {self.packed.num_spheres} spheres, "
                 f"{self.packed.num_lights} emitters, BVH depth {self.packed.bvh_depth}",
                 f"integrator: {self.plugin.name} ({self.plugin.folder}), primary hit from {self.plugin.primary}",
                 f"parameters: {', '.join(f'{k}={v}' for k, v in self.params.items())}"]
        if self.plugin.biased:
            lines.append(f"BIASED: {self.plugin.biased}")
        if COHERENT_DEFINE in getattr(self.trace, "defines", {}):
            w, h = self.trace.local_size
            k = int(self.trace.defines.get(INTERLEAVE_DEFINE, 1))
            spread = f" (its pixels {k} apart in a {k * w}x{k * h} block: interleaved)" if k > 1 else ""
            lines.append(f"coherent sampling: the pixels of each {w}x{h} tile{spread} share their random numbers "
                         "(the tiles move every frame; a plugin may draw some of its own: bdpt's light subpaths): "
                         "unbiased per pixel, the noise correlated in blocks"
                         + ("; the denoiser keeps such blocks (docs/denoiser.md)"
                            if self.denoise_pass is not None else ""))
        if self.clamp_sigma > 0 and self.reproject is not None:
            lines.append(f"BIASED: temporal neighbourhood clamp (+-{self.clamp_sigma:g} sigma) on moving frames")
        if self.denoise_pass is not None:
            lines.append(f"BIASED: denoise={self.denoise_mode} ({self.denoiser}): {DENOISER_BIASED}")
        lines.append("passes:")
        reasons = {"gbuffer": "the plugin takes its first hit from the raster G-buffer (primary = \"gbuffer\")"
                              + ("; ray cast, one camera ray a pixel (the option gbuffer)"
                                 if isinstance(self.gbuffer, TracedGBufferPass) else ""),
                   "trace": f"runs {self.plugin.entry}" + self._trace_device(),
                   "reduced": f"runs {self.plugin.reduced.function}() for 1 pixel in "
                              f"{self._reduced_setting('scale')}x{self._reduced_setting('scale')} "
                              "(the plugin's [reduced] table)" if self.plugin.reduced else "",
                   "upsample": "joint bilateral upsampling of the reduced estimate, guided by normal and depth "
                               f"(normal_power {self._reduced_setting('normal_power')}, depth_sigma "
                               f"{self._reduced_setting('depth_sigma')}), added to the frame" if self.plugin.reduced else "",
                   "reproject": "temporal = reproject: runs ONLY on frames where the camera or an object moved "
                                "since the last frame: the history seen from the new camera (motion vectors, "
                                "bilinear taps rejected by depth and normal), capped at "
                                f"{history_cap(self.min_blend, self.samples_per_frame):g} samples "
                                f"(min blend {self.min_blend:g})"
                                + (f", clamped to the frame's neighbourhood (+-{self.clamp_sigma:g} sigma: BIASED)"
                                   if self.clamp_sigma > 0 else ""),
                   "accumulate": "still camera: exact running mean (compensated sum), and the difference "
                                 "of two halves of the frames for the error estimate, and luminance moments"
                                 + ("; after a reprojection it adds the frame to the reprojected history"
                                    if self.reproject is not None else ""),
                   "denoise": self._denoise_reason(),
                   "tonemap": "a display image was asked for (PNG or screen)"}
        if self.reproject is not None:
            reasons["gbuffer"] = ("the reproject pass needs its motion vectors and the previous frame's normal "
                                  "and depth (temporal = reproject)"
                                  + ("; the plugin also takes its first hit from it" if self.plugin.primary == "gbuffer"
                                     else ""))
        for p in self.passes:
            if p is self.tonemap_noisy:
                continue
            outputs = p.outputs + (("motion", "previous normal_depth") if p is self.gbuffer and self.reproject else ())
            lines.append(f"  {p.name:<11} {', '.join(p.inputs)} -> {', '.join(outputs)}: {reasons[p.name]}")
        if self.gbuffer is None:
            lines.append("  (no gbuffer: the plugin traces camera rays, primary = \"camera\")")
        lines.append("scene features compiled in (+) and left out (-):")
        lines += ["  " + f for f in self.features.explain()]
        if self.buffers.in_uniform_block:
            lines.append("scene arrays in uniform blocks, which a CPU rasterizer reads faster than storage "
                         f"buffers (docs/cpu-speed.md): {', '.join(sorted(self.buffers.in_uniform_block))}")
        lines += self._explain_memory()
        lines.append("options (--option KEY=VALUE; lift_gl/options.py):")
        lines += self.choices.explain()
        return "\n".join(lines)

    def _denoise_reason(self) -> str:
        if self.denoise_pass is None:
            return ""
        when = ("after every frame" if self.denoise_mode == "every"
                else "once at the end of each render() call (the final frame)")
        if self.denoiser == "atrous":
            s = self.denoise_pass.atrous.settings
            how = (f"à-trous on the GPU: mean / albedo, {s.iterations} iterations of SVGF edge-stopping "
                   f"(sigma luminance {s.sigma_luminance} x sqrt(variance from the half-buffers), normal "
                   f"{s.sigma_normal}, depth {s.sigma_depth}), x albedo")
        else:
            how = f"{self.denoiser} on the CPU: mean, albedo, normal, depth and variance read back, result uploaded"
        return f"--denoise {self.denoise_mode}: {how}, {when}; guides from an unjittered G-buffer"

    def _explain_instances(self) -> list[str]:
        if not self.scene.instances:
            return []
        p = self.packed
        flattened = len(self.scene.instances) - p.num_instances
        blas = p.instance_blas or {}
        line = (f"instances: {p.num_instances:,} traced through {len(blas)} BLAS "
                f"({sum(len(b.positions) for b, _, _ in blas.values()):,} triangles, built once) under a TLAS of depth "
                f"{p.instance_table.tlas_depth if p.instance_table else 0}")
        if flattened:
            line += (f"; {flattened:,} copied into world space (emissive or moving within the shutter, "
                     "or an OpenCL plugin: lift_gl/scene/instances.py)")
        return [line]

    def _explain_stack(self) -> list[str]:
        """What the trace pass's BVH stack holds and how deep it is (accel/wide.stack_defines)."""
        d = self._plugin_defines(self.plugin, self.params) if self.packed.bvh_width != 2 else {}
        if "LIFT_BVH_STACK_SIZE" not in d:
            return []
        what = "node groups" if d.get("LIFT_BVH_GROUP_STACK") else "child entries"
        if getattr(getattr(self, "trace", None), "shared_stack", None) is False:
            shared = ", in a local array"   # CPU rasterizers; on GPUs pt's queued megakernel (passes/trace.py)
        else:
            shared = (f", the top {d['LIFT_BVH_SHARED_DEPTH']} in shared memory on GPUs"
                      if "LIFT_BVH_SHARED_DEPTH" in d else "")
        paired = ("a path vertex's shadow ray and next ray traced in one loop" if d.get("LIFT_TRACE_PAIRED")
                  else "shadow and next rays traced apart")
        return [f"BVH stack: {d['LIFT_BVH_STACK_SIZE']} {what}{shared}; {paired}"]

    def _explain_memory(self) -> list[str]:
        """The scene's storage buffers, each with its size, and how a big scene was split."""
        p, plan = self.packed, self.buffers.plan
        buffers = self.buffers.memory()
        total = sum(size for _, _, size in buffers)
        lines = [f"BVH: {p.bvh_nodes.shape[0]:,} {'binary' if p.bvh_width == 2 else f'{p.bvh_width}-wide'}{' quantized' if p.bvh_quantized else ''} nodes, "
                 f"depth {p.bvh_depth} (binary), built by {p.bvh_builder} (lift_gl/accel)",
                 *self._explain_stack(),
                 *self._explain_instances(),
                 f"GPU memory, scene storage buffers: {total / (1 << 20):,.1f} MiB in {len(buffers)} buffers "
                 f"(limit {self.limits.max_ssbo_bytes / (1 << 20):,.0f} MiB a buffer)"
                 + (f"; BVH and triangles split into {plan.chunks} buffers of up to "
                    f"{plan.chunk_rows * 16 / (1 << 20):,.1f} MiB" if plan.split else "")]
        lines += [f"  {name:<40} binding {binding:>2}  {size:>14,} bytes" for name, binding, size in buffers]
        return lines

    def _trace_device(self) -> str:
        if self.plugin.language != "opencl":
            queue = ("its lanes taking their next pixel from a queue as their paths end"
                     if getattr(self.trace, "pixel_queue", None) is not None else "")
            carry = getattr(self.trace, "carry", None)
            if getattr(self.trace, "carry_tuning", None) is not None:
                queue += ("; paths under way when the queue runs out may go on in the next frame, if that is "
                          "faster on a render's first frames")
            elif carry is not None:
                queue += (f"; paths under way when the queue runs out go on in the next frame "
                          f"({carry.buffer.size / 2**20:.1f} MiB for them)")
            elif getattr(self.trace, "carry_fallback", None):
                queue += f"; paths are not carried into the next frame: {self.trace.carry_fallback}"
            return f" (megakernel, {queue})" if queue else ""
        from .opencl import describe_device

        return f" as an OpenCL kernel on {describe_device()}; G-buffer read back, frame written to GL"

    # ---- rendering ----
    def reset(self, seed: int | None = None) -> None:
        """Restart accumulation (and the frame sequence), optionally with another seed."""
        if seed is not None:
            self.seed = int(seed)
        self.accumulate.reset()
        discard = getattr(getattr(self, "trace", None), "discard_parked", None)
        if discard is not None:
            discard()   # parked paths' samples belong to the accumulation just dropped
        self.buffers.reset_stats()
        for timer in (self.timers or {}).values():
            timer.total_ns = timer.count = 0
        self.frame_index = 0
        self.stats = RenderStats(denoiser=self._denoiser_label())
        self.stream_spp = [0, 0]  # samples per pixel so far in each half's low-discrepancy stream
        self._frame_camera = self._frame_scene = None  # nothing to reproject from
        self._denoised_spp = None

    def _reduced_setting(self, name: str):
        return self.plugin.reduced.value(name, self.params)

    def _timer(self) -> GpuTimer:
        return GpuTimer(self.ctx, cpu_clock=is_software(self.ctx))

    def _timed(self, name):
        if self.timers is None:
            return _NoTimer()
        return self.timers[name]

    def _compiled_pixel_filter(self):
        """The scene's pixel filter; a box over the pixel where the shaders sample one that the
        scene lacks (compiled with every feature, `--all-features`)."""
        if self.scene.pixel_filter is None and self.features.pixel_filter:
            return PixelFilter("box", (0.5, 0.5))
        return self.scene.pixel_filter

    def render_frame(self, samples: int | None = None, park: bool = False, frames_left: int | None = None) -> None:
        """One frame of `samples` per pixel. `park`: a still camera's paths still under way at
        the frame's end may go on in the next frame's dispatch, which must follow with the same
        camera (passes/carry.py; render() asks for it on every frame but the last).
        `frames_left`: the render's frames from this one on, where known (passes/trace.py)."""
        samples = samples or self.samples_per_frame
        jitter = filtered_jitter(frame_jitter(self.frame_index, self.seed), self.scene.pixel_filter,
                                 self.scene.film_size, self.size)
        # The accumulation's two halves (error estimate) draw from two independent streams.
        stream = 0 if half_sign(self.accumulate.frames) > 0 else 1
        self.buffers.bind()
        moved, motion = self._motion() if self.reproject is not None else (False, None)
        if self.gbuffer is not None:
            with self._timed("gbuffer"):
                # Only a [reduced] plugin's passes read more of it than the trace pass's visibility.
                self.gbuffer.run(self.camera, self.packed.bounds, jitter, self.scene_uniforms, self.camera_uniforms,
                                 motion, visibility_only=self.reduced is None)
        uniforms = dict(self.scene_uniforms, **self.camera_uniforms,
                        **param_uniforms(self.plugin, self.params),
                        u_frame=self.frame_index, u_seed=self.seed & 0xFFFFFFFF, u_samples=samples,
                        u_sample_base=self.stream_spp[stream], u_stream=stream,
                        u_jitter=jitter,
                        **filter_uniforms(self._compiled_pixel_filter(), self.scene.film_size, self.size))
        with self._timed("trace"):
            self.trace.run(uniforms, self.gbuffer.visibility if self.gbuffer is not None else None,
                           park=park and self.reproject is None and self.reduced is None, frames_left=frames_left)
        if self.reduced is not None:
            scale = int(self._reduced_setting("scale"))
            offset = block_offset(self.frame_index, scale)
            with self._timed("reduced"):
                self.reduced.run(uniforms, self.gbuffer, scale, offset)
            with self._timed("upsample"):
                self.upsample.run(self.trace.frame, self.reduced.reduced, self.gbuffer, scale, offset,
                                  self._reduced_setting("normal_power"), self._reduced_setting("depth_sigma"))
        if moved:
            with self._timed("reproject"):
                self.reproject.run(self.accumulate, self.gbuffer, self.trace.frame,
                                   history_cap(self.min_blend, samples), self.clamp_sigma)
            self.stats.reprojected += 1
        with self._timed("accumulate"):
            self.accumulate.run(self.trace.frame, late=getattr(self.trace, "late", None))
        if self.reproject is not None:
            self._frame_camera, self._frame_scene = self.scene.camera, self.scene
        self.frame_index += 1
        self.stats.frames += 1
        self.stats.spp += samples
        self.stream_spp[stream] += samples
        if self.denoise_mode == "every":
            self.run_denoiser()

    def _guides(self):
        """The G-buffer rendered through the pixel centres (no jitter): the denoiser's guides
        and the AOVs match the image's pixels rather than the last frame's subpixel offset."""
        if self.gbuffer is None:
            self.gbuffer = self._new_gbuffer()
        self.buffers.bind()
        motion = None
        if self.gbuffer.motion_vectors:
            # Written into the older normal_depth texture, which the next frame overwrites:
            # the previous frame's, which a reprojection needs, is kept.
            _, motion = self._motion(frame=False)
            self.gbuffer.swap_history()
        self.gbuffer.run(self.camera, self.packed.bounds, (0.5, 0.5), self.scene_uniforms, self.camera_uniforms,
                         motion)
        return self.gbuffer

    def _guides_done(self) -> None:
        """After _guides' textures were read: the frame's own normal and depth are current
        again, and the guides' copy is the older one, which the next frame overwrites."""
        if self.gbuffer.motion_vectors:
            self.gbuffer.swap_history()

    def run_denoiser(self) -> None:
        """Denoise the mean so far (what denoise="every" does after each frame and "final"
        at the end of render()); the viewer calls it for its final frame."""
        if self.denoise_pass is None:
            raise DenoiserError("this renderer was made with denoise='off'")
        start = time.perf_counter()
        gbuffer = self._guides()
        with self._timed("denoise"):
            self.denoise_pass.run(self.accumulate, gbuffer)
        self._guides_done()
        self.ctx.finish()
        self.stats.denoise_seconds += time.perf_counter() - start
        self.stats.denoise_runs += 1
        self._denoised_spp = self.stats.spp

    @property
    def denoised_current(self) -> bool:
        """True when the denoised image is of the mean as it is now."""
        return self.denoise_pass is not None and self._denoised_spp == self.stats.spp and self.stats.spp > 0

    def _motion(self, frame: bool = True) -> tuple[bool, dict]:
        """temporal="reproject": whether something moved since the last frame, and the
        G-buffer's motion-vector uniforms; binds its prev_positions buffer. frame=False (an
        AOV's G-buffer run, not a frame): no motion, and the history is left alone."""
        camera, scene = self.scene.camera, self.scene
        before_camera = self._frame_camera if frame and self._frame_camera is not None else camera
        before_scene = self._frame_scene if frame and self._frame_scene is not None else scene
        objects = objects_moved(before_scene, scene)
        if objects or not self._prev_positions_still:
            rows = previous_positions(self.packed, before_scene if objects else None, scene)
            if self._prev_positions is None or self._prev_positions.size != rows.nbytes:
                if self._prev_positions is not None:
                    self._prev_positions.release()
                self._prev_positions = self.ctx.buffer(reserve=max(rows.nbytes, 16))
            self._prev_positions.write(rows.tobytes())
            self._prev_positions_still = not objects
        self._prev_positions.bind_to_storage_buffer(PREV_POSITIONS_BINDING)
        if frame:
            self.gbuffer.swap_history()  # this frame's normal and depth go into the older texture
        moved = objects or not same_camera(before_camera, camera)
        uniforms = motion_uniforms(self.packed.to_gpu_camera(before_camera), self.camera, self.size, self.packed.bounds)
        uniforms["u_prev_instance_rows"] = 3 * self.packed.num_triangles + self.packed.num_spheres
        return moved, uniforms

    def render(self, spp: int | None = None, seconds: float | None = None, progress=None,
               readback: bool = True, final: bool = True) -> np.ndarray | None:
        """Add spp samples per pixel (or render for `seconds` of wall time); the image so far
        (None with readback=False: the viewer shows the GPU image and reads nothing back).

        With denoise="final" the denoiser runs once at the end, inside the timed render, unless
        final=False (the viewer, whose final frame comes later). The image returned is the
        denoised one when the denoiser ran on the mean as it is now (image())."""
        if spp is None and seconds is None:
            spp = 16
        start = time.perf_counter()
        done = frames = queued = 0
        batch = self._frames_between_waits(seconds, progress is not None, 0.0, 0)   # frames before the next wait
        while True:
            if spp is not None and done >= spp:
                break
            # the clock is read right after a wait; a timed render adds at least one frame: a
            # budget shorter than the clock's first reading must not give a checkpoint with no
            # new sample
            if seconds is not None and done > 0 and queued == 0 and time.perf_counter() - start >= seconds:
                break
            n = self.samples_per_frame if spp is None else min(self.samples_per_frame, spp - done)
            # every frame but the last may leave paths to the next one (a timed render does not
            # know its last frame)
            self.render_frame(n, park=seconds is None and spp is not None and done + n < spp,
                              frames_left=None if spp is None else -(-(spp - done) // self.samples_per_frame))
            done += n
            frames += 1
            queued += 1
            if queued >= batch or (spp is not None and done >= spp):
                self.ctx.finish()
                queued = 0
                if progress is not None:
                    progress(self, done)
                batch = self._frames_between_waits(seconds, progress is not None, time.perf_counter() - start, frames)
        if self.denoise_mode == "final" and final and done > 0:
            self.run_denoiser()
        self.ctx.finish()
        self.stats.render_seconds += time.perf_counter() - start
        counters = self.buffers.read_stats()
        self.stats.dropped_samples = int(counters[STAT_DROPPED])
        self.stats.rays = int(counters[STAT_RAYS_LOW]) + (int(counters[STAT_RAYS_HIGH]) << 32)
        self.stats.dropped_splats = int(counters[STAT_DROPPED_SPLATS])
        self.stats.loop_limited = int(counters[STAT_LOOP_LIMITED])
        if self.timers is not None:
            self.stats.pass_ms = {name: t.mean_ms for name, t in self.timers.items()}
        return self.image() if readback else None

    @staticmethod
    def _frames_between_waits(seconds: float | None, progress: bool, elapsed: float, frames: int) -> int:
        """How many frames render() queues before its next wait (TIMED_WAIT_FRACTION)."""
        if seconds is None and not progress:
            return MAX_QUEUED_FRAMES
        interval = PROGRESS_INTERVAL_S if progress else float("inf")
        if seconds is not None:
            interval = min(interval, TIMED_WAIT_FRACTION * seconds, max(seconds - elapsed, 0.0))
        per_frame = elapsed / max(frames, 1)
        if per_frame <= 0.0:
            return 1
        # (a hair over 1: a frame time read as 0.0100000001 s must still fit 10 in 0.1 s)
        return int(max(1, min(MAX_QUEUED_FRAMES, interval / per_frame * (1.0 + 1e-9))))

    def image(self) -> np.ndarray:
        """The image so far: float32 (H, W, 3), row 0 = top. The denoised radiance when the
        denoiser ran on the mean as it is now, else the mean radiance (noisy_image())."""
        if self.denoised_current:
            return self.denoise_pass.read()
        return self.accumulate.read_mean()

    def noisy_image(self) -> np.ndarray:
        """Mean radiance so far, never denoised: float32 (H, W, 3), row 0 = top."""
        return self.accumulate.read_mean()

    def estimate_error(self) -> ErrorEstimate | None:
        """The relative error of the mean so far, estimated without a reference from the
        accumulation's two half-buffers (lift_gl/error_estimate.py); also kept in stats."""
        self.stats.error = estimate_error(self.accumulate.read_totals(), self.accumulate.read_half_difference())
        return self.stats.error

    def display(self, exposure: float = 0.0, operator: str = "aces", gamma: float | None = None,
                readback: bool = True, source: str = "image") -> np.ndarray | None:
        """The image so far tone-mapped on the GPU: uint8 sRGB (H, W, 3), row 0 = top.

        gamma None encodes with the sRGB curve, a number with x^(1/gamma). With readback=False
        the result stays in the RGBA8 texture `self.tonemap.display` (rows bottom-up) and
        None is returned. source "image": what image() returns (denoised when current);
        "noisy": the mean, into `self.tonemap_noisy.display` when a denoiser is on (the
        viewer's noisy / denoised split view).
        """
        if source not in ("image", "noisy"):
            raise ValueError(f"display source must be 'image' or 'noisy', not {source!r}")
        if source == "noisy" and self.denoise_pass is not None:
            if self.tonemap_noisy is None:
                self.tonemap_noisy = TonemapPass(self.ctx, self.size)
            self.tonemap_noisy.run(self.accumulate, exposure, operator, gamma)
            return self.tonemap_noisy.read() if readback else None
        if self.tonemap is None:
            self.tonemap = TonemapPass(self.ctx, self.size)
            if self.timers is not None:
                self.timers["tonemap"] = self._timer()
        shown = self.denoise_pass if self.denoised_current else self.accumulate
        with self._timed("tonemap"):
            self.tonemap.run(shown, exposure, operator, gamma)
        return self.tonemap.read() if readback else None

    def pixel(self, x: int, y: int) -> tuple[np.ndarray, float]:
        """Mean radiance (float64 RGB) and valid sample count of one pixel; (0, 0) = top left."""
        return self.accumulate.read_pixel(int(x), self.size[1] - 1 - int(y))

    def variance(self) -> np.ndarray:
        """Per pixel, the variance of one frame's luminance estimate, from the first and
        second moments the accumulation keeps: float32 (H, W), row 0 = top (divide by the
        history's frames for the variance of the mean). A denoiser's guide (SVGF-style)."""
        return self.accumulate.read_variance()

    def aov(self, name: str) -> np.ndarray:
        """float32 (H, W, 3), row 0 = top: a G-buffer channel of the current camera (albedo,
        normal, depth), or a view of the accumulation: history (its length in samples, per
        pixel), rejection (the last reprojection's rejected bilinear weight by depth, normal,
        off screen as r, g, b), variance (Renderer.variance), irradiance (radiance / albedo,
        lift_gl.denoise.demodulate)."""
        if name not in AOVS:
            raise ValueError(f"unknown AOV {name!r}; choose one of {', '.join(AOVS)}")
        if name == "history":
            count = self.accumulate.read_totals()[::-1, :, 3:4]
            return np.ascontiguousarray(np.repeat(count, 3, axis=2)).astype(np.float32)
        if name == "rejection":
            if self.reproject is None:
                return np.zeros((self.size[1], self.size[0], 3), np.float32)
            return self.reproject.read_rejection()
        if name == "variance":
            return np.ascontiguousarray(np.repeat(self.variance()[..., None], 3, axis=2))
        if name == "irradiance":
            from .denoise.demodulate import demodulate

            return demodulate(self.image(), self.aov("albedo"))
        self._guides()
        w, h = self.size
        if name == "albedo":
            data = np.frombuffer(self.gbuffer.albedo.read(), np.float16).reshape(h, w, 4)[..., :3]
        else:
            nd = np.frombuffer(self.gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)
            data = nd[..., :3] if name == "normal" else np.repeat(nd[..., 3:4], 3, axis=2)
        self._guides_done()
        return np.ascontiguousarray(data[::-1]).astype(np.float32)

    def release(self) -> None:
        for p in self.passes:
            p.release()
        if self._prev_positions is not None:
            self._prev_positions.release()
        if hasattr(self._numpy_denoiser, "release"):
            self._numpy_denoiser.release()  # glsl: GL objects of this context
            self._numpy_denoiser = None
        self.buffers.release()


def _environment(scene: Scene):
    return None if scene.environment is None else tuple(np.ravel(scene.environment.radiance))


class _NoTimer:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
