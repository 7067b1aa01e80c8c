"""F2 Statistics: where the time goes and how far the image has come."""
from __future__ import annotations

from imgui_bundle import imgui

from ...gl.context import is_software
from . import Panel, UiState, text_wrapped_colored

SATURATED_MS = 4294.9  # moderngl reads GL_TIME_ELAPSED as 32 bits: 2^32 ns is its ceiling


def _si(value: float) -> str:
    for factor, prefix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if value >= factor:
            return f"{value / factor:.2f} {prefix}"
    return f"{value:.1f} "


class StatisticsPanel(Panel):
    title = "Statistics"
    key = "F2"
    dock = "readout"

    def draw(self, session, ui: UiState) -> None:
        if not self.begin(ui):
            return
        stats = session.statistics()
        frame = session.last_frame
        # Names of any length (scene files, GL renderers) wrap; the rows below are short.
        imgui.text_wrapped(f"{stats['integrator']}" + (f" | {stats['compare_integrator']}"
                                                       if stats["compare_integrator"] else "")
                           + f" on {session.scene_path.name}")
        renderer_name, _, version = stats["device"].partition(" | ")
        text_wrapped_colored(imgui.get_style_color_vec4(imgui.Col_.text_disabled), renderer_name)
        imgui.set_item_tooltip(version)
        w, h = stats["render_size"]
        aw, ah = stats["image_area_size"]
        imgui.text(f"resolution   {w} x {h}")
        imgui.set_item_tooltip("the render's; it follows the image's area (render scale in Settings)")
        imgui.text(f"image area   {aw} x {ah} of {ui.window_size[0]} x {ui.window_size[1]}")
        imgui.set_item_tooltip("window pixels the image may take beside the panels (letterboxed in it)")
        imgui.text(f"accumulated  {stats['spp']} spp, {stats['frames']} frames")
        imgui.text(f"render time  {stats['render_seconds']:.2f} s")
        imgui.text(f"frame        {frame.wall_ms:.1f} ms  ({frame.samples} spp)")
        clock = "wall" if is_software(session.ctx) else "GPU"
        for name, ms in frame.pass_ms.items():
            shown = f">= {SATURATED_MS:.0f}" if ms >= SATURATED_MS and clock == "GPU" else f"{ms:8.2f}"
            imgui.text(f"  {name:<11}{shown} ms ({clock})")
            if clock == "wall":
                imgui.set_item_tooltip("a CPU rasterizer: each pass timed between two glFinish calls")
            else:
                imgui.set_item_tooltip("GL timer query (GL_TIME_ELAPSED)")
        imgui.text(f"paths / s    {_si(stats['paths_per_second'])}")
        imgui.set_item_tooltip("camera paths (pixels x samples) per second of render time")
        dropped = stats["dropped_samples"]
        color = imgui.ImVec4(1.0, 0.4, 0.4, 1.0) if dropped else imgui.ImVec4(0.7, 0.7, 0.7, 1.0)
        imgui.text_colored(color, f"dropped NaN/Inf samples: {dropped}")
        # Always one status line, so that the panel keeps its height (others are placed below it).
        if session.frozen:
            reason = "paused" if session.sampling.paused else "target reached"
            imgui.text_colored(imgui.ImVec4(0.4, 1.0, 0.4, 1.0), f"frozen ({reason})")
        elif session.moving and session.resolution.moving_scale < 1:
            imgui.text_colored(imgui.ImVec4(1.0, 0.8, 0.3, 1.0), "moving: lower resolution")
        else:
            imgui.text_disabled("rendering")
        self.end(ui)
