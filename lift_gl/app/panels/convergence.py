"""Convergence plot (implot): relMSE against render time, log-log, while a reference is loaded.

A Monte Carlo estimator's error falls as 1/time once it is past its start-up cost; the
dashed guide through the first point has that slope, so a curve that bends away from it
shows bias, fireflies or a change of speed.
"""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui, implot

from . import Panel, UiState


class ConvergencePanel(Panel):
    title = "Convergence"
    visible = True  # shown while a reference is loaded

    def draw(self, session, ui: UiState) -> None:
        if session.reference is None:
            return
        imgui.set_next_window_pos(imgui.ImVec2(ui.window_size[0] - 8, ui.window_size[1] - 8),
                                  imgui.Cond_.first_use_ever, imgui.ImVec2(1.0, 1.0))
        imgui.set_next_window_size(imgui.ImVec2(420, 300), imgui.Cond_.first_use_ever)
        if not self.begin(ui):
            return
        points = session.convergence
        if len(points) < 2:
            imgui.text("collecting (the error is measured at growing spp)...")
            imgui.end()
            return
        seconds = np.array([p.seconds for p in points], np.float64)
        rel_mse = np.array([p.rel_mse for p in points], np.float64)
        if implot.begin_plot("relMSE against render time", imgui.ImVec2(-1, -1)):
            implot.setup_axes("render time (s)", "relMSE")
            implot.setup_axis_scale(implot.ImAxis_.x1, implot.Scale_.log10)
            implot.setup_axis_scale(implot.ImAxis_.y1, implot.Scale_.log10)
            implot.plot_line(session.renderer.plugin.name, seconds, rel_mse)
            guide = rel_mse[0] * seconds[0] / seconds
            implot.set_next_line_style(imgui.ImVec4(0.6, 0.6, 0.6, 1.0), 1.0)
            implot.plot_line("1 / time", seconds, guide)
            implot.end_plot()
        imgui.end()
