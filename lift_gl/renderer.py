"""Renderer: one scene, one integrator, one resolution; renders frames into an accumulation.

    scene = load_scene("scenes/cornell.toml")
    image = Renderer(scene, size=(256, 256), integrator="pt").render(spp=64)  # float32 HxWx3

A frame is: G-buffer (when the plugin takes its first hit from it) -> trace -> accumulate.
Only the passes the settings need are created (see `explain()`).

Hot reload: `reload()` recompiles the plugin when its files changed; a broken edit raises
its error (file and line) and the last good program goes on rendering.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from .error_estimate import ErrorEstimate, estimate_error
from .errors import LiftError
from .gl.context import create_context, describe, is_software
from .passes.accumulate import AccumulatePass, half_sign
from .passes.camera import camera_uniforms, frame_jitter
from .limits import GlLimits, check_film, check_packed, check_triangle_count
from .passes.common import (SCENE_BINDINGS, STAT_DROPPED, STAT_DROPPED_SPLATS, STAT_LOOP_LIMITED, STAT_RAYS_HIGH,
                            STAT_RAYS_LOW, GpuTimer, SceneBuffers)
from .passes.gbuffer import GBufferPass
from .passes.reduced_trace import ReducedTracePass, block_offset
from .passes.tonemap import TonemapPass
from .passes.trace import TracePass, param_uniforms
from .passes.upsample import UpsamplePass
from .plugins import Plugin, find_plugin, load_manifest
from .scene.features import SceneFeatures
from .scene.model import Scene
from .scene.pack import pack_materials, pack_scene
from .scene.validate import validate_scene
from .watch import FileWatcher

AOVS = ("albedo", "normal", "depth")


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

    def summary(self) -> str:
        error = "" if self.error is None else f", est. rel. std. error {100 * self.error.rel_std_error:.2f}%"
        text = (f"{self.spp} spp in {self.render_seconds:.2f} s ({self.frames} frames){error}, "
                f"dropped NaN/Inf samples: {self.dropped_samples}"
                + (f", splats: {self.dropped_splats}" if self.dropped_splats else ""))
        if self.loop_limited:
            text += (f"; WARNING: in {self.loop_limited} pixel-frames the GL driver's loop limit "
                     "cut paths short (the image is too dark there: lower max_depth, or use a GPU)")
        return text


class Renderer:
    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, integrator: str = "pt",
                 backend: str = "auto", seed: int = 0, params: dict | None = None,
                 samples_per_frame: int | None = None, plugin_dirs=(), features: SceneFeatures | None = None,
                 timers: bool = False, count_rays: bool = False, ctx=None):
        self.scene = validate_scene(scene)
        self.size = tuple(int(v) for v in (size or scene.film_size))
        self.seed = int(seed)
        # A window hands in its own context (the viewer); otherwise a headless one.
        self.ctx = ctx if ctx is not None else create_context(backend)
        # Hostile sizes are refused here, before any GPU (or BVH) memory is allocated.
        self.limits = GlLimits.query(self.ctx)
        check_film(self.size, self.limits, scene.path if size is None else None)
        check_triangle_count(scene.triangle_count, self.limits, scene.path)
        self.plugin = find_plugin(integrator, plugin_dirs)
        self.param_overrides = dict(params or {})  # what the caller set; survives a reload
        self.params = self._resolve_params(self.param_overrides)
        self._fixed_features = features  # None: follow the scene (also after edits)
        self.features = features or SceneFeatures.of(scene)
        self.defines = self.features.defines()
        if count_rays:  # compiled in only when asked: one more atomic per pixel and frame
            self.defines["LIFT_COUNT_RAYS"] = True
        self.packed = pack_scene(scene)
        check_packed(self.packed, self.limits, SCENE_BINDINGS, scene.path)
        self.buffers = SceneBuffers(self.ctx, self.packed, motion=self.features.motion,
                                    max_buffer_bytes=self.limits.max_ssbo_bytes)
        self.defines.update(self.buffers.plan.defines())  # a scene split across buffers
        env = scene.environment.radiance if scene.environment is not None else (0.0, 0.0, 0.0)
        self.scene_uniforms = self.buffers.uniforms(env)
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        uses_gbuffer = self.plugin.primary == "gbuffer"
        self.samples_per_frame = samples_per_frame or (1 if uses_gbuffer else 4)
        self._samples_per_frame_asked = samples_per_frame  # None: the default of the plugin's primary
        self.use_timers = timers
        self._create_passes()
        self.frame_index = 0
        self.stats = RenderStats()
        self.stream_spp = [0, 0]  # samples per pixel so far in each half's low-discrepancy stream
        self.reload_error: LiftError | None = None  # why the last reload failed, until one succeeds
        self.watcher = FileWatcher(self._watched_files())

    def _create_passes(self) -> None:
        """The passes this plugin and resolution need (programs come from the driver's cache on resize)."""
        uses_gbuffer = self.plugin.primary == "gbuffer"
        self.gbuffer = (GBufferPass(self.ctx, self.size, self.defines, self.packed.num_triangles,
                                    self.packed.num_spheres) if uses_gbuffer else None)
        self.trace = self._create_trace(self.plugin)
        # A plugin with a [reduced] estimate (hybrid): traced at reduced resolution, upsampled into the frame.
        reduced = self.plugin.reduced is not None
        self.reduced = ReducedTracePass(self.ctx, self.size, self.plugin, self.defines) if reduced else None
        self.upsample = UpsamplePass(self.ctx, self.size, self.defines) if reduced else None
        self.accumulate = AccumulatePass(self.ctx, self.size)
        self.tonemap = None  # created on the first display() call: headless float output needs none
        self.timers = {p.name: self._timer() for p in self.passes} if self.use_timers else None

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
        for name, value in values.items():
            self.params.update(self._resolve_params({name: value}))
            self.param_overrides[name] = value
        self.reset()

    @property
    def camera(self):
        """The scene's camera in the GPU's coordinates (rebased as the scene is: scene/pack.py)."""
        return self.packed.to_gpu_camera(self.scene.camera)

    def set_camera(self, camera) -> None:
        """Look through another camera; only the camera uniforms change, accumulation restarts.

        The caller's Scene is not modified (two renderers may share one).
        """
        self.scene = dataclasses.replace(self.scene, camera=camera)
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        self.reset()

    def update_scene(self, scene: Scene, geometry: bool = True) -> None:
        """Show an edited scene (the viewer's live edits, lift_gl/scene/edit.py); the camera
        stays the one on screen, accumulation restarts.

        geometry=False (colours, roughness, emission): the materials buffer is rewritten, and
        the emitter table rebuilt when emission changed. geometry=True (objects moved or
        resized): the scene is re-packed and its BVH rebuilt. Either way only buffers whose
        contents changed are uploaded, and shaders are recompiled only when the scene's
        features change (a first rough material, a first emitter...).
        """
        materials = pack_materials(scene)
        old = self.packed.materials
        emission_changed = materials.shape != old.shape or not np.array_equal(materials[:, 1, :3], old[:, 1, :3])
        if geometry or emission_changed:
            packed = pack_scene(scene)
        else:
            packed = dataclasses.replace(self.packed, materials=materials)
        self.scene = dataclasses.replace(scene, camera=self.scene.camera)
        self.packed = packed
        self.camera_uniforms = camera_uniforms(self.camera, self.size)  # the origin may have moved
        split_before = self.buffers.plan.defines()
        self.uploaded = self.buffers.upload(packed)  # names of the buffers rewritten
        env = scene.environment.radiance if scene.environment is not None else (0.0, 0.0, 0.0)
        self.scene_uniforms = self.buffers.uniforms(env)
        features = self._fixed_features or SceneFeatures.of(scene)
        if features != self.features or self.buffers.plan.defines() != split_before:
            extra = {k: v for k, v in self.defines.items() if k == "LIFT_COUNT_RAYS"}
            self.features, self.defines = features, {**features.defines(), **self.buffers.plan.defines(), **extra}
            for p in self.passes:
                p.release()
            self._create_passes()
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
    def _create_trace(self, plugin: Plugin):
        if plugin.language == "opencl":
            from .passes.trace_cl import OpenCLTracePass  # pyopencl only when such a plugin runs

            return OpenCLTracePass(self.ctx, self.size, plugin, self.defines, self.buffers)
        return TracePass(self.ctx, self.size, plugin, self.defines)

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
            trace = self._create_trace(plugin)
        except LiftError as exc:
            self.reload_error = exc
            raise
        self.trace.release()
        self.plugin, self.params, self.trace, self.reload_error = plugin, params, trace, None
        if plugin.primary == "gbuffer" and self.gbuffer is None:
            self.gbuffer = GBufferPass(self.ctx, self.size, self.defines, self.packed.num_triangles,
                                       self.packed.num_spheres)
        elif plugin.primary == "camera" and self.gbuffer is not None:
            self.gbuffer.release()  # the plugin now traces its own camera rays
            self.gbuffer = None
        for stale in (getattr(self, "reduced", None), getattr(self, "upsample", None)):
            if stale is not None:
                stale.release()
        reduced = plugin.reduced is not None  # a [reduced] plugin (hybrid) brings its two passes
        self.reduced = ReducedTracePass(self.ctx, self.size, plugin, self.defines) if reduced else None
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
        return [p for p in (self.gbuffer, self.trace, self.reduced, self.upsample, self.accumulate, self.tonemap)
                if p is not None]

    def explain(self) -> str:
        lines = [f"device: {describe(self.ctx)}",
                 f"scene: {self.packed.num_triangles} triangles, {self.packed.num_spheres} spheres, "
                 f"{self.packed.num_lights} emitters, BVH depth {self.packed.bvh_depth}",
                 f"integrator: {self.plugin.name} ({self.plugin.folder}), primary hit from {self.plugin.primary}",
                 f"parameters: {', '.join(f'{k}={v}' for k, v in self.params.items())}"]
        if self.plugin.biased:
            lines.append(f"BIASED: {self.plugin.biased}")
        lines.append("passes:")
        reasons = {"gbuffer": "the plugin takes its first hit from the raster G-buffer (primary = \"gbuffer\")",
                   "trace": f"runs {self.plugin.entry}" + self._trace_device(),
                   "reduced": f"runs {self.plugin.reduced.function}() for 1 pixel in "
                              f"{self._reduced_setting('scale')}x{self._reduced_setting('scale')} "
                              "(the plugin's [reduced] table)" if self.plugin.reduced else "",
                   "upsample": "joint bilateral upsampling of the reduced estimate, guided by normal and depth "
                               f"(normal_power {self._reduced_setting('normal_power')}, depth_sigma "
                               f"{self._reduced_setting('depth_sigma')}), added to the frame" if self.plugin.reduced else "",
                   "accumulate": "still camera: exact running mean (compensated sum), and the difference "
                                 "of two halves of the frames for the error estimate",
                   "tonemap": "a display image was asked for (PNG or screen)"}
        for p in self.passes:
            lines.append(f"  {p.name:<11} {', '.join(p.inputs)} -> {', '.join(p.outputs)}: {reasons[p.name]}")
        if self.gbuffer is None:
            lines.append("  (no gbuffer: the plugin traces camera rays, primary = \"camera\")")
        lines.append("scene features compiled in (+) and left out (-):")
        lines += ["  " + f for f in self.features.explain()]
        lines += self._explain_memory()
        return "\n".join(lines)

    def _explain_memory(self) -> list[str]:
        """The scene's storage buffers, each with its size, and how a big scene was split."""
        p, plan = self.packed, self.buffers.plan
        buffers = self.buffers.memory()
        total = sum(size for _, _, size in buffers)
        lines = [f"BVH: {p.bvh_nodes.shape[0]:,} nodes, depth {p.bvh_depth}, built by {p.bvh_builder} "
                 f"(lift_gl/accel; $LIFT_GL_BVH_BUILDER chooses)",
                 f"GPU memory, scene storage buffers: {total / (1 << 20):,.1f} MiB in {len(buffers)} buffers "
                 f"(limit {self.limits.max_ssbo_bytes / (1 << 20):,.0f} MiB a buffer)"
                 + (f"; BVH and triangles split into {plan.chunks} buffers of up to "
                    f"{plan.chunk_rows * 16 / (1 << 20):,.1f} MiB" if plan.split else "")]
        lines += [f"  {name:<40} binding {binding:>2}  {size:>14,} bytes" for name, binding, size in buffers]
        return lines

    def _trace_device(self) -> str:
        if self.plugin.language != "opencl":
            return ""
        from .opencl import describe_device

        return f" as an OpenCL kernel on {describe_device()}; G-buffer read back, frame written to GL"

    # ---- rendering ----
    def reset(self, seed: int | None = None) -> None:
        """Restart accumulation (and the frame sequence), optionally with another seed."""
        if seed is not None:
            self.seed = int(seed)
        self.accumulate.reset()
        self.buffers.reset_stats()
        for timer in (self.timers or {}).values():
            timer.total_ns = timer.count = 0
        self.frame_index = 0
        self.stats = RenderStats()
        self.stream_spp = [0, 0]  # samples per pixel so far in each half's low-discrepancy stream

    def _reduced_setting(self, name: str):
        return self.plugin.reduced.value(name, self.params)

    def _timer(self) -> GpuTimer:
        return GpuTimer(self.ctx, cpu_clock=is_software(self.ctx))

    def _timed(self, name):
        if self.timers is None:
            return _NoTimer()
        return self.timers[name]

    def render_frame(self, samples: int | None = None) -> None:
        samples = samples or self.samples_per_frame
        jitter = frame_jitter(self.frame_index, self.seed)
        # The accumulation's two halves (error estimate) draw from two independent streams.
        stream = 0 if half_sign(self.accumulate.frames) > 0 else 1
        self.buffers.bind()
        if self.gbuffer is not None:
            with self._timed("gbuffer"):
                self.gbuffer.run(self.camera, self.packed.bounds, jitter, self.scene_uniforms, self.camera_uniforms)
        uniforms = dict(self.scene_uniforms, **self.camera_uniforms,
                        **param_uniforms(self.plugin, self.params),
                        u_frame=self.frame_index, u_seed=self.seed & 0xFFFFFFFF, u_samples=samples,
                        u_sample_base=self.stream_spp[stream], u_stream=stream,
                        u_jitter=jitter)
        with self._timed("trace"):
            self.trace.run(uniforms, self.gbuffer.visibility if self.gbuffer is not None else None)
        if self.reduced is not None:
            scale = int(self._reduced_setting("scale"))
            offset = block_offset(self.frame_index, scale)
            with self._timed("reduced"):
                self.reduced.run(uniforms, self.gbuffer.visibility, scale, offset)
            with self._timed("upsample"):
                self.upsample.run(self.trace.frame, self.reduced.reduced, self.gbuffer, scale, offset,
                                  self._reduced_setting("normal_power"), self._reduced_setting("depth_sigma"))
        with self._timed("accumulate"):
            self.accumulate.run(self.trace.frame)
        self.frame_index += 1
        self.stats.frames += 1
        self.stats.spp += samples
        self.stream_spp[stream] += samples

    def render(self, spp: int | None = None, seconds: float | None = None, progress=None,
               readback: bool = True) -> np.ndarray | None:
        """Add spp samples per pixel (or render for `seconds` of wall time); the mean so far
        (None with readback=False: the viewer shows the GPU image and reads nothing back)."""
        if spp is None and seconds is None:
            spp = 16
        start = time.perf_counter()
        done = 0
        while True:
            if spp is not None and done >= spp:
                break
            if seconds is not None and time.perf_counter() - start >= seconds:
                break
            n = self.samples_per_frame if spp is None else min(self.samples_per_frame, spp - done)
            self.render_frame(n)
            done += n
            if seconds is not None or progress is not None:
                self.ctx.finish()
            if progress is not None:
                progress(self, done)
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

    def image(self) -> np.ndarray:
        """Mean radiance so far: float32 (H, W, 3), row 0 = top."""
        return self.accumulate.read_mean()

    def estimate_error(self) -> ErrorEstimate | None:
        """The relative error of the mean so far, estimated without a reference from the
        accumulation's two half-buffers (lift_gl/error_estimate.py); also kept in stats."""
        self.stats.error = estimate_error(self.accumulate.read_totals(), self.accumulate.read_half_difference())
        return self.stats.error

    def display(self, exposure: float = 0.0, operator: str = "aces", gamma: float | None = None,
                readback: bool = True) -> np.ndarray | None:
        """The mean so far tone-mapped on the GPU: uint8 sRGB (H, W, 3), row 0 = top.

        gamma None encodes with the sRGB curve, a number with x^(1/gamma). With readback=False
        the result stays in the RGBA8 texture `self.tonemap.display` (rows bottom-up) and
        None is returned.
        """
        if self.tonemap is None:
            self.tonemap = TonemapPass(self.ctx, self.size)
            if self.timers is not None:
                self.timers["tonemap"] = self._timer()
        with self._timed("tonemap"):
            self.tonemap.run(self.accumulate, exposure, operator, gamma)
        return self.tonemap.read() if readback else None

    def pixel(self, x: int, y: int) -> tuple[np.ndarray, float]:
        """Mean radiance (float64 RGB) and valid sample count of one pixel; (0, 0) = top left."""
        return self.accumulate.read_pixel(int(x), self.size[1] - 1 - int(y))

    def aov(self, name: str) -> np.ndarray:
        """A G-buffer channel of the current frame, float32 (H, W, 3), row 0 = top."""
        if name not in AOVS:
            raise ValueError(f"unknown AOV {name!r}; choose one of {', '.join(AOVS)}")
        if self.gbuffer is None:
            self.gbuffer = GBufferPass(self.ctx, self.size, self.defines, self.packed.num_triangles,
                                       self.packed.num_spheres)
        self.buffers.bind()
        self.gbuffer.run(self.camera, self.packed.bounds, (0.5, 0.5), self.scene_uniforms, self.camera_uniforms)
        w, h = self.size
        if name == "albedo":
            data = np.frombuffer(self.gbuffer.albedo.read(), np.float16).reshape(h, w, 4)[..., :3]
        else:
            nd = np.frombuffer(self.gbuffer.normal_depth.read(), np.float32).reshape(h, w, 4)
            data = nd[..., :3] if name == "normal" else np.repeat(nd[..., 3:4], 3, axis=2)
        return np.ascontiguousarray(data[::-1]).astype(np.float32)

    def release(self) -> None:
        for p in self.passes:
            p.release()
        self.buffers.release()


class _NoTimer:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
