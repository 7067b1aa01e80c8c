"""The viewer's GUI panels (imgui-bundle). Each panel edits or shows a ViewSession and holds no
rendering logic of its own.

| key | panel                                                              |
| --- | ------------------------------------------------------------------ |
| F1  | Settings: scene, integrator and its parameters, sampling, camera, display, reference |
| F2  | Statistics: timings per pass, resolution, spp, paths/s, dropped samples |
| F3  | Denoiser: off / every frame / final frame, which denoiser, à-trous settings, noisy vs denoised |
| F4  | Edit: lights and materials                                         |
| H   | keyboard help                                                      |
| I   | Pixel: the pixel inspector                                         |
|     | Convergence (opens with a reference), Errors (opens on an error)   |

Panels dock beside the image, never over it (layout.py): `dock` names the column or strip a
panel goes to, and panels sharing one are tabs.

A new panel is a class with `title`, `key`, `visible`, `dock` and `draw(session, ui)` (between
`self.begin(ui)` and `self.end(ui)`) added to `make_panels`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from imgui_bundle import imgui


@dataclass
class UiState:
    """GUI-only state: text boxes, window size, and where each panel was drawn this frame."""

    window_size: tuple[int, int] = (1280, 720)
    scene_text: str = ""
    reference_text: str = ""
    bookmark_name: str = ""
    inspector: bool = False
    mouse: tuple[int, int] | None = None  # window pixels, from the top left
    image_rect: tuple[int, int, int, int] = (0, 0, 1, 1)  # window pixels, from the top left
    panel_rects: dict = field(default_factory=dict)  # title -> (x, y, w, h), ImGui's window coordinates
    panel_fit: dict = field(default_factory=dict)  # title -> (content right edge, room's right edge)
    screenshot_request: bool = False
    messages: list = field(default_factory=list)  # short notices (screenshot written...)


class Panel:
    title = ""
    key = None  # the function key that toggles it, e.g. "F1"
    visible = True
    flags = 0
    dock = "tools"  # where layout.DockLayout puts it: "tools", "readout" or "below"
    focus_next = False  # bring it to the front (select its tab) when next drawn
    _last_begin_frame = -2

    def begin(self, ui: UiState) -> bool:
        """imgui.begin with a close box; records the panel's rectangle. Call end() if True.

        A panel that opens while the viewer runs comes to the front of its dock node (its tab
        is selected); at start the first panel docked in a node is the one shown."""
        frame = imgui.get_frame_count()
        if self.focus_next or (self._last_begin_frame < frame - 1 and frame > 1):
            self._to_front()
        self.focus_next = False
        self._last_begin_frame = frame
        # No focus of ImGui's own on appearing: which panel is in front is decided here and in layout.py.
        expanded, opened = imgui.begin(self.title, True, self.flags | imgui.WindowFlags_.no_focus_on_appearing)
        if opened is False:
            self.visible = False
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        ui.panel_rects[self.title] = (int(pos.x), int(pos.y), int(size.x), int(size.y))
        if not expanded:
            imgui.end()
        return expanded

    def _to_front(self) -> None:
        """Select this panel's tab in its dock node. Not by focusing it: ImGui selects the tab of
        the window focused last in a frame only, and several nodes may change at once."""
        window = imgui.internal.find_window_by_name(self.title)
        node = window.dock_node if window is not None else None
        if node is not None and node.tab_bar is not None:
            node.tab_bar.next_selected_tab_id = window.tab_id
        else:
            imgui.set_next_window_focus()

    def end(self, ui: UiState) -> None:
        """imgui.end, after recording how far the widest line of the panel reached against the
        room it had: a label or line past that room is clipped (a scripted screenshot's JSON
        has it as panel_fit; the viewer's tests check it)."""
        window = imgui.internal.get_current_window()
        ui.panel_fit[self.title] = (float(window.dc.cursor_max_pos.x), float(window.work_rect.max.x))
        imgui.end()

    def draw(self, session, ui: UiState) -> None:
        raise NotImplementedError


def push_label_room(labels) -> None:
    """Widgets as wide as the panel less its widest label: ImGui draws a widget's label on its
    right, so every label then fits in the panel whatever the panel's width."""
    widest = max(imgui.calc_text_size(label.split("##")[0]).x for label in labels)
    imgui.push_item_width(-(widest + imgui.get_style().item_inner_spacing.x))


def text_wrapped_colored(colour: imgui.ImVec4, text: str) -> None:
    """Coloured text that wraps at the panel's edge (ImGui has no such call of its own)."""
    imgui.push_style_color(imgui.Col_.text, colour)
    imgui.text_wrapped(text)
    imgui.pop_style_color()


def make_panels() -> list[Panel]:
    from .convergence import ConvergencePanel
    from .denoiser import DenoiserPanel
    from .edit import EditPanel
    from .errors import ErrorsPanel
    from .help import HelpOverlay
    from .inspector import PixelInspector
    from .settings import SettingsPanel
    from .statistics import StatisticsPanel

    return [SettingsPanel(), StatisticsPanel(), DenoiserPanel(), ConvergencePanel(), ErrorsPanel(), HelpOverlay(),
            PixelInspector(), EditPanel()]
