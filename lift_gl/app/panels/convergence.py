"""Convergence plot (implot): relMSE against render time, log-log, while a reference is loaded.

A Monte Carlo estimator's error falls as 1/time once it is past its start-up cost; the
dashed guide through the first point has that slope, so a curve that bends away from it
shows bias (a plateau), fireflies (steps up) or a change of speed.
"""
from __future__ import annotations

import math

import numpy as np
from imgui_bundle import imgui, implot

from . import Panel, UiState

MANTISSAS = (1, 2, 5)


def log_ticks(lo: float, hi: float) -> list[float]:
    """Tick values for a log axis over [lo, hi]: 1-2-5 per decade, or 1..9 when that gives fewer
    than three (implot labels only whole decades, so a short range would have no label)."""
    if not (lo > 0 and hi >= lo):
        return []
    decades = range(math.floor(math.log10(lo)), math.floor(math.log10(hi)) + 1)
    for mantissas in (MANTISSAS, range(1, 10)):
        ticks = [m * 10.0 ** d for d in decades for m in mantissas if lo <= m * 10.0 ** d <= hi]
        if len(ticks) >= 3:
            return ticks
    return ticks


def _label(value: float) -> str:
    return f"{value:.3g}"


class ConvergencePanel(Panel):
    title = "Convergence"
    dock = "below"  # under the image: a reference fixes the render's aspect, which leaves room there

    def draw(self, session, ui: UiState) -> None:
        if session.reference is None:
            return
        if not self.begin(ui):
            return
        points = session.convergence
        if points:
            last = points[-1]
            imgui.text_wrapped(f"relMSE {last.rel_mse:.4g}  RMSE {last.rmse:.4g}  at {last.spp} spp, "
                               f"{last.seconds:.1f} s")
        if len(points) < 2:
            imgui.text_wrapped("measuring (at 1, 2, 3, 4, 5, 7, 9... spp)")
            self.end(ui)
            return
        seconds = np.array([p.seconds for p in points], np.float64)
        rel_mse = np.array([p.rel_mse for p in points], np.float64)
        guide = rel_mse[0] * seconds[0] / seconds
        if implot.begin_plot("##convergence", imgui.ImVec2(-1, -1)):
            # Refit every frame: the curve grows (implot otherwise keeps its first view).
            implot.setup_axes("render time (s)", "relMSE", implot.AxisFlags_.auto_fit, implot.AxisFlags_.auto_fit)
            for axis, values in ((implot.ImAxis_.x1, seconds), (implot.ImAxis_.y1, np.concatenate([rel_mse, guide]))):
                implot.setup_axis_scale(axis, implot.Scale_.log10)
                ticks = log_ticks(float(values.min()), float(values.max()))
                if ticks:
                    implot.setup_axis_ticks(axis, ticks, [_label(t) for t in ticks], False)
            implot.plot_line(session.renderer.plugin.name, seconds, rel_mse)
            implot.set_next_line_style(imgui.ImVec4(0.6, 0.6, 0.6, 1.0), 1.0)
            implot.plot_line("1 / time", seconds, guide)
            implot.end_plot()
        self.end(ui)
