"""F1 Settings: scene, integrator and its parameters, sampling, camera, display, reference."""
from __future__ import annotations

from imgui_bundle import imgui

from ...tonemap import OPERATORS
from ..aov_view import AOV_VIEWS
from ..session import NOISY_SPLIT
from ..camera_controller import MODES
from ..scene_catalog import find_scenes
from . import Panel, UiState, push_label_room, text_wrapped_colored
from .params import param_widget

VIEWS = ("render",) + AOV_VIEWS
SPP_CHOICES = (1, 2, 4, 8, 16, 32, 64)
# The labels drawn beside widgets (the plugins' parameter names join them): the widest sets
# how much of the panel's width the labels keep.
LABELS = ("scene", "path", "integrator", "samples / frame", "target spp", "target seconds", "speed",
          "mouse sensitivity", "fov (vertical)", "aperture radius", "focus distance", "name", "view", "exposure",
          "tone mapping", "render scale", "scale while moving", "right side", "divider")


def _combo(label: str, items, current) -> tuple[bool, str]:
    items = list(items)
    index = items.index(current) if current in items else 0
    changed, index = imgui.combo(label, index, items)
    return changed, items[index]


class SettingsPanel(Panel):
    title = "Settings"
    key = "F1"

    def __init__(self):
        self._scenes = None  # found once, on the first draw (refresh button)
        self._plugins = None

    def draw(self, session, ui: UiState) -> None:
        if not self.begin(ui):
            return
        params = [p.name for r in session.renderers for p in r.plugin.params.values()]
        push_label_room(LABELS + tuple(params))
        self._scene(session, ui)
        self._integrator(session)
        self._sampling(session)
        self._camera(session, ui)
        self._display(session, ui)
        self._reference(session, ui)
        imgui.pop_item_width()
        self.end(ui)

    # ---- scene ----
    def _scene(self, session, ui):
        if not imgui.collapsing_header("Scene", imgui.TreeNodeFlags_.default_open):
            return
        if self._scenes is None:
            self._scenes = find_scenes()
        current = str(session.scene_path)
        labels = [label for label, _ in self._scenes]
        paths = [str(p.resolve()) for _, p in self._scenes]
        index = paths.index(str(session.scene_path.resolve())) if str(session.scene_path.resolve()) in paths else -1
        preview = labels[index] if index >= 0 else session.scene_path.name
        if imgui.begin_combo("scene", preview):
            for i, label in enumerate(labels):
                if imgui.selectable(label, i == index)[0] and i != index:
                    session.open_scene(self._scenes[i][1])
            imgui.end_combo()
        imgui.set_item_tooltip(current)
        _, ui.scene_text = imgui.input_text("path##scene", ui.scene_text)
        imgui.same_line()
        if imgui.button("Open##scene") and ui.scene_text.strip():
            session.open_scene(ui.scene_text.strip())
        imgui.set_item_tooltip("open a scene file (.toml, .pbrt, .obj, .ply, .glb); or drop it on the window")

    # ---- integrator ----
    def _integrator(self, session):
        if not imgui.collapsing_header("Integrator", imgui.TreeNodeFlags_.default_open):
            return
        if self._plugins is None:
            self._plugins = session.plugins()
        names = sorted(self._plugins)
        renderer = session.renderer
        changed, name = _combo("integrator", names, renderer.plugin.name)
        if renderer.plugin.description:
            imgui.set_item_tooltip(renderer.plugin.description)
        if changed and name != renderer.plugin.name:
            session.set_integrator(name)
        if imgui.button("Rescan plugins"):
            self._plugins = None
        for param in session.renderer.plugin.params.values():
            changed, value = param_widget(param, session.renderer.params[param.name])
            if changed:
                session.set_param(param.name, value)
        if session.renderer.plugin.primary == "gbuffer":
            imgui.text_disabled("primary hit from the raster G-buffer")
        else:
            imgui.text_disabled("primary hit from camera rays (thin lens)")

    # ---- sampling ----
    def _sampling(self, session):
        if not imgui.collapsing_header("Sampling", imgui.TreeNodeFlags_.default_open):
            return
        s = session.sampling
        spp = s.samples_per_frame
        changed, spp = imgui.slider_int("samples / frame", spp, 1, 64)
        if changed:
            s.samples_per_frame = max(1, spp)
        _, s.accumulate = imgui.checkbox("accumulate", s.accumulate)
        imgui.set_item_tooltip("off: every frame starts over (shows the noise of one frame)")
        imgui.same_line()
        _, s.paused = imgui.checkbox("pause (Space)", s.paused)
        changed, target = imgui.input_int("target spp", s.target_spp, 16, 256)
        if changed:
            s.target_spp = max(0, target)
        imgui.set_item_tooltip("0: none. The image freezes when the target is reached.")
        changed, seconds = imgui.input_float("target seconds", s.target_seconds, 1.0, 10.0, "%.1f")
        if changed:
            s.target_seconds = max(0.0, seconds)
        imgui.set_item_tooltip("0: none. Render time as the statistics count it (GUI excluded).")
        if session.target_reached:
            imgui.text_colored(imgui.ImVec4(0.4, 1.0, 0.4, 1.0), "target reached: image frozen")
        if imgui.button("Restart accumulation"):
            session.restart()

    # ---- camera ----
    def _camera(self, session, ui):
        if not imgui.collapsing_header("Camera"):
            return
        c = session.controller
        for mode in MODES:
            if imgui.radio_button(mode, c.mode == mode):
                c.mode = mode
            imgui.same_line()
        imgui.text_disabled("(Tab)")
        s = c.settings
        changed, speed = imgui.drag_float("speed", s.speed, s.speed * 0.01, 1e-4 * c.scene_size, 1e2 * c.scene_size,
                                          "%.3g", imgui.SliderFlags_.logarithmic)
        if changed:
            s.speed = speed
        imgui.set_item_tooltip("scene units per second (mouse wheel in fly mode; Shift x4, Ctrl x1/4)")
        _, s.sensitivity = imgui.slider_float("mouse sensitivity", s.sensitivity, 0.02, 1.0, "%.2f deg/px")
        moved = False
        changed, s.fov_deg = imgui.slider_float("fov (vertical)", s.fov_deg, 5.0, 120.0, "%.1f deg")
        moved |= changed
        changed, s.aperture_radius = imgui.drag_float("aperture radius", s.aperture_radius,
                                                      0.001 * c.scene_size, 0.0, c.scene_size, "%.4f")
        moved |= changed
        changed, s.focus_distance = imgui.drag_float("focus distance", s.focus_distance, 0.005 * c.scene_size,
                                                     1e-3 * c.scene_size, 100 * c.scene_size, "%.3f")
        moved |= changed
        if session.renderer.plugin.primary == "gbuffer" and s.aperture_radius > 0:
            imgui.text_wrapped("Depth of field needs a plugin with primary = \"camera\"; "
                               "this one takes its first hit from the pinhole G-buffer.")
        if moved:
            session.apply_camera()
        if imgui.button("Reset camera (Backspace)"):
            session.reset_camera()
        imgui.separator_text("Bookmarks")
        for i, bookmark in enumerate(list(session.bookmarks)):
            imgui.push_id(i)
            if imgui.button("Go"):
                session.go_to_bookmark(i)
            imgui.same_line()
            if imgui.button("x"):
                session.delete_bookmark(i)
                imgui.pop_id()
                break
            imgui.same_line()
            key = f" ({i + 1})" if i < 9 else ""
            imgui.text_wrapped(bookmark.name + key)
            imgui.pop_id()
        _, ui.bookmark_name = imgui.input_text("name##bookmark", ui.bookmark_name)
        imgui.same_line()
        if imgui.button("Add (B)"):
            session.add_bookmark(ui.bookmark_name.strip() or None)
            ui.bookmark_name = ""
        text_wrapped_colored(imgui.get_style_color_vec4(imgui.Col_.text_disabled), session.bookmarks_file.name)
        imgui.set_item_tooltip(str(session.bookmarks_file))

    # ---- display ----
    def _display(self, session, ui):
        if not imgui.collapsing_header("Display", imgui.TreeNodeFlags_.default_open):
            return
        d = session.display
        views = VIEWS + ((NOISY_SPLIT,) if session.renderer.denoise_mode != "off" else ())
        _, d.view = _combo("view", views, d.view)
        imgui.set_item_tooltip("the tone-mapped render, a G-buffer channel (AOV), or with a denoiser on, "
                               "the noisy and denoised images side by side (F3)")
        _, d.exposure = imgui.slider_float("exposure", d.exposure, -10.0, 10.0, "%.2f stops")
        _, d.operator = _combo("tone mapping", OPERATORS, d.operator)
        srgb = d.gamma is None
        changed, srgb = imgui.checkbox("sRGB curve", srgb)
        if changed:
            d.gamma = None if srgb else 2.2
        if d.gamma is not None:
            imgui.same_line()
            imgui.set_next_item_width(120)
            _, gamma = imgui.slider_float("gamma", d.gamma, 1.0, 3.0, "%.2f")
            d.gamma = gamma
        r = session.resolution
        fixed = r.fixed is not None
        changed, r.scale = imgui.slider_float("render scale", r.scale, 0.1, 1.0, "%.2f")
        if changed and not fixed:
            session.apply_resolution()
        imgui.set_item_tooltip("render resolution / window resolution")
        changed, r.moving_scale = imgui.slider_float("scale while moving", r.moving_scale, 0.1, 1.0, "%.2f")
        if changed:
            session.apply_resolution()
        imgui.set_item_tooltip("a lower resolution while the camera moves keeps the viewer fluid (1: off)")
        w, h = session.renderer.size
        imgui.text_disabled(f"render {w}x{h}" + (" (fixed)" if fixed else ""))
        # Split view: the right side of the image shows a second integrator.
        names = sorted(self._plugins or session.plugins())
        split = session.compare is not None
        changed, split = imgui.checkbox("split view", split)
        if changed:
            other = next((n for n in names if n != session.renderer.plugin.name), session.renderer.plugin.name)
            session.set_compare(other if split else None)
        if session.compare is not None:
            changed, name = _combo("right side", names, session.compare.plugin.name)
            if changed:
                session.set_compare(name)
            for param in session.compare.plugin.params.values():
                changed, value = param_widget(param, session.compare.params[param.name], f"{param.name}##right")
                if changed:
                    session.set_param(param.name, value, session.compare)
            _, d.split_position = imgui.slider_float("divider", d.split_position, 0.0, 1.0, "%.2f")
        _, ui.inspector = imgui.checkbox("pixel inspector (I)", ui.inspector)
        imgui.set_item_tooltip("hover the image to read a pixel's radiance, sample count and G-buffer")

    # ---- reference ----
    def _reference(self, session, ui):
        if not imgui.collapsing_header("Reference", imgui.TreeNodeFlags_.default_open if session.reference is not None else 0):
            return
        _, ui.reference_text = imgui.input_text("path##reference", ui.reference_text)
        imgui.set_item_tooltip("a converged image of this view (.exr .pfm .npy .png): the error "
                               "against it is plotted against render time")
        if imgui.button("Load##reference") and ui.reference_text.strip():
            session.load_reference(ui.reference_text.strip())
        if session.reference is not None:
            imgui.same_line()
            if imgui.button("Clear##reference"):
                session.clear_reference()
            else:
                h, w = session.reference.shape[:2]
                imgui.text_wrapped(f"{session.reference_path.name}: {w}x{h}, rendering at 1/{session.reference_factor}")
        if session.convergence:
            point = session.convergence[-1]
            imgui.text(f"relMSE {point.rel_mse:.4g} at {point.spp} spp, {point.seconds:.1f} s")
