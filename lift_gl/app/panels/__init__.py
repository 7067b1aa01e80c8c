"""The viewer's GUI panels (imgui-bundle). Each panel edits or shows a ViewSession and holds no
rendering logic of its own.

| key | panel                                                              |
| --- | ------------------------------------------------------------------ |
| F1  | Settings: scene, integrator and its parameters, sampling, camera, display, reference |
| F2  | Statistics: timings per pass, resolution, spp, paths/s, dropped samples |
| F3  | Denoiser: off / every frame / final frame, which denoiser, à-trous settings, noisy vs denoised |
| H   | keyboard help                                                      |
|     | Convergence (opens with a reference), Errors (opens on an error), pixel inspector |

A new panel is a class with `title`, `key`, `visible` and `draw(session, ui)` added to
`make_panels`.
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
    image_rect: tuple[int, int, int, int] = (0, 0, 1, 1)
    panel_rects: dict = field(default_factory=dict)
    screenshot_request: bool = False
    messages: list = field(default_factory=list)  # short notices (screenshot written...)
    resized: bool = False  # the window changed size this frame: panels go back to their anchors

    def placement(self) -> int:
        """The imgui condition for a panel's default position and size."""
        return imgui.Cond_.always if self.resized else imgui.Cond_.first_use_ever


class Panel:
    title = ""
    key = None  # the function key that toggles it, e.g. "F1"
    visible = True
    flags = 0

    def begin(self, ui: UiState) -> bool:
        """imgui.begin with a close box; records the panel's rectangle. Call end() if True."""
        expanded, opened = imgui.begin(self.title, True, self.flags)
        if opened is False:
            self.visible = False
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        ui.panel_rects[self.title] = (int(pos.x), int(pos.y), int(size.x), int(size.y))
        if not expanded:
            imgui.end()
        return expanded

    def draw(self, session, ui: UiState) -> None:
        raise NotImplementedError


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
