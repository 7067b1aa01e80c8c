"""Pixel inspector: a tooltip with what the render pixel under the mouse holds."""
from __future__ import annotations

from imgui_bundle import imgui

from ..image_view import window_to_pixel
from . import Panel, UiState


def _rgb(v) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in v) + ")"


class PixelInspector(Panel):
    title = "Pixel"

    def draw(self, session, ui: UiState) -> None:
        if not ui.inspector or ui.mouse is None or imgui.get_io().want_capture_mouse:
            return
        pixel = window_to_pixel(ui.mouse, ui.image_rect, session.renderer.size)
        if pixel is None:
            return
        info = session.inspect(*pixel)
        if info is None:
            return
        if imgui.begin_tooltip():
            imgui.text(f"pixel {pixel[0]}, {pixel[1]} (from the top left)")
            imgui.text(f"radiance {_rgb(info['radiance'])}")
            imgui.text(f"samples  {info['samples']:.0f}")
            if "compare_radiance" in info:
                imgui.text(f"right side {_rgb(info['compare_radiance'])}")
            if "reference" in info:
                imgui.text(f"reference {_rgb(info['reference'])}")
            imgui.text(f"albedo   {_rgb(info['albedo'])}")
            imgui.text(f"normal   {_rgb(info['normal'])}")
            imgui.text(f"depth    {float(info['depth'][0]):.4g}")
            imgui.end_tooltip()
