"""ViewSession: what the viewer shows and does, with no window and no GUI toolkit.

It owns the Renderer (and a second one for the split view), the camera controller, the
sampling target, the reference image and its convergence curve, the bookmarks and the error
log. The window (window.py) feeds it input and draws what it holds; the panels (panels/)
edit its settings. Everything here runs on any moderngl context, so it is tested headless.

All rendering goes through Renderer: `step()` adds samples, `update_display()` tone-maps
into the Renderer's RGBA8 display texture, which the window draws without a read-back.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import metrics
from ..errors import DenoiserError, LiftError
from ..frame_settings import DenoiseSettings
from ..image_io import read_image, write_image, write_srgb8
from ..plugins import discover
from ..renderer import Renderer
from ..scene.loader import load_scene, scene_bounds
from .aov_view import ACCUMULATION_VIEWS, AOV_VIEWS, GBUFFER_VIEWS, aov_to_display
from .bookmarks import Bookmark, bookmarks_path, load_bookmarks, save_bookmarks
from .camera_controller import CameraController
from .scene_editor import SceneEditor

MAX_ERRORS = 20
RELOAD_POLL_S = 0.5  # how often the plugin's files are checked for changes
CONVERGENCE_GROWTH = 1.25  # sample the error at spp 1, 2, 3, 4, 5, 7, 9, ... (x1.25 each time)


@dataclass
class Sampling:
    samples_per_frame: int = 1
    accumulate: bool = True  # off: every frame starts over (see single-frame noise)
    target_spp: int = 0  # 0: no target; the image freezes when reached
    target_seconds: float = 0.0  # 0: no target; render time, as Renderer.stats counts it
    target_frames: int = 0  # 0: no target; scripted runs (--frames N) stop after N frames
    paused: bool = False


@dataclass
class Display:
    exposure: float = 0.0  # stops
    operator: str = "aces"
    gamma: float | None = None  # None: the sRGB curve
    view: str = "render"  # "render" or an AOV name
    split_position: float = 0.5  # of the image width, for the split view


@dataclass
class Denoise:
    """The denoiser settings the viewer keeps across integrators and scenes (F3 panel)."""

    mode: str = "off"  # off | every | final (final: when the image freezes, at its target or paused)
    denoiser: str = "auto"
    options: dict = field(default_factory=dict)  # the à-trous settings (lift_gl/passes/atrous.py)


NOISY_SPLIT = "noisy | denoised"  # a display view: the noisy mean left, the denoised image right


@dataclass
class Resolution:
    window: tuple[int, int] = (1280, 720)  # the image's area: the window less its docked panels, pixels
    scale: float = 1.0  # render resolution / the area's resolution
    moving_scale: float = 1.0  # extra factor while the camera moves (1: off)
    fixed: tuple[int, int] | None = None  # a fixed render resolution (--render-size, a reference)

    def render_size(self, moving: bool = False) -> tuple[int, int]:
        if self.fixed is not None:
            base, factor = self.fixed, 1.0
        else:
            base, factor = self.window, self.scale
        if moving:
            factor *= self.moving_scale
        # Rounded down (never more render pixels than the area holds at this scale), so that at a
        # scale of 1/k the image can be drawn at exactly k x k window pixels a render pixel (fit_rect).
        return (max(1, math.floor(base[0] * factor + 1e-6)), max(1, math.floor(base[1] * factor + 1e-6)))


@dataclass
class FrameTimes:
    """The last frame: wall time of the render step (with a GPU sync) and GPU time per pass."""

    wall_ms: float = 0.0
    pass_ms: dict = field(default_factory=dict)
    samples: int = 0
    pixels: int = 0


@dataclass
class ConvergencePoint:
    seconds: float
    spp: int
    rel_mse: float
    rmse: float


class ErrorLog:
    """Messages the GUI shows until dismissed (shader compile errors, bad files...)."""

    def __init__(self):
        self.entries: list[str] = []

    def add(self, error) -> None:
        text = str(error)
        if text in self.entries:
            self.entries.remove(text)
        self.entries.append(text)
        del self.entries[:-MAX_ERRORS]

    def clear(self) -> None:
        self.entries.clear()


class ViewSession:
    def __init__(self, ctx, scene_path, integrator: str = "pt", params: dict | None = None, seed: int = 0,
                 plugin_dirs=(), resolution: Resolution | None = None, timers: bool = True,
                 temporal: str = "reset", options=None):
        """`options`: the renderers' lift_gl/options.py Options (None: the defaults)."""
        self.ctx = ctx
        self.options = options
        self.temporal = temporal  # Renderer(temporal=...): "reproject" keeps history while the camera moves
        self.seed = int(seed)
        self.plugin_dirs = tuple(plugin_dirs)
        self.timers = timers
        self.resolution = resolution or Resolution()
        self.sampling = Sampling()
        self.display = Display()
        self.denoise = Denoise()
        self.errors = ErrorLog()
        self.moving = False
        self.last_frame = FrameTimes()
        self.compare: Renderer | None = None  # the split view's second integrator
        self.reference: np.ndarray | None = None
        self.reference_path: Path | None = None
        self.reference_factor = 1
        self._fixed_without_reference = self.resolution.fixed
        self.convergence: list[ConvergencePoint] = []
        self._next_convergence_spp = 1
        self._aov_cache: dict[str, np.ndarray] = {}
        self._display_key = None
        self._last_reload_poll = -math.inf
        self.scene_path = Path(scene_path)
        self.scene = load_scene(self.scene_path)
        self.renderer = self._make_renderer(integrator, params or {})
        self._adopt_scene()
        self.editor = SceneEditor(self)  # live edits of lights and materials (Edit panel, F4)

    # ---- construction -------------------------------------------------------------------
    def _make_renderer(self, integrator: str, params: dict, scene=None) -> Renderer:
        try:
            return Renderer(scene or self.scene, size=self.resolution.render_size(self.moving), integrator=integrator,
                            seed=self.seed, params=params, plugin_dirs=self.plugin_dirs, timers=self.timers,
                            ctx=self.ctx, temporal=self.temporal, options=self.options,
                            denoise=DenoiseSettings(self.denoise.mode, self.denoise.denoiser, self.denoise.options))
        except DenoiserError as exc:  # the denoiser went away (a missing package): render without it
            self.errors.add(exc)
            self.denoise = Denoise()
            return self._make_renderer(integrator, params, scene)

    def _adopt_scene(self) -> None:
        bounds = scene_bounds(self.scene)
        diagonal = float(np.linalg.norm(bounds[1] - bounds[0])) if bounds is not None else 1.0
        self.controller = CameraController(self.scene.camera, diagonal)
        self.bookmarks: list[Bookmark] = []
        try:
            self.bookmarks = load_bookmarks(self.bookmarks_file)
        except LiftError as exc:
            self.errors.add(exc)

    @property
    def bookmarks_file(self) -> Path:
        return bookmarks_path(self.scene_path)

    @property
    def renderers(self) -> list[Renderer]:
        return [r for r in (self.renderer, self.compare) if r is not None]

    def _restarted(self) -> None:
        """Accumulation restarted: cached AOVs and the convergence curve belong to the old image."""
        self._aov_cache.clear()
        self._display_key = None
        self.convergence.clear()
        self._next_convergence_spp = 1

    # ---- what the panels change ---------------------------------------------------------
    def open_scene(self, path) -> bool:
        """Load another scene with the same integrator; on error keep the current one."""
        path = Path(path)
        try:
            scene = load_scene(path)
            renderer = self._make_renderer(self.renderer.plugin.name, {}, scene)
        except LiftError as exc:
            self.errors.add(exc)
            return False
        for r in self.renderers:
            r.release()
        self.compare = None
        self.scene, self.scene_path, self.renderer = scene, path, renderer
        self.clear_reference()
        self._adopt_scene()
        self.editor = SceneEditor(self)
        self._restarted()
        return True

    def set_integrator(self, name: str, params: dict | None = None) -> bool:
        """Switch plugins; a plugin that fails to load or compile leaves the last good one running."""
        try:
            renderer = self._make_renderer(name, params or {}, self._current_scene())
        except LiftError as exc:
            self.errors.add(exc)
            return False
        self.renderer.release()
        self.renderer = renderer
        self._restarted()
        return True

    def set_compare(self, name: str | None, params: dict | None = None) -> bool:
        """The split view's right side: another integrator, or None to end the split view."""
        if self.compare is not None:
            self.compare.release()
            self.compare = None
        if name:
            try:
                self.compare = self._make_renderer(name, params or {}, self._current_scene())
            except LiftError as exc:
                self.errors.add(exc)
                return False
        for r in self.renderers:
            r.reset()
        self._restarted()
        return True

    def set_denoise(self, mode: str | None = None, denoiser: str | None = None, options: dict | None = None) -> bool:
        """Denoiser settings of the main renderer (the split view's right integrator stays
        noisy); a denoiser that cannot run (pyoidn missing) is reported and nothing changes."""
        try:
            self.renderer.set_denoise(mode, denoiser, options)
        except LiftError as exc:
            self.errors.add(exc)
            return False
        r = self.renderer
        self.denoise = Denoise(r.denoise_mode, r.denoiser, dict(r.denoiser_options))
        if self.display.view == NOISY_SPLIT and r.denoise_mode == "off":
            self.display.view = "render"
        self._display_key = None
        return True

    def _denoise_final_frame(self) -> None:
        """denoise=final: the image is denoised once, when it freezes (target reached, paused)."""
        r = self.renderer
        if r.denoise_mode == "final" and self.frozen and r.stats.spp > 0 and not r.denoised_current:
            r.run_denoiser()
            self._display_key = None

    def set_param(self, name: str, value, renderer: Renderer | None = None) -> bool:
        try:
            (renderer or self.renderer).set_params(**{name: value})
        except LiftError as exc:
            self.errors.add(exc)
            return False
        self._restarted()
        return True

    def scene_edited(self, geometry: bool) -> bool:
        """self.scene was edited (app/scene_editor.py): every renderer takes it, accumulation
        restarts. geometry: objects moved or resized (re-pack, BVH), else materials only."""
        try:
            for r in self.renderers:
                r.update_scene(self.scene, geometry=geometry)
        except LiftError as exc:
            self.errors.add(exc)
            return False
        self._restarted()
        return True

    def _current_scene(self):
        return self.renderer.scene  # its camera is the one on screen

    def plugins(self) -> dict:
        broken: dict = {}
        found = discover(self.plugin_dirs, broken)
        for folder, exc in broken.items():
            self.errors.add(exc)
        return found

    def restart(self) -> None:
        for r in self.renderers:
            r.reset()
        self._restarted()

    # ---- camera -------------------------------------------------------------------------
    def apply_camera(self) -> None:
        """Send the controller's camera to the renderers (accumulation restarts)."""
        camera = self.controller.camera()
        for r in self.renderers:
            r.set_camera(camera)
        self._restarted()

    def reset_camera(self) -> None:
        self.controller.set_camera(self.scene.camera)
        self.apply_camera()

    def go_to_bookmark(self, index: int) -> None:
        self.controller.set_camera(self.bookmarks[index].camera)
        self.apply_camera()

    def add_bookmark(self, name: str | None = None) -> bool:
        self.bookmarks.append(Bookmark(name or f"view {len(self.bookmarks) + 1}", self.controller.camera()))
        return self.save_bookmarks()

    def delete_bookmark(self, index: int) -> bool:
        del self.bookmarks[index]
        return self.save_bookmarks()

    def save_bookmarks(self) -> bool:
        try:
            save_bookmarks(self.bookmarks_file, self.bookmarks, self.scene_path.name)
        except LiftError as exc:
            self.errors.add(exc)
            return False
        return True

    def set_moving(self, moving: bool) -> None:
        """While the camera moves, render at the lower 'moving' resolution (if one is set)."""
        if moving != self.moving:
            self.moving = moving
            self.apply_resolution()

    # ---- resolution ---------------------------------------------------------------------
    def set_window_size(self, size) -> None:
        """The size of the image's area (the viewer's window less its docked panels), pixels."""
        self.resolution.window = (max(1, int(size[0])), max(1, int(size[1])))
        self.apply_resolution()

    def apply_resolution(self) -> None:
        size = self.resolution.render_size(self.moving)
        if size != self.renderer.size:
            for r in self.renderers:
                r.resize(size)
            self._restarted()

    # ---- frames -------------------------------------------------------------------------
    @property
    def target_reached(self) -> bool:
        s, stats = self.sampling, self.renderer.stats
        if not s.accumulate:
            return False
        return bool(s.target_spp and stats.spp >= s.target_spp
                    or s.target_seconds and stats.render_seconds >= s.target_seconds
                    or s.target_frames and stats.frames >= s.target_frames)

    @property
    def frozen(self) -> bool:
        return self.sampling.paused or self.target_reached

    def poll_reload(self) -> None:
        """Hot reload: `Renderer.reload()` recompiles a plugin whose files changed (True when
        it did, accumulation restarted); a broken edit raises its error, shown in the Errors
        panel, and the last good program keeps running."""
        now = time.perf_counter()
        if now - self._last_reload_poll < RELOAD_POLL_S:
            return
        self._last_reload_poll = now
        for r in self.renderers:
            try:
                if r.reload():
                    self._restarted()
            except LiftError as exc:
                self.errors.add(exc)

    def step(self) -> bool:
        """Render one frame unless frozen; True if samples were added."""
        self.poll_reload()
        if self.frozen:
            return False
        samples = max(1, int(self.sampling.samples_per_frame))
        if self.sampling.target_spp and self.sampling.accumulate:
            samples = min(samples, self.sampling.target_spp - self.renderer.stats.spp)
        start = time.perf_counter()
        for r in self.renderers:
            if not self.sampling.accumulate:
                r.reset()
            r.samples_per_frame = samples  # one Renderer frame of `samples` samples per pixel
            # denoise=every runs inside render(); final waits for the image to freeze.
            r.render(spp=samples, readback=False, final=False)  # ends with a GPU sync: wall time is GPU time
        wall = time.perf_counter() - start
        self._display_key = None
        self._denoise_final_frame()
        self.last_frame = FrameTimes(wall_ms=wall * 1e3, pass_ms=self.pass_times(), samples=samples,
                                     pixels=self.renderer.size[0] * self.renderer.size[1])
        # Sampled at geometrically growing spp (cheap: one read-back each), and at the final image.
        if self.reference is not None and (self.renderer.stats.spp >= self._next_convergence_spp
                                           or self.target_reached):
            self._record_convergence()
        return True

    def pass_times(self) -> dict:
        """Time of each pass in its last run, ms (GPU timer queries; the wall clock on llvmpipe)."""
        timers = self.renderer.timers or {}
        return {name: t.last_ms for name, t in timers.items() if t.count}

    def update_display(self) -> None:
        """Tone-map into the renderers' display textures (only when something changed)."""
        self._denoise_final_frame()  # paused with denoise=final: the frozen image gets denoised
        d = self.display
        r = self.renderer
        key = (id(r), id(self.compare), r.stats.spp, d.exposure, d.operator, d.gamma, r.size, d.view,
               r.denoise_mode, r.denoised_current)
        if key == self._display_key:
            return
        for renderer in self.renderers:
            renderer.display(d.exposure, d.operator, d.gamma, readback=False)
        if d.view == NOISY_SPLIT and r.denoise_pass is not None:
            r.display(d.exposure, d.operator, d.gamma, readback=False, source="noisy")
        self._display_key = key

    def display_textures(self) -> list:
        """The textures the image area shows: one, or the split view's left and right."""
        r = self.renderer
        if self.display.view == NOISY_SPLIT and r.tonemap_noisy is not None and r.tonemap is not None:
            return [r.tonemap_noisy.display, r.tonemap.display]
        return [x.tonemap.display for x in self.renderers if x.tonemap is not None]

    def split_labels(self) -> tuple[str, str] | None:
        """Names of the two sides of the split view, if one is shown."""
        if self.display.view == NOISY_SPLIT and self.renderer.tonemap_noisy is not None:
            return "noisy", f"denoised ({self.renderer.denoiser})"
        if self.compare is not None and self.display.view == "render":
            return self.renderer.plugin.name, self.compare.plugin.name
        return None

    # ---- AOVs and the pixel inspector ---------------------------------------------------
    def _aov_key(self, name: str) -> str:
        # Views of the accumulation change with every frame: cached per sample count.
        return f"{name}@{self.renderer.stats.spp}" if name in ACCUMULATION_VIEWS else name

    def aov(self, name: str) -> np.ndarray:
        """The renderer's AOV for the current camera (float32 H x W x 3, cached)."""
        key = self._aov_key(name)
        if key not in self._aov_cache:
            self._aov_cache[key] = self.renderer.aov(name)
        return self._aov_cache[key]

    def aov_display(self, name: str) -> np.ndarray:
        """uint8 display colours of an AOV (cached with it: the same array until the view changes)."""
        key = "display:" + self._aov_key(name)
        if key not in self._aov_cache:
            self._aov_cache[key] = aov_to_display(name, self.aov(name))
        return self._aov_cache[key]

    def inspect(self, x: int, y: int) -> dict | None:
        """What one render pixel holds: (x, y) from the top left."""
        w, h = self.renderer.size
        if not (0 <= x < w and 0 <= y < h):
            return None
        radiance, samples = self.renderer.pixel(x, y)
        info = {"pixel": (x, y), "radiance": radiance, "samples": samples}
        for name in GBUFFER_VIEWS:  # not the accumulation's views: those would be read back every frame
            info[name] = self.aov(name)[y, x]
        if self.compare is not None:
            info["compare_radiance"] = self.compare.pixel(x, y)[0]
        reference = self._reference_at_size() if self.reference is not None else None
        if reference is not None:
            info["reference"] = reference[y, x]
        return info

    # ---- reference and convergence ------------------------------------------------------
    def load_reference(self, path) -> bool:
        """A reference image (same aspect; its resolution or an integer multiple of the render's).

        The render resolution is locked to the reference's, divided by the smallest integer
        factor that fits the current pixel budget (window x scale), so the error is measured
        against a box-filtered reference without resampling the render.
        """
        path = Path(path)
        try:
            reference = read_image(path)
        except LiftError as exc:
            self.errors.add(exc)
            return False
        h, w = reference.shape[:2]
        budget = self.resolution.render_size()[0] * self.resolution.render_size()[1]
        factor = next((k for k in range(1, 33) if w % k == 0 and h % k == 0 and (w // k) * (h // k) <= budget), None)
        if factor is None:
            factor = max(k for k in range(1, 33) if w % k == 0 and h % k == 0)
        if self.reference is None:
            self._fixed_without_reference = self.resolution.fixed  # --render-size, restored on clear
        self.reference, self.reference_path, self.reference_factor = reference, path, factor
        self.resolution.fixed = (w // factor, h // factor)
        self.apply_resolution()
        self.restart()
        return True

    def clear_reference(self) -> None:
        if self.reference is not None:
            self.resolution.fixed = self._fixed_without_reference
        self.reference = None
        self.reference_path = None
        self.convergence.clear()
        self.apply_resolution()

    def _reference_at_size(self) -> np.ndarray | None:
        """The reference box-filtered to the render's size; None while that size is not the
        reference's over an integer (the camera moving, at moving_scale: 45x55 -> 22x27)."""
        w, h = self.renderer.size
        rh, rw = self.reference.shape[:2]
        if rh % h or rw % w or rh // h != rw // w:
            return None
        return metrics.resize_to(self.reference, (h, w))

    def _record_convergence(self) -> None:
        image = self.renderer.image()
        reference = self._reference_at_size()
        if reference is None:
            return
        stats = self.renderer.stats
        self.convergence.append(ConvergencePoint(stats.render_seconds, stats.spp, metrics.rel_mse(image, reference),
                                                 metrics.rmse(image, reference)))
        self._next_convergence_spp = max(stats.spp + 1, math.ceil(stats.spp * CONVERGENCE_GROWTH))

    # ---- output -------------------------------------------------------------------------
    def screenshot(self, stem) -> list[Path]:
        """stem.png (what the image area shows, tone-mapped, no GUI) and stem.exr (linear radiance)."""
        stem = Path(stem)
        png, exr = stem.with_suffix(".png"), stem.with_suffix(".exr")
        d = self.display
        if d.view in AOV_VIEWS:
            write_srgb8(png, self.aov_display(d.view))
            write_image(exr, self.aov(d.view))
        else:
            write_srgb8(png, self.renderer.display(d.exposure, d.operator, d.gamma))
            write_image(exr, self.renderer.image())
        return [png, exr]

    def statistics(self) -> dict:
        """What the statistics panel shows, also written beside scripted screenshots."""
        r, stats, frame = self.renderer, self.renderer.stats, self.last_frame
        pixels = r.size[0] * r.size[1]
        out = {
            "scene": str(self.scene_path), "integrator": r.plugin.name,
            "compare_integrator": self.compare.plugin.name if self.compare else None,
            "device": f"{self.ctx.info['GL_RENDERER']} | {self.ctx.info['GL_VERSION']}",
            "render_size": list(r.size), "image_area_size": list(self.resolution.window),
            "spp": stats.spp, "frames": stats.frames, "render_seconds": stats.render_seconds,
            "frame_ms": frame.wall_ms, "pass_ms": dict(frame.pass_ms),
            "paths_per_second": pixels * stats.spp / stats.render_seconds if stats.render_seconds > 0 else 0.0,
            "dropped_samples": stats.dropped_samples, "frozen": self.frozen, "target_reached": self.target_reached,
            "params": {k: (list(v) if isinstance(v, (list, tuple)) else v) for k, v in r.params.items()},
            "denoise": r.denoise_mode, "denoiser": r.denoiser if r.denoise_mode != "off" else None,
            "denoise_runs": stats.denoise_runs, "denoised_shown": r.denoised_current,
        }
        if self.convergence:
            last = self.convergence[-1]
            out["rel_mse"] = last.rel_mse
            out["reference"] = str(self.reference_path)
        return out

    def release(self) -> None:
        for r in self.renderers:
            r.release()
