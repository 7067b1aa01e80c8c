"""ImGui drawing on the viewer's moderngl context: moderngl-window's imgui-bundle integration,
with two fixes the viewer needs.

Why imgui-bundle 1.6.x (ImGui 1.91): moderngl-window 3.1.1's integration uploads the font
atlas once with `get_tex_data_as_rgba32`; ImGui 1.92 replaced that with a texture protocol
in which the backend creates and updates textures on request, so the integration fails at
start with imgui-bundle >= 1.92. Pinning `imgui-bundle<1.92` (the `viewer` extra) keeps a
maintained integration that covers our needs (panels, tooltips, implot) instead of a
renderer of our own to keep in step with ImGui's texture protocol.

Fixes over the stock integration:
- it sets the mouse state directly (`io.mouse_down[0] = 1`), so a click whose press and
  release both arrive between two frames is lost; a frame on llvmpipe can take a second, so
  here mouse events go through ImGui's input queue (`add_mouse_button_event`...), which
  replays them one frame at a time;
- its vertex and index buffers hold 65536 entries and a bigger draw list (a long convergence
  plot, many text lines) would overflow them: here they grow;
- it forwards only navigation keys: here Ctrl/Shift/Alt and the letters of the usual
  shortcuts (Ctrl+A/C/V/X/Z in text boxes) are forwarded too.
"""
from __future__ import annotations

from imgui_bundle import imgui
from moderngl_window.integrations.imgui_bundle import ModernglWindowRenderer


class ImguiRenderer(ModernglWindowRenderer):
    def _init_key_maps(self):
        super()._init_key_maps()
        keys = self.wnd.keys
        for letter in "ACVXZ":
            self.REVERSE_KEYMAP[getattr(keys, letter)] = getattr(imgui.Key, letter.lower())

    def key_event(self, key, action, modifiers):
        self.io.add_key_event(imgui.Key.mod_ctrl, bool(modifiers.ctrl))
        self.io.add_key_event(imgui.Key.mod_shift, bool(modifiers.shift))
        self.io.add_key_event(imgui.Key.mod_alt, bool(modifiers.alt))
        super().key_event(key, action, modifiers)

    # ---- mouse, through the input queue ----
    def _button(self, button) -> int | None:
        mouse = self.wnd.mouse
        return {mouse.left: 0, mouse.right: 1, mouse.middle: 2}.get(button)

    def mouse_position_event(self, x, y, dx, dy):
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))

    def mouse_drag_event(self, x, y, dx, dy):
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))

    def mouse_press_event(self, x, y, button):
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))
        if self._button(button) is not None:
            self.io.add_mouse_button_event(self._button(button), True)

    def mouse_release_event(self, x, y, button):
        self.io.add_mouse_pos_event(*self._mouse_pos_viewport(x, y))
        if self._button(button) is not None:
            self.io.add_mouse_button_event(self._button(button), False)

    def mouse_scroll_event(self, x_offset, y_offset):
        self.io.add_mouse_wheel_event(x_offset, y_offset)

    def render(self, draw_data: imgui.ImDrawData):
        vertices = max((c.vtx_buffer.size() for c in draw_data.cmd_lists), default=0) * imgui.VERTEX_SIZE
        indices = max((c.idx_buffer.size() for c in draw_data.cmd_lists), default=0) * imgui.INDEX_SIZE
        # orphan() reallocates under the same GL name, so the vertex array stays valid.
        if vertices > self._vertex_buffer.size:
            self._vertex_buffer.orphan(2 * vertices)
        if indices > self._index_buffer.size:
            self._index_buffer.orphan(2 * indices)
        super().render(draw_data)
