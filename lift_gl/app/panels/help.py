"""H: the keyboard and mouse help overlay."""
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
    flags = imgui.WindowFlags_.always_auto_resize | imgui.WindowFlags_.no_collapse

    def draw(self, session, ui: UiState) -> None:
        imgui.set_next_window_pos(imgui.ImVec2(ui.window_size[0] * 0.5, ui.window_size[1] * 0.5),
                                  imgui.Cond_.appearing, imgui.ImVec2(0.5, 0.5))
        imgui.set_next_window_bg_alpha(0.9)
        if not self.begin(ui):
            return
        if imgui.begin_table("keys", 2):
            for key, action in KEYS:
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text_colored(imgui.ImVec4(1.0, 0.85, 0.3, 1.0), key)
                imgui.table_next_column()
                imgui.text(action)
            imgui.end_table()
        imgui.end()
