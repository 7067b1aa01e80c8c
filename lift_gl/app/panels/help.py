"""H: the keyboard and mouse help, a tab beside Settings."""
from __future__ import annotations

from imgui_bundle import imgui

from . import Panel, UiState

KEYS = (
    ("F1 / F2 / F3", "settings / statistics / denoiser panel"),
    ("F4", "edit panel: lights and materials; click selects, drag moves a light"),
    ("H", "this help"),
    ("W A S D", "fly forward, left, back, right"),
    ("Q / E", "down / up"),
    ("Shift / Ctrl", "4x faster / 4x slower"),
    ("drag (left button)", "look around (fly) or turn about the target (orbit)"),
    ("mouse wheel", "speed (fly) or zoom (orbit)"),
    ("Tab", "fly / orbit"),
    ("Backspace", "reset the camera to the scene's"),
    ("B / 1-9", "add a bookmark / go to bookmark n"),
    ("Space", "pause / resume"),
    ("R", "restart accumulation"),
    ("I", "pixel inspector"),
    ("F12", "screenshot: PNG + EXR of the image, PNG of the window"),
    ("Esc", "quit"),
)


class HelpOverlay(Panel):
    title = "Keys"
    key = "H"
    visible = False
    flags = imgui.WindowFlags_.no_collapse

    def draw(self, session, ui: UiState) -> None:
        if not self.begin(ui):
            return
        # Two columns by hand, not a table: the actions wrap at the panel's edge, whatever its width.
        style = imgui.get_style()
        action_x = style.window_padding.x + max(imgui.calc_text_size(k).x for k, _ in KEYS) + style.item_spacing.x
        for key, action in KEYS:
            imgui.text_colored(imgui.ImVec4(1.0, 0.85, 0.3, 1.0), key)
            imgui.same_line(action_x)
            imgui.text_wrapped(action)
        self.end(ui)
