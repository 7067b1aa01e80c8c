"""Where the panels go: docked beside the image, never over it (ImGui's docking).

    +------------+---------------------------------------+
    | tools      |                                       |
    | Settings,  |     the image: the central node,      |
    | Denoiser,  |     letterboxed in it                 |
    | Edit, Keys |                                       |
    |------------|                                       |
    | readout    |---------------------------------------|
    | Statistics,| below: Convergence, Errors            |
    | Pixel      |                                       |
    +------------+---------------------------------------+

A dock space covers the window; DockBuilder splits it into those nodes and the central node
stays empty (passthru: the image drawn under the GUI shows through, and the mouse there is not
ImGui's). Panels sharing a node are tabs. A node with no open panel gives its room to its
neighbour, so the image takes the whole window when every panel is closed, and the strip below
it exists only while a reference or an error is shown. The user can drag the splitters or
undock a panel (a floating panel may then cover the image: the user's choice); a change of
window size lays everything out again by the rule below.
"""
from __future__ import annotations

from imgui_bundle import imgui

COLUMN_FRACTION = 0.3  # of the window's width, within:
COLUMN_EM = (28.0, 36.0)  # in font heights: the narrowest column that fits the panels' labels, the widest useful
MAX_COLUMN_FRACTION = 0.45  # a narrow window keeps at least this much for the image
READOUT_ROWS = 15  # text lines of the statistics panel (its height: the readout node's)
MAX_READOUT_FRACTION = 0.5  # of the column's height
BELOW_FRACTION = 0.3  # of the window's height: the strip for the convergence plot and errors, within:
BELOW_EM = 16.0  # in font heights: a tab, a line of text and implot's smallest plot (150 points high)
MAX_BELOW_FRACTION = 0.45


def column_width(window_width: float, font_size: float) -> float:
    """The panels' column, in window points: a fraction of the window, at least wide enough for
    the panels' labels, at most a little less than half a narrow window."""
    lo, hi = COLUMN_EM[0] * font_size, COLUMN_EM[1] * font_size
    width = min(max(COLUMN_FRACTION * window_width, lo), hi)
    return min(width, MAX_COLUMN_FRACTION * window_width)


class DockLayout:
    def __init__(self, panels):
        self.panels = panels
        self.dockspace_id = 0
        self._built_for = None  # the window size the nodes were split for

    def image_area(self) -> tuple[float, float, float, float]:
        """Submit the dock space; call right after imgui.new_frame(), before the panels.
        Returns the central node's rectangle (x, y, w, h), window points from the top left.
        It reflects the panels open in the last frame (ImGui updates the nodes a frame late)."""
        internal = imgui.internal
        viewport = imgui.get_main_viewport()
        size = (float(viewport.size.x), float(viewport.size.y))
        if self.dockspace_id == 0:
            self.dockspace_id = imgui.get_id("lift-gl dock space")
        if size != self._built_for:
            self._build(size)
        imgui.dock_space_over_viewport(self.dockspace_id, viewport, imgui.DockNodeFlags_.passthru_central_node)
        node = internal.dock_builder_get_central_node(self.dockspace_id)
        return float(node.pos.x), float(node.pos.y), max(0.0, float(node.size.x)), max(0.0, float(node.size.y))

    def _front_panels(self) -> list:
        """The panel in front in each node (its tab selected) before a rebuild; in a node that
        shows none yet, the first open panel in `panels` order."""
        internal = imgui.internal
        front, slots = [], set()
        for panel in self.panels:
            window = internal.find_window_by_name(panel.title)
            node = window.dock_node if window is not None else None
            if node is not None and node.visible_window is not None and node.visible_window.name == panel.title:
                front.append(panel)
                slots.add(panel.dock)
        for panel in self.panels:
            if panel.visible and panel.dock not in slots:
                front.append(panel)
                slots.add(panel.dock)
        return front

    def _build(self, size) -> None:
        internal = imgui.internal
        width, height = size
        front = self._front_panels()
        style = imgui.get_style()
        dock = self.dockspace_id
        internal.dock_builder_remove_node(dock)  # undocks the panels; they are docked again below
        internal.dock_builder_add_node(dock, internal.DockNodeFlagsPrivate_.dock_space)
        internal.dock_builder_set_node_size(dock, imgui.ImVec2(width, height))
        column = column_width(width, imgui.get_font_size())
        _, left, rest = internal.dock_builder_split_node_py(dock, imgui.Dir.left, column / max(width, 1.0))
        below_height = min(max(BELOW_FRACTION * height, BELOW_EM * imgui.get_font_size()), MAX_BELOW_FRACTION * height)
        _, below, _ = internal.dock_builder_split_node_py(rest, imgui.Dir.down, below_height / max(height, 1.0))
        readout_height = (READOUT_ROWS * imgui.get_text_line_height_with_spacing() + imgui.get_frame_height()
                          + 2 * style.window_padding.y)
        readout_ratio = min(readout_height / max(height, 1.0), MAX_READOUT_FRACTION)
        _, readout, tools = internal.dock_builder_split_node_py(left, imgui.Dir.down, readout_ratio)
        nodes = {"tools": tools, "readout": readout, "below": below}
        for panel in self.panels:
            internal.dock_builder_dock_window(panel.title, nodes[panel.dock])
        internal.dock_builder_finish(dock)
        for panel in front:
            panel.focus_next = True
        self._built_for = size


def gui_window_at(x: float, y: float) -> bool:
    """Whether a panel, popup or menu of ImGui's covers this point (window points) as last drawn:
    not the dock space behind the panels (its central node shows the image), nor a tooltip.

    Read from the windows' rectangles, not from io.want_capture_mouse: that flag follows the mouse
    as ImGui's input queue replays it, a frame per button change, so a click on the image just
    after one on a panel would still find it set (a frame on llvmpipe can take a second)."""
    def inside(px, py, w, h) -> bool:
        return px <= x < px + w and py <= y < py + h

    for window in imgui.get_current_context().windows:
        if not window.active or window.hidden or window.flags & imgui.WindowFlags_.no_mouse_inputs:
            continue
        pos, hole, hole_size = window.pos, window.hit_test_hole_offset, window.hit_test_hole_size
        # The dock space's windows have a hole where its central node is (the passthru).
        if inside(pos.x, pos.y, window.size.x, window.size.y) and not inside(
                pos.x + hole.x, pos.y + hole.y, hole_size.x, hole_size.y):
            return True
    return False
