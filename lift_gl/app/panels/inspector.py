"""Pixel inspector (I): what the render pixel under the mouse holds, in a panel beside the
image (a tab by the statistics), so the readout never covers the pixels around the mouse. The
last pixel the mouse was over stays shown, its values kept up to date, while the mouse is away."""
from __future__ import annotations

from imgui_bundle import imgui

from ..image_view import window_to_pixel
from . import Panel, UiState


def _rgb(v) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in v) + ")"


class PixelInspector(Panel):
    title = "Pixel"
    dock = "readout"

    def __init__(self):
        self._pixel = None  # render pixel (x, y from the top left) last under the mouse

    def draw(self, session, ui: UiState) -> None:
        if not ui.inspector:
            return
        if ui.mouse is not None and not imgui.get_io().want_capture_mouse:
            self._pixel = window_to_pixel(ui.mouse, ui.image_rect, session.renderer.size) or self._pixel
        if not self.begin(ui):
            return
        if not self.visible:  # closed with its box
            ui.inspector, self.visible = False, True
        info = session.inspect(*self._pixel) if self._pixel is not None else None
        if info is None:
            imgui.text_wrapped("hover the image to read a pixel")
            self.end(ui)
            return
        imgui.text(f"pixel {self._pixel[0]}, {self._pixel[1]} (from the top left)")
        imgui.text_wrapped(f"radiance {_rgb(info['radiance'])}")
        imgui.text(f"samples  {info['samples']:.0f}")
        if "compare_radiance" in info:
            imgui.text_wrapped(f"right side {_rgb(info['compare_radiance'])}")
        if "reference" in info:
            imgui.text_wrapped(f"reference {_rgb(info['reference'])}")
        imgui.text_wrapped(f"albedo   {_rgb(info['albedo'])}")
        imgui.text_wrapped(f"normal   {_rgb(info['normal'])}")
        imgui.text(f"depth    {float(info['depth'][0]):.4g}")
        self.end(ui)
