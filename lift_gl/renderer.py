"""Renderer: one scene, one integrator, one resolution; renders frames into an accumulation.

    scene = load_scene("scenes/cornell.toml")
    image = Renderer(scene, size=(256, 256), integrator="pt").render(spp=64)  # float32 HxWx3

A frame is: G-buffer (when the plugin takes its first hit from it) -> trace -> accumulate.
Only the passes the settings need are created (see `explain()`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .gl.context import create_context, describe
from .passes.accumulate import AccumulatePass
from .passes.camera import camera_uniforms, frame_jitter
from .limits import GlLimits, check_film, check_packed, check_triangle_count
from .passes.common import SCENE_BINDINGS, STAT_DROPPED, STAT_LOOP_LIMITED, GpuTimer, SceneBuffers
from .passes.gbuffer import GBufferPass
from .passes.tonemap import TonemapPass
from .passes.trace import TracePass, param_uniforms
from .plugins import find_plugin
from .scene.features import SceneFeatures
from .scene.model import Scene
from .scene.pack import pack_scene
from .scene.validate import validate_scene

AOVS = ("albedo", "normal", "depth")


@dataclass
class RenderStats:
    frames: int = 0
    spp: int = 0
    dropped_samples: int = 0
    loop_limited: int = 0  # pixel-frames whose paths the driver's loop limit cut short
    render_seconds: float = 0.0  # wall time of the frames, I/O excluded
    pass_ms: dict = field(default_factory=dict)  # mean GPU time per pass (with timers=True)

    def summary(self) -> str:
        text = (f"{self.spp} spp in {self.render_seconds:.2f} s ({self.frames} frames), "
                f"dropped NaN/Inf samples: {self.dropped_samples}")
        if self.loop_limited:
            text += (f"; WARNING: in {self.loop_limited} pixel-frames the GL driver's loop limit "
                     "cut paths short (the image is too dark there: lower max_depth, or use a GPU)")
        return text


class Renderer:
    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, integrator: str = "pt",
                 backend: str = "auto", seed: int = 0, params: dict | None = None,
                 samples_per_frame: int | None = None, plugin_dirs=(), features: SceneFeatures | None = None,
                 timers: bool = False):
        self.scene = validate_scene(scene)
        self.size = tuple(int(v) for v in (size or scene.film_size))
        self.seed = int(seed)
        self.ctx = create_context(backend)
        # Hostile sizes are refused here, before any GPU (or BVH) memory is allocated.
        self.limits = GlLimits.query(self.ctx)
        check_film(self.size, self.limits, scene.path if size is None else None)
        check_triangle_count(scene.triangle_count, self.limits, scene.path)
        self.plugin = find_plugin(integrator, plugin_dirs)
        self.params = self._resolve_params(params or {})
        self.features = features or SceneFeatures.of(scene)
        self.defines = self.features.defines()
        self.packed = pack_scene(scene)
        check_packed(self.packed, self.limits, SCENE_BINDINGS, scene.path)
        self.camera = self.packed.to_gpu_camera(scene.camera)  # rebased as the scene is (pack.py)
        self.buffers = SceneBuffers(self.ctx, self.packed)
        env = scene.environment.radiance if scene.environment is not None else (0.0, 0.0, 0.0)
        self.scene_uniforms = self.buffers.uniforms(env)
        self.camera_uniforms = camera_uniforms(self.camera, self.size)
        uses_gbuffer = self.plugin.primary == "gbuffer"
        self.samples_per_frame = samples_per_frame or (1 if uses_gbuffer else 4)
        self.gbuffer = (GBufferPass(self.ctx, self.size, self.defines, self.packed.num_triangles,
                                    self.packed.num_spheres) if uses_gbuffer else None)
        self.trace = TracePass(self.ctx, self.size, self.plugin, self.defines)
        self.accumulate = AccumulatePass(self.ctx, self.size)
        self.tonemap = None  # created on the first display() call: headless float output needs none
        self.timers = {p.name: GpuTimer(self.ctx) for p in self.passes} if timers else None
        self.frame_index = 0
        self.stats = RenderStats()

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
        self.reset()

    @property
    def passes(self) -> list:
        return [p for p in (self.gbuffer, self.trace, self.accumulate, self.tonemap) if p is not None]

    def explain(self) -> str:
        lines = [f"device: {describe(self.ctx)}",
                 f"scene: {self.packed.num_triangles} triangles, {self.packed.num_spheres} spheres, "
                 f"{self.packed.num_lights} emitters, BVH depth {self.packed.bvh_depth}",
                 f"integrator: {self.plugin.name} ({self.plugin.folder}), primary hit from {self.plugin.primary}",
                 f"parameters: {', '.join(f'{k}={v}' for k, v in self.params.items())}",
                 "passes:"]
        reasons = {"gbuffer": "the plugin takes its first hit from the raster G-buffer (primary = \"gbuffer\")",
                   "trace": f"runs {self.plugin.entry}",
                   "accumulate": "still camera: exact running mean (compensated sum)",
                   "tonemap": "a display image was asked for (PNG or screen)"}
        for p in self.passes:
            lines.append(f"  {p.name:<11} {', '.join(p.inputs)} -> {', '.join(p.outputs)}: {reasons[p.name]}")
        if self.gbuffer is None:
            lines.append("  (no gbuffer: the plugin traces camera rays, primary = \"camera\")")
        lines.append("scene features compiled in (+) and left out (-):")
        lines += ["  " + f for f in self.features.explain()]
        return "\n".join(lines)

    # ---- rendering ----
    def reset(self) -> None:
        self.accumulate.reset()
        self.buffers.reset_stats()
        self.frame_index = 0
        self.stats = RenderStats()

    def _timed(self, name):
        if self.timers is None:
            return _NoTimer()
        return self.timers[name]

    def render_frame(self, samples: int | None = None) -> None:
        samples = samples or self.samples_per_frame
        jitter = frame_jitter(self.frame_index, self.seed)
        self.buffers.bind()
        if self.gbuffer is not None:
            with self._timed("gbuffer"):
                self.gbuffer.run(self.camera, self.packed.bounds, jitter, self.scene_uniforms, self.camera_uniforms)
        uniforms = dict(self.scene_uniforms, **self.camera_uniforms,
                        **param_uniforms(self.plugin, self.params),
                        u_frame=self.frame_index, u_seed=self.seed & 0xFFFFFFFF, u_samples=samples,
                        u_jitter=jitter)
        with self._timed("trace"):
            self.trace.run(uniforms, self.gbuffer.visibility if self.gbuffer is not None else None)
        with self._timed("accumulate"):
            self.accumulate.run(self.trace.frame)
        self.frame_index += 1
        self.stats.frames += 1
        self.stats.spp += samples

    def render(self, spp: int | None = None, seconds: float | None = None, progress=None) -> np.ndarray:
        """Add spp samples per pixel (or render for `seconds` of wall time); the mean so far."""
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
        self.stats.loop_limited = int(counters[STAT_LOOP_LIMITED])
        if self.timers is not None:
            self.stats.pass_ms = {name: t.mean_ms for name, t in self.timers.items()}
        return self.image()

    def image(self) -> np.ndarray:
        """Mean radiance so far: float32 (H, W, 3), row 0 = top."""
        return self.accumulate.read_mean()

    def display(self, exposure: float = 0.0, operator: str = "aces") -> np.ndarray:
        """The mean so far tone-mapped on the GPU: uint8 sRGB (H, W, 3), row 0 = top."""
        if self.tonemap is None:
            self.tonemap = TonemapPass(self.ctx, self.size)
        self.tonemap.run(self.accumulate, exposure, operator)
        return self.tonemap.read()

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
