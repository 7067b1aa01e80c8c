"""Renderer: one scene, one integrator, one resolution; renders frames into an accumulation.

    scene = load_scene("scenes/cornell.toml")
    image = Renderer(scene, size=(256, 256), integrator="pt").render(spp=64)  # float32 HxWx3

A frame is a graph of passes (lift_gl/frame_passes.py, passes/graph.py): G-buffer (when the
plugin takes its first hit from it) -> trace -> accumulate, then, with a denoiser
(`denoise="every"` after each frame, `"final"` at the end of each `render()` call), unjittered
G-buffer guides -> denoise. Only the passes the settings need are made (`explain()` lists them).

This class is the front: what a frame runs is in lift_gl/frame.py, the choice of passes in
frame_passes.py, what the shaders are compiled with in compile_settings.py, scene edits in
scene_update.py, hot reload in hot_reload.py, --explain in explain.py, the GPU waits in
gpu_waits.py.

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

import numpy as np

from . import frame, hot_reload, scene_update
from .compile_settings import bvh_layout, plugin_defines, resolve_choices, scene_defines
from .errors import DenoiserError, LiftError
from .error_estimate import ErrorEstimate, estimate_error
from .explain import explain
from .frame_passes import DENOISED, DISPLAY, NOISY_DISPLAY, asked, frame_nodes
from .frame_settings import DenoiseSettings, TemporalSettings
from .gl.context import create_context, is_software
from .gpu_waits import frames_between_waits
from .limits import GlLimits, check_film, check_packed, check_triangle_count
from .options import Device, Options, ResolvedOptions
from .passes.common import SCENE_BINDINGS, GpuTimer, SceneBuffers
from .passes.graph import FrameGraph
from .passes.motion_history import MotionHistory
from .passes.camera import camera_uniforms
from .plugin_params import resolve_params
from .plugins import Plugin, find_plugin, param_defines
from .render_stats import RenderStats
from .scene.features import SceneFeatures
from .scene.instances import flatten_instances
from .scene.model import Scene
from .scene.pack import pack_scene
from .scene.validate import validate_scene

GBUFFER_AOVS = ("albedo", "normal", "depth")
# Views of the accumulation's internals (docs/temporal.md): history length (samples),
# the last reprojection's rejection mask, the frames' luminance variance, radiance / albedo.
AOVS = GBUFFER_AOVS + ("history", "rejection", "variance", "irradiance")
__all__ = ["AOVS", "GBUFFER_AOVS", "RenderStats", "Renderer"]


def _pass(name: str, doc: str) -> property:
    """A renderer attribute for the frame graph's pass `name` (None where the frame has none);
    setting it puts another pass in its place (tests swap in a differently compiled trace)."""
    return property(lambda self: self.graph.get(name), lambda self, made: self.graph.swap(name, made), doc=doc)


class Renderer:
    gbuffer = _pass("gbuffer", "The G-buffer pass (raster or ray cast), or None.")
    prepass = _pass("prepass", "A [prepass] plugin's prepass, or None.")
    trace = _pass("trace", "The plugin's trace pass.")
    reduced = _pass("reduced", "A [reduced] plugin's reduced-resolution trace pass, or None.")
    upsample = _pass("upsample", "A [reduced] plugin's upsample pass, or None.")
    reproject = _pass("reproject", "The reproject pass (temporal=\"reproject\"), or None.")
    accumulate = _pass("accumulate", "The accumulate pass: the running mean and its statistics.")
    denoise_pass = _pass("denoise", "The denoise pass, or None (denoise=\"off\").")
    tonemap = _pass("tonemap", "The tone mapper, made by the first display() call.")
    tonemap_noisy = _pass("tonemap_noisy", "The noisy mean's tone mapper (display(source=\"noisy\")).")

    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, integrator: str = "pt",
                 backend: str = "auto", seed: int = 0, params: dict | None = None,
                 samples_per_frame: int | None = None, plugin_dirs=(), features: SceneFeatures | None = None,
                 timers: bool = False, count_rays: bool = False, ctx=None,
                 temporal: str | TemporalSettings = "reset", denoise: str | DenoiseSettings = "off",
                 options: Options | None = None):
        """temporal: "reset", "reproject" or a TemporalSettings (lift_gl/frame_settings.py:
        min_blend, clamp_sigma). denoise: "off", "every", "final" or a DenoiseSettings (which
        denoiser, its options): BIASED, labelled as such. options: how frames run
        (lift_gl/options.py), "auto" ones resolved for this device (`choices`, in explain()).
        features: compile these SceneFeatures rather than the scene's. timers: GPU time per pass
        (stats.pass_ms); count_rays: count the rays traced (stats.rays)."""
        self.temporal = TemporalSettings.of(temporal)
        self.denoise_asked = DenoiseSettings.of(denoise)  # the denoiser may be "auto": self.denoise has its choice
        self.numpy_denoiser = None  # onnx / oidn / glsl: made once (model loading), kept across resizes
        self.scene = validate_scene(scene)
        self.size = tuple(int(v) for v in (size or scene.film_size))
        self.seed = int(seed)
        # A window hands in its own context (the viewer); otherwise a headless one.
        self.ctx = ctx if ctx is not None else create_context(backend)
        self.options = options if options is not None else Options()
        self.device = Device.of(self.ctx)
        self.denoise, self.denoise_choice = self.denoise_asked.resolved(self.device.software)
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
        self.params = resolve_params(self.plugin, self.scene, self.param_overrides)
        self.fixed_features = features  # None: follow the scene (also after edits)
        self.features = features or SceneFeatures.of(scene)
        self.count_rays = count_rays
        self.packed = pack_scene(scene, **bvh_layout(self.resolve_choices(self.plugin, self.features)))
        self.choices = self.resolve_choices(self.plugin, self.features, self.packed)
        check_packed(self.packed, self.limits, SCENE_BINDINGS, scene.path)
        # On a CPU rasterizer the small scene arrays go in uniform blocks, which llvmpipe reads
        # faster than storage buffers (docs/cpu-speed.md; the option uniform_blocks).
        uniform_blocks = self.choices["uniform_blocks"] == "on"
        block_bytes = int(self.ctx.info.get("GL_MAX_UNIFORM_BLOCK_SIZE", 0)) if uniform_blocks else 0
        self.buffers = SceneBuffers(self.ctx, self.packed, motion=self.features.motion, uniform_block_bytes=block_bytes,
                                    max_buffer_bytes=self.limits.max_ssbo_bytes,  # a big scene is split
                                    instances=self.features.instances)
        self.defines = self._shader_defines()
        self.scene_uniforms = self.buffers.uniforms(scene_update.environment_radiance(scene))
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        self.samples_per_frame_asked = samples_per_frame  # None: the default of the plugin's primary
        self.samples_per_frame = samples_per_frame or (1 if self.plugin.primary == "gbuffer" else 4)
        self.timers = {} if timers else None
        self.motion_history = MotionHistory(self.ctx)
        self.graph = FrameGraph(frame_nodes(self), asked(self), on_make=self._made)
        self._denoised_spp = None  # stats.spp when the denoised image was made (None: none is current)
        self._denoised_on_frame_guides = False  # the last denoise used the frame's jittered G-buffer
        self.frame_index = 0
        self.stats = RenderStats(denoiser=self.denoise.label())
        self.stream_spp = [0, 0]  # samples per pixel so far in each half's low-discrepancy stream
        self.reload_error: LiftError | None = None  # why the last reload failed, until one succeeds
        self.watcher = hot_reload.new_watcher(self)

    # ---- what the shaders are compiled with (compile_settings.py) ----
    def resolve_choices(self, plugin: Plugin, features: SceneFeatures, packed=None, scene=None) -> ResolvedOptions:
        """The options' choices for this device, plugin and scene (`scene`: an edit's, before it
        replaces self.scene; provisional before packing)."""
        return resolve_choices(self.options, self.device, plugin, features, scene or self.scene, packed)

    def _shader_defines(self) -> dict:
        """Every program's defines for this scene (a subclass may add its own)."""
        return scene_defines(self.features, self.buffers, self.packed, self.choices, self.count_rays)

    def plugin_defines(self, plugin: Plugin, params: dict, choices: ResolvedOptions | None = None) -> dict:
        """The defines of a plugin's programs: the scene's and the plugin's own."""
        return plugin_defines(self.defines, self.packed, plugin, params, choices or self.choices)

    # ---- the frame's passes (frame_passes.py, passes/graph.py) ----
    @property
    def passes(self) -> list:
        """The frame's passes, in the order they run."""
        return self.graph.passes

    def _made(self, name: str, made) -> None:
        if self.timers is not None and name != "tonemap_noisy":
            self.timers.setdefault(name, self._timer())

    def remake_passes(self) -> None:
        """Every pass made anew (new defines or a new size); the scene stays uploaded."""
        self.graph.rebuild(frame_nodes(self), remake=True)
        self._denoised_spp = None

    def remake_plugin_passes(self, plugin: Plugin, params: dict, choices: ResolvedOptions,
                             remake=("prepass", "trace", "reduced", "upsample")) -> None:
        """The plugin's passes (trace, a [reduced] plugin's two) for another manifest or other
        compile-time parameters; a G-buffer made or dropped as the plugin's primary hit needs.
        If one fails to compile, every pass stays as it was."""
        self.graph.rebuild(frame_nodes(self, plugin, params, choices), remake=set(remake))

    def _timer(self) -> GpuTimer:
        return GpuTimer(self.ctx, cpu_clock=is_software(self.ctx))

    def timed(self, name: str):
        """The GPU timer of pass `name` as a context (a no-op without timers)."""
        return self.timers[name] if self.timers is not None else _NoTimer()

    # ---- settings ----
    @property
    def denoise_mode(self) -> str:
        return self.denoise.mode

    @property
    def denoiser(self) -> str:
        return self.denoise.denoiser

    @property
    def denoiser_options(self) -> dict:
        return self.denoise.options

    def set_denoise(self, mode: str | None = None, denoiser: str | None = None, options: dict | None = None) -> None:
        """Change the denoise mode, denoiser or its options (the viewer's F3 panel);
        accumulation goes on. A denoiser that cannot be made (a missing package, a bad
        option) raises DenoiserError and nothing changes."""
        old, old_asked, old_choice = self.denoise, self.denoise_asked, self.denoise_choice
        mode = old_asked.mode if mode is None else mode
        if denoiser is None:  # options tune the denoiser the mode will use, which "auto" may stand for
            denoiser = old_asked.denoiser
            if options and denoiser == "auto":
                denoiser = DenoiseSettings(mode).resolved(self.device.software)[0].denoiser
        new_asked = DenoiseSettings(mode, denoiser, old.options if options is None else options)
        new, choice = new_asked.resolved(self.device.software)
        self.denoise_asked, self.denoise_choice = new_asked, choice
        if new == old:
            return
        old_numpy = self.numpy_denoiser
        if (new.denoiser, new.options) != (old.denoiser, old.options):
            self.numpy_denoiser = None
        self.denoise = new
        try:
            self.graph.rebuild(frame_nodes(self), asked(self) + tuple(a for a in self.graph.asked if a != DENOISED),
                               remake={"denoise"})
        except LiftError:
            self.denoise, self.denoise_asked, self.denoise_choice, self.numpy_denoiser = (old, old_asked, old_choice,
                                                                                          old_numpy)
            raise
        if old_numpy is not None and old_numpy is not self.numpy_denoiser and hasattr(old_numpy, "release"):
            old_numpy.release()  # glsl: its GL buffers and programs
        self._denoised_spp = None
        self.stats.denoiser = self.denoise.label()

    def set_params(self, **values) -> None:
        """Change plugin parameters; accumulation restarts."""
        params = dict(self.params)
        for name, value in values.items():
            params[name] = resolve_params(self.plugin, self.scene, {name: value})[name]  # the others keep theirs
        prepass = self.plugin.prepass
        if param_defines(self.plugin, params) != param_defines(self.plugin, self.params) or \
                prepass is not None and prepass.entry_count(params) != prepass.entry_count(self.params):
            # a compile-time parameter or the prepass's storage: new programs; if one fails, nothing changed
            self.remake_plugin_passes(self.plugin, params, self.choices, remake=("prepass", "trace", "reduced"))
        self.params = params
        self.param_overrides.update(values)
        self.reset()

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
        if not self.temporal.reproject:
            self.reset()

    def update_scene(self, scene: Scene, geometry: bool = True) -> None:
        """Show an edited scene (the viewer's live edits, lift_gl/scene/edit.py); the camera
        stays the one on screen. With temporal="reproject", objects that only moved keep their
        history (reprojected on the next frame); any other change (materials, lights,
        environment, compiled features) restarts accumulation. geometry=False: colours,
        roughness, emission; True: objects moved or resized. Only buffers whose contents
        changed are uploaded, and shaders recompiled only when the scene's features change
        (lift_gl/scene_update.py)."""
        keeps_history = scene_update.update_scene(self, scene, geometry)
        if not (self.temporal.reproject and keeps_history):
            self.reset()

    def resize(self, size: tuple[int, int]) -> None:
        """Render at another resolution: the scene stays uploaded, the passes are rebuilt,
        accumulation restarts."""
        size = tuple(int(v) for v in size)
        if size == self.size:
            return
        if min(size) <= 0:
            raise ValueError(f"resolution must be positive, not {size}")
        self.size = size
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        self.remake_passes()
        self.reset()

    def reload(self, force: bool = False) -> bool:
        """Recompile the plugin if any of its files changed since the last call (always with
        `force`). True when a new program replaced the old one; accumulation then restarts.

        A broken edit (manifest or shader) raises its PluginError or ShaderError, which names
        the file and line, and the renderer keeps rendering with the last good program.
        `reload_error` keeps that error until an edit compiles (lift_gl/hot_reload.py)."""
        if not hot_reload.reload(self, force):
            return False
        self.reset()
        return True

    def explain(self) -> str:
        """What this renderer runs and why (`lift-gl render --explain`; lift_gl/explain.py)."""
        return explain(self)

    # ---- rendering ----
    def reset(self, seed: int | None = None) -> None:
        """Restart accumulation (and the frame sequence), optionally with another seed."""
        if seed is not None:
            self.seed = int(seed)
        self.accumulate.reset()
        discard = getattr(self.trace, "discard_parked", None)
        if discard is not None:
            discard()   # parked paths' samples belong to the accumulation just dropped
        self.buffers.reset_stats()
        for timer in (self.timers or {}).values():
            timer.total_ns = timer.count = 0
        self.frame_index = 0
        self.stats = RenderStats(denoiser=self.denoise.label())
        self.stream_spp = [0, 0]
        self.motion_history.forget()  # nothing to reproject from
        self._denoised_spp = None
        self._denoised_on_frame_guides = False

    def render_frame(self, samples: int | None = None, park: bool = False) -> None:
        """One frame of `samples` per pixel (lift_gl/frame.py). `park`: a still camera's paths
        still under way at the frame's end may go on in the next frame's dispatch, which must
        follow with the same camera (passes/carry.py; render() asks for it on every frame but
        the last)."""
        frame.render_frame(self, samples or self.samples_per_frame, park)
        if self.denoise.mode == "every":
            self.run_denoiser(frame_guides=frame.frame_guides(self))

    def run_denoiser(self, frame_guides: bool = False) -> None:
        """Denoise the mean so far (what denoise="every" does after each frame and "final"
        at the end of render()); the viewer calls it for its final frame. frame_guides: the
        guides are the last frame's G-buffer (frame.frame_guides), not a G-buffer through the
        pixel centres."""
        if self.denoise_pass is None:
            raise DenoiserError("this renderer was made with denoise='off'")
        start = time.perf_counter()
        gbuffer = self.gbuffer if frame_guides else frame.guides(self)
        with self.timed("denoise"):
            self.denoise_pass.run(self.accumulate, gbuffer, frame_guides)  # history: the frame's own guides
        if not frame_guides:
            frame.guides_done(self)
        self._denoised_on_frame_guides = frame_guides
        self.stats.denoise_runs += 1
        self._denoised_spp = self.stats.spp
        if not frame_guides:
            # a frame's denoise (denoise="every") is not waited for: a wait here would keep the
            # CPU from preparing the next frame while the GPU works (its time: the per-pass timers)
            self.ctx.finish()
            self.stats.denoise_seconds += time.perf_counter() - start

    @property
    def denoised_current(self) -> bool:
        """True when the denoised image is of the mean as it is now."""
        return self.denoise_pass is not None and self._denoised_spp == self.stats.spp and self.stats.spp > 0

    def render(self, spp: int | None = None, seconds: float | None = None, progress=None,
               readback: bool = True, final: bool = True) -> np.ndarray | None:
        """Add spp samples per pixel (or render for `seconds` of wall time); the image so far
        (None with readback=False: the viewer shows the GPU image and reads nothing back).

        With denoise="final" the denoiser runs once at the end, inside the timed render, unless
        final=False (the viewer, whose final frame comes later). The image returned is the
        denoised one when the denoiser ran on the mean as it is now (image()).

        progress: a callable `progress(renderer, done)` (lift_gl/progress.py), or True for a
        progress bar made and closed here (tqdm's notebook form in Jupyter)."""
        if spp is None and seconds is None:
            spp = 16
        if spp is not None and not (isinstance(spp, (int, np.integer)) and spp >= 1):
            raise ValueError(f"spp must be a whole number of at least 1, not {spp!r}")
        if seconds is not None and not (isinstance(seconds, (int, float)) and 0 < seconds < float("inf")):
            raise ValueError(f"seconds must be finite and above 0, not {seconds!r}")
        if progress is True:
            from .progress import RenderProgress

            bar = RenderProgress(spp=spp, seconds=seconds)
            try:
                return self.render(spp, seconds, bar, readback, final)
            finally:
                bar.close()
        start = time.perf_counter()
        done = frames = queued = 0
        batch = frames_between_waits(seconds, progress is not None, 0.0, 0)   # frames before the next wait
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
            self.render_frame(n, park=seconds is None and spp is not None and done + n < spp)
            done += n
            frames += 1
            queued += 1
            if queued >= batch or (spp is not None and done >= spp):
                self.ctx.finish()
                queued = 0
                if progress is not None:
                    progress(self, done)
                batch = frames_between_waits(seconds, progress is not None, time.perf_counter() - start, frames)
        # denoise="every" ends a final image as "final" does: denoised on guides through the
        # pixel centres, not on the last frame's jittered ones (the same image either way)
        if final and done > 0 and (self.denoise.mode == "final" or self._denoised_on_frame_guides):
            self.run_denoiser()
        self.ctx.finish()
        self.stats.render_seconds += time.perf_counter() - start
        self.stats.read_counters(self.buffers.read_stats())
        if self.timers is not None:
            self.stats.pass_ms = {name: t.mean_ms for name, t in self.timers.items()}
        return self.image() if readback else None

    # ---- what it shows ----
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
            self.graph.ask(NOISY_DISPLAY)
            self.tonemap_noisy.run(self.accumulate, exposure, operator, gamma)
            return self.tonemap_noisy.read() if readback else None
        self.graph.ask(DISPLAY)
        shown = self.denoise_pass if self.denoised_current else self.accumulate
        with self.timed("tonemap"):
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
        gbuffer = frame.guides(self)
        w, h = self.size
        if name == "albedo":
            data = np.frombuffer(gbuffer.albedo.read(), np.float16).reshape(h, w, 4)[..., :3]
        else:
            nd = np.frombuffer(gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)
            data = nd[..., :3] if name == "normal" else np.repeat(nd[..., 3:4], 3, axis=2)
        frame.guides_done(self)
        return np.ascontiguousarray(data[::-1]).astype(np.float32)

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows a renderer as its image so far, tone-mapped (lift_gl/notebook/display.py)."""
        from .notebook.display import renderer_png

        return renderer_png(self)

    def release(self) -> None:
        self.graph.release()
        self.motion_history.release()
        if hasattr(self.numpy_denoiser, "release"):
            self.numpy_denoiser.release()  # glsl: GL objects of this context
            self.numpy_denoiser = None
        self.buffers.release()


class _NoTimer:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
