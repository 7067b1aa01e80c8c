"""The viewer's main window: moderngl-window for the GL 4.3 context and input, imgui-bundle for
the panels. Each frame: input -> camera -> the panels, docked beside the image (layout.py), which
give the image its area -> ViewSession.step() at a resolution that follows that area (the
Renderer adds samples) -> tone-map on the GPU -> draw the display texture in its area -> draw
the panels -> swap.

Scripted runs (`frames`, `screenshot`) render that many frames, save the window with its
GUI as a PNG (plus the statistics and panel rectangles as JSON beside it) and return.
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import moderngl_window as mglw
import numpy as np
from imgui_bundle import imgui, implot
from moderngl_window.conf import settings

from ..errors import LiftError
from ..gl.context import is_software
from ..image_io import write_srgb8
from .aov_view import AOV_VIEWS
from .image_view import ImageView, fit_rect, window_to_pixel
from .imgui_renderer import ImguiRenderer
from .layout import DockLayout, gui_window_at
from .panels import UiState, make_panels
from .session import Resolution, ViewSession

WINDOW_CLASSES = {"pyglet": "moderngl_window.context.pyglet.Window",
                  "glfw": "moderngl_window.context.glfw.Window",
                  "headless": "moderngl_window.context.headless.Window"}
MOVING_HOLD_S = 0.25  # the camera counts as moving this long after the last motion
MAX_FLY_STEP_S = 1.0  # a longer frame (a shader compile) does not throw the camera far
SOFTWARE_SCALE = 0.25  # default render scale on a CPU rasterizer (llvmpipe: seconds a frame at 1280x720)
MIN_GUI_FRAMES = 2  # ImGui sizes auto-resizing panels a frame after their content changes
SCENE_EXTENSIONS = (".toml", ".pbrt", ".obj", ".ply", ".glb", ".gltf")
IMAGE_EXTENSIONS = (".exr", ".pfm", ".npy", ".png")


@dataclass
class ViewOptions:
    scene: str
    integrator: str = "pt"
    params: dict | None = None
    plugin_dirs: tuple = ()
    seed: int = 0
    window_size: tuple[int, int] = (1280, 720)
    window_class: str = "pyglet"
    render_scale: float | None = None  # None: 1 on a GPU, SOFTWARE_SCALE on llvmpipe
    moving_scale: float | None = None  # None: 0.5 on llvmpipe, else 1
    render_size: tuple[int, int] | None = None
    samples_per_frame: int = 1
    target_spp: int = 0
    target_seconds: float = 0.0
    exposure: float = 0.0
    operator: str = "aces"
    gamma: float | None = None
    view: str = "render"
    denoise: str = "off"
    denoiser: str = "auto"
    split: str | None = None
    split_params: dict | None = None
    reference: str | None = None
    panels: tuple = ("settings", "statistics")
    inspector: bool = False
    frames: int | None = None
    screenshot: str | None = None
    vsync: bool = False
    temporal: str = "reset"  # "reproject": a moving camera keeps its history (docs/temporal.md)
    render_options: object = None  # lift_gl/options.py Options (--option); None: the defaults


class ViewerWindow:
    def __init__(self, options: ViewOptions):
        self.options = options
        settings.WINDOW.update({
            "class": WINDOW_CLASSES[options.window_class], "gl_version": (4, 3), "size": options.window_size,
            "aspect_ratio": None, "title": f"lift-gl view: {Path(options.scene).name}", "vsync": options.vsync,
            "resizable": True, "samples": 0,
        })
        if options.window_class == "headless":
            settings.WINDOW["backend"] = "egl"
        try:
            self.wnd = mglw.create_window_from_settings()
        except Exception as exc:  # the toolkit's own errors: no display, no OpenGL 4.3 context
            hint = ""
            if options.window_class != "headless" and not os.environ.get("DISPLAY"):
                hint = " (no $DISPLAY: run it under `xvfb-run -a`, or with --window headless)"
            raise LiftError(f"cannot open a {options.window_class} window with OpenGL 4.3: "
                            f"{type(exc).__name__}: {exc}{hint}") from None
        mglw.activate_context(window=self.wnd)
        self.ctx = self.wnd.ctx

        imgui.create_context()
        implot.create_context()
        io = imgui.get_io()
        io.set_ini_filename("")  # a scripted run must not depend on a previous session's layout
        io.config_flags |= imgui.ConfigFlags_.docking_enable
        self.gui = ImguiRenderer(self.wnd)
        self.ui = UiState(window_size=tuple(self.wnd.buffer_size), inspector=options.inspector)
        self.panels = make_panels()
        self.layout = DockLayout(self.panels)
        self._image_area = (0, 0, *self.wnd.buffer_size)  # window pixels: the central dock node
        for panel in self.panels:
            if panel.key in ("F1", "F2", "F3", "F4", "H"):
                panel.visible = {"F1": "settings", "F2": "statistics", "F3": "denoiser", "F4": "edit",
                                 "H": "help"}[panel.key] in options.panels

        software = is_software(self.ctx)
        resolution = Resolution(
            window=tuple(self.wnd.buffer_size),
            scale=options.render_scale if options.render_scale is not None else (SOFTWARE_SCALE if software else 1.0),
            # Reprojection needs the same resolution while moving (a resize restarts accumulation).
            moving_scale=(1.0 if options.temporal == "reproject" else options.moving_scale
                          if options.moving_scale is not None else (0.5 if software else 1.0)),
            fixed=options.render_size)
        self.session = ViewSession(self.ctx, options.scene, integrator=options.integrator, params=options.params,
                                   seed=options.seed, plugin_dirs=options.plugin_dirs, resolution=resolution,
                                   temporal=options.temporal, options=options.render_options)
        s = self.session
        s.sampling.samples_per_frame = options.samples_per_frame
        s.sampling.target_spp = options.target_spp
        s.sampling.target_seconds = options.target_seconds
        s.sampling.target_frames = options.frames or 0
        s.display.exposure, s.display.operator, s.display.gamma = options.exposure, options.operator, options.gamma
        if options.denoise != "off" or options.denoiser != "auto":
            s.set_denoise(options.denoise, options.denoiser)
        s.display.view = options.view
        if options.split:
            s.set_compare(options.split, options.split_params)
        if options.reference:
            s.load_reference(options.reference)
        self.ui.scene_text = str(options.scene)
        self.ui.reference_text = options.reference or ""
        self.view = ImageView(self.ctx)
        self._drag = False
        self._camera_dirty = False
        self._uploaded = None  # the AOV image now in the view's upload texture
        self._last_motion = -1e9
        self._last_time = time.perf_counter()
        self._connect_events()

    # ---- events ---------------------------------------------------------------------------
    def _connect_events(self):
        w = self.wnd
        w.key_event_func = self.on_key
        w.mouse_position_event_func = self.on_mouse_position
        w.mouse_drag_event_func = self.on_mouse_drag
        w.mouse_press_event_func = self.on_mouse_press
        w.mouse_release_event_func = self.on_mouse_release
        w.mouse_scroll_event_func = self.on_mouse_scroll
        w.unicode_char_entered_func = self.gui.unicode_char_entered
        w.resize_func = self.on_resize
        w.files_dropped_event_func = self.on_files_dropped

    def on_key(self, key, action, modifiers):
        self.gui.key_event(key, action, modifiers)
        keys = self.wnd.keys
        if action != keys.ACTION_PRESS or imgui.get_io().want_capture_keyboard:
            return
        s = self.session
        toggles = {keys.F1: "F1", keys.F2: "F2", keys.F3: "F3", keys.F4: "F4", keys.H: "H"}
        if key in toggles:
            for panel in self.panels:
                if panel.key == toggles[key]:
                    panel.visible = not panel.visible
        elif key == keys.F12:
            self.ui.screenshot_request = True
        elif key == keys.TAB:
            s.controller.mode = "orbit" if s.controller.mode == "fly" else "fly"
        elif key == keys.SPACE:
            s.sampling.paused = not s.sampling.paused
        elif key == keys.BACKSPACE:
            s.reset_camera()
        elif key == keys.R:
            s.restart()
        elif key == keys.I:
            self.ui.inspector = not self.ui.inspector
        elif key == keys.B:
            s.add_bookmark()
        else:
            digits = [getattr(keys, f"NUMBER_{n}") for n in range(1, 10)]
            if key in digits and digits.index(key) < len(s.bookmarks):
                s.go_to_bookmark(digits.index(key))

    def _mouse_in_pixels(self, x, y):
        """Window coordinates -> framebuffer pixels (they differ on high-DPI screens)."""
        ratio = self.wnd.pixel_ratio
        return int(x * ratio), int(y * ratio)

    def on_mouse_position(self, x, y, dx, dy):
        self.gui.mouse_position_event(x, y, dx, dy)
        self.ui.mouse = self._mouse_in_pixels(x, y)

    def _edit_panel_open(self) -> bool:
        return any(panel.key == "F4" and panel.visible for panel in self.panels)

    def _render_pixel(self, x, y):
        return window_to_pixel(self._mouse_in_pixels(x, y), self.ui.image_rect, self.session.renderer.size)

    def _over_image(self, point) -> bool:
        """Whether a window pixel is on the image, with no ImGui window (a panel, a popup) over it.
        The letterbox bars and the splitters between panels are not the image."""
        x, y = point
        rx, ry, rw, rh = self.ui.image_rect
        ratio = self.wnd.pixel_ratio
        return rx <= x < rx + rw and ry <= y < ry + rh and not gui_window_at(x / ratio, y / ratio)

    def on_mouse_press(self, x, y, button):
        self.gui.mouse_press_event(x, y, button)
        self.ui.mouse = self._mouse_in_pixels(x, y)
        self._drag = self._over_image(self.ui.mouse)  # a drag that starts on a panel never moves the camera
        # With the Edit panel open a click selects what is under it, and dragging a light moves it.
        if self._drag and button == 1 and self._edit_panel_open():
            pixel = self._render_pixel(x, y)
            if pixel is not None and self.session.editor.press(pixel):
                self._drag = False

    def on_mouse_release(self, x, y, button):
        self.gui.mouse_release_event(x, y, button)
        self._drag = False
        self.session.editor.release()

    def on_mouse_drag(self, x, y, dx, dy):
        self.gui.mouse_drag_event(x, y, dx, dy)
        self.ui.mouse = self._mouse_in_pixels(x, y)
        if self.session.editor.dragging:
            pixel = self._render_pixel(x, y)
            if pixel is not None:
                self.session.editor.drag(pixel)
        elif self._drag and self.session.controller.look(dx, dy):
            self._camera_moved()

    def on_mouse_scroll(self, x_offset, y_offset):
        self.gui.mouse_scroll_event(x_offset, y_offset)
        over_image = self.ui.mouse is not None and self._over_image(self.ui.mouse)
        if over_image and self.session.controller.scroll(y_offset):
            self._camera_moved()

    def on_resize(self, width, height):
        """The next frame's dock space is split anew for this size (layout.py), and the render
        resolution follows the image's new area."""
        self.gui.resize(width, height)
        self.ui.window_size = tuple(self.wnd.buffer_size)

    def on_files_dropped(self, x, y, paths):
        for path in map(Path, paths):
            if path.suffix.lower() in SCENE_EXTENSIONS:
                self.session.open_scene(path)
            elif path.suffix.lower() in IMAGE_EXTENSIONS:
                self.session.load_reference(path)

    def _camera_moved(self):
        """Input moved the camera: applied once per frame (a drag sends many events a frame)."""
        self._last_motion = time.perf_counter()
        self._camera_dirty = True

    # ---- one frame ----------------------------------------------------------------------------
    def _fly(self, dt: float) -> None:
        if imgui.get_io().want_capture_keyboard:
            return
        keys = self.wnd.keys
        held = [name for name in "wasdqe" if self.wnd.is_key_pressed(getattr(keys, name.upper()))]
        mods = self.wnd.modifiers
        boost = 4.0 if mods.shift else (0.25 if mods.ctrl else 1.0)
        if held and self.session.controller.move(held, dt, boost):
            self._camera_moved()

    def frame(self) -> None:
        now = time.perf_counter()
        dt, self._last_time = now - self._last_time, now
        self._fly(min(dt, MAX_FLY_STEP_S))
        if self._camera_dirty:
            self._camera_dirty = False
            self.session.set_moving(True)
            self.session.apply_camera()
        elif self.session.moving and now - self._last_motion > MOVING_HOLD_S:
            self.session.set_moving(False)
        self.session.editor.apply_pending()  # a light dragged with the mouse: once a frame
        self._build_gui()
        self.session.step()
        self.session.update_display()

        fb_size = tuple(self.wnd.buffer_size)
        self.wnd.use()
        self.ctx.clear(0.08, 0.08, 0.09, 1.0)
        self._draw_image(fb_size)
        imgui.render()
        self.gui.render(imgui.get_draw_data())
        if self.ui.screenshot_request:
            self.ui.screenshot_request = False
            self._interactive_screenshot()

    def _draw_image(self, fb_size) -> None:
        s = self.session
        self._fit_image()  # again: a panel may have changed the render's size since (scale, reference)
        if s.display.view in AOV_VIEWS:
            shown = s.aov_display(s.display.view)
            if shown is not self._uploaded:  # upload once per view change, not every frame
                self.view.upload(shown)
                self._uploaded = shown
            left, right = self.view.uploaded, None
        else:
            textures = s.display_textures()
            if not textures:
                return
            left, right = textures[0], (textures[1] if len(textures) > 1 else None)
        self.view.draw(fb_size, self.ui.image_rect, left, right, s.display.split_position)

    def _build_gui(self) -> None:
        """The panels of this frame (drawn after the image), and the image's place beside them.

        ImGui updates its dock nodes a frame after a panel opens or closes; so when this frame's
        panels are not last frame's, the frame's GUI is built again, and the image is never
        drawn where a panel has just opened."""
        for attempt in range(2):
            imgui.new_frame()
            self._set_image_area(self.layout.image_area())
            shown_before = set(self.ui.panel_rects)
            self.ui.panel_rects, self.ui.panel_fit = {}, {}
            for panel in self.panels:
                if panel.visible:
                    panel.draw(self.session, self.ui)
            if set(self.ui.panel_rects) == shown_before or attempt == 1:
                break
            imgui.end_frame()
        self._draw_labels()

    def _set_image_area(self, area_points) -> None:
        """The central dock node (window points) -> the image's area and rectangle (window pixels);
        the render resolution follows the area (ViewSession.set_window_size)."""
        ratio = self.wnd.pixel_ratio
        x, y, w, h = (round(v * ratio) for v in area_points)
        area = (x, y, max(1, w), max(1, h))
        if area != self._image_area:
            self._image_area = area
            self.session.set_window_size(area[2:])
        self._fit_image()

    def _fit_image(self) -> None:
        x, y, w, h = self._image_area
        self.ui.image_rect = fit_rect(self.session.renderer.size, (w, h), (x, y))

    def _draw_labels(self) -> None:
        """Names over the split view's two sides, and notices (screenshot written)."""
        draw = imgui.get_foreground_draw_list()
        x, y, w, h = self.ui.image_rect
        s = self.session
        labels = s.split_labels()
        if labels is not None:
            divider = x + w * s.display.split_position
            draw.add_text(imgui.ImVec2(divider - 8 - 8 * len(labels[0]), y + h - 24), 0xFFFFFFFF, labels[0])
            draw.add_text(imgui.ImVec2(divider + 8, y + h - 24), 0xFFFFFFFF, labels[1])
        now = time.perf_counter()
        self.ui.messages = [(t, text) for t, text in self.ui.messages if now - t < 4.0]
        for i, (_, text) in enumerate(self.ui.messages):
            draw.add_text(imgui.ImVec2(x + 8, y + h - 24 - 16 * (i + 1)), 0xFF80FFFF, text)

    def _interactive_screenshot(self) -> None:
        stem = Path.cwd() / f"{self.session.scene_path.stem}-{time.strftime('%Y%m%d-%H%M%S')}"
        paths = self.session.screenshot(stem)
        window = stem.with_name(stem.name + "-window.png")
        write_srgb8(window, self.read_window())
        self.ui.messages.append((time.perf_counter(), "wrote " + ", ".join(p.name for p in paths + [window])))

    def read_window(self) -> np.ndarray:
        """The window as drawn so far (image and GUI): uint8 (H, W, 3), row 0 = top."""
        w, h = self.wnd.buffer_size
        data = self.wnd.fbo.read(viewport=(0, 0, w, h), components=3, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()

    # ---- the loop -----------------------------------------------------------------------------
    def run(self) -> int:
        frames, shot = self.options.frames, self.options.screenshot
        settled = 0  # GUI frames drawn since the last image change (auto-sized panels need a few)
        while not self.wnd.is_closing:
            spp_before = self.session.renderer.stats.spp
            self.frame()
            settled = 0 if self.session.renderer.stats.spp != spp_before else settled + 1
            if frames is not None and self.session.frozen and settled >= MIN_GUI_FRAMES:
                if shot:
                    self._scripted_screenshot(Path(shot))
                break
            self.wnd.swap_buffers()
        self.close()
        return 0

    def _scripted_screenshot(self, path: Path) -> None:
        write_srgb8(path, self.read_window())
        report = dict(self.session.statistics(), **self.layout_report(), view=self.session.display.view,
                      exposure=self.session.display.exposure, operator=self.session.display.operator,
                      errors=list(self.session.errors.entries))
        from ..atomic import write_text

        write_text(path.with_suffix(".json"), json.dumps(report, indent=2) + "\n")
        print(f"{path}: {report['render_size'][0]}x{report['render_size'][1]}, {report['integrator']}, "
              f"{report['spp']} spp in {report['render_seconds']:.2f} s, dropped NaN/Inf samples: "
              f"{report['dropped_samples']}")

    def layout_report(self) -> dict:
        """Where this frame put the image and the panels: window pixels from the top left (panels in
        ImGui's window coordinates, the same without high-DPI scaling); panel_fit: for each panel
        drawn in front, the right edge its widest line reached and the right edge of its room."""
        return {"window_size": list(self.wnd.buffer_size), "image_area": list(self._image_area),
                "image_rect": list(self.ui.image_rect), "render_size": list(self.session.renderer.size),
                "panels": {k: list(v) for k, v in self.ui.panel_rects.items()},
                "panel_fit": {k: list(v) for k, v in self.ui.panel_fit.items()}}

    def close(self) -> None:
        self.session.release()
        self.view.release()
        self.gui.shutdown()
        self.wnd.destroy()
