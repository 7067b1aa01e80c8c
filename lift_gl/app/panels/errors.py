"""Errors: shader compile errors (file:line), bad scene, plugin or reference files. The last good
renderer keeps running; the panel stays until cleared, in the strip below the image, and comes
to the front when a new error arrives."""
from __future__ import annotations

from imgui_bundle import imgui

from . import Panel, UiState


class ErrorsPanel(Panel):
    title = "Errors"
    dock = "below"

    def __init__(self):
        self._shown = 0  # errors in the log when last drawn

    def draw(self, session, ui: UiState) -> None:
        if not session.errors.entries:
            self._shown = 0
            return
        if len(session.errors.entries) > self._shown:
            self.focus_next = True
        self._shown = len(session.errors.entries)
        imgui.push_style_color(imgui.Col_.title_bg_active, imgui.ImVec4(0.6, 0.1, 0.1, 1.0))
        imgui.push_style_color(imgui.Col_.title_bg, imgui.ImVec4(0.45, 0.08, 0.08, 1.0))
        visible = self.begin(ui)
        imgui.pop_style_color(2)
        if not self.visible:  # closed with its box: dismiss the messages
            session.errors.clear()
            self.visible = True
        if not visible:
            return
        imgui.text_disabled("the last good renderer keeps running")
        for text in reversed(session.errors.entries):
            imgui.separator()
            imgui.text_wrapped(text)
        if imgui.button("Clear"):
            session.errors.clear()
        self.end(ui)
