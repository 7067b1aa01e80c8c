"""From the checkpoints of every run to what the report says: curves with confidence bands,
the table at the end of the runs, errors at equal time, and the verdict (who reaches a
given error first, and how much sooner).

A run is one configuration and one seed; its rows are dicts, one per checkpoint, with
`spp`, `render_seconds`, `wall_seconds` and the error metrics.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .statistics import Interval, log_interval, loglog_interpolate, ratio_interval, time_to_reach

METRICS = ("rel_mse", "rmse", "ssim", "dssim", "flip")
NAMES = {"rel_mse": "relMSE", "rmse": "RMSE", "ssim": "SSIM", "dssim": "DSSIM", "flip": "FLIP",
         "est_rel_mse": "est. relMSE"}


def metrics_in(rows: list[dict]) -> list[str]:
    return [m for m in METRICS if rows and m in rows[0]]


def curve(runs: list[list[dict]], mode: str, grid) -> dict:
    """Geometric mean and confidence interval over seeds at each point of the grid.

    mode "spp": grid = the spp checkpoints (every seed has them);
    mode "time": grid = render times; each seed's error is interpolated there on its log-log
    curve, and points outside any seed's range are left out."""
    out = {"seconds": [], "spp": []}
    metrics = metrics_in(runs[0]) + ["est_rel_mse"]
    for m in metrics:
        out[m] = []
    for x in grid:
        if mode == "spp":
            rows = [next((r for r in run if r["spp"] == x), None) for run in runs]
            if any(r is None for r in rows):
                continue
            values = {m: [r[m] for r in rows] for m in metrics}
            seconds = [r["render_seconds"] for r in rows]
            spp = float(x)
        else:
            values = {m: [loglog_interpolate([r["render_seconds"] for r in run], [r[m] for r in run], x) for run in runs]
                      for m in metrics}
            if any(math.isnan(v) for v in values["rel_mse"]):
                continue
            seconds = [x]
            spp = float(np.mean([loglog_interpolate([r["render_seconds"] for r in run], [r["spp"] for r in run], x)
                                 for run in runs]))
        out["seconds"].append(log_interval(seconds).mean)
        out["spp"].append(spp)
        for m in metrics:
            out[m].append(log_interval([v for v in values[m] if v is not None and not math.isnan(v)]))
    return out


def final_row(runs: list[list[dict]]) -> dict:
    """The last checkpoint of each seed: intervals over seeds."""
    last = [run[-1] for run in runs]
    out = {key: log_interval([r[key] for r in last])
           for key in ("spp", "render_seconds", "wall_seconds", "est_rel_mse") + tuple(metrics_in(runs[0]))}
    out["dropped_samples"] = int(sum(r["dropped_samples"] for r in last))
    return out


@dataclass
class Reach:
    label: str
    seconds: Interval                    # time to reach the target, over seeds
    per_seed: list[float]
    ratio: Interval | None = None        # its time / the winner's time
    already: bool = False                # below the target at its first checkpoint


@dataclass
class Verdict:
    metric: str
    target: float
    target_given: bool
    reaches: list[Reach]                 # fastest first; inf: never reached

    def sentence(self) -> str:
        name = NAMES[self.metric]
        reached = [r for r in self.reaches if math.isfinite(r.seconds.mean)]
        if not reached:
            return f"No configuration reaches {name} {self.target:.3g} within its budget."
        best = reached[0]
        how = "(the target given)" if self.target_given else "(the highest final error of any run: every run got there)"
        parts = [f"**{best.label}** reaches {name} {self.target:.3g} {how} first, in "
                 f"{best.seconds.format('.3g', ' s')}{' or less' if best.already else ''}"]
        for r in self.reaches[1:]:
            if not math.isfinite(r.seconds.mean):
                parts.append(f"{r.label} does not reach it within its budget")
            else:
                parts.append(f"{r.label} takes {r.seconds.format('.3g', ' s')}: "
                             f"{r.ratio.format('.2f', '×')} as long")
        return "; ".join(parts) + "."


def verdict(runs_by_label: dict, metric: str, target: float | None = None) -> Verdict | None:
    """Who reaches `target` error first (default: the highest error of any run's last
    checkpoint, which every run reached), and the ratio of times with its confidence interval."""
    if any(metric not in runs[0][0] for runs in runs_by_label.values()):
        return None
    given = target is not None
    if target is None:  # the worst last checkpoint of any run: every run got at least there
        target = max(run[-1][metric] for runs in runs_by_label.values() for run in runs)
    reaches = []
    for label, runs in runs_by_label.items():
        times = [time_to_reach([r["render_seconds"] for r in run], [r[metric] for r in run], target) for run in runs]
        already = all(run[0][metric] <= target for run in runs)
        reaches.append(Reach(label, log_interval(times), times, already=already))
    reaches.sort(key=lambda r: r.seconds.mean)
    best = reaches[0]
    for r in reaches[1:]:
        if math.isfinite(r.seconds.mean) and math.isfinite(best.seconds.mean):
            r.ratio = ratio_interval(r.per_seed, best.per_seed)
    return Verdict(metric=metric, target=target, target_given=given, reaches=reaches)


def common_time(runs_by_label: dict) -> float:
    """The longest render time that every run reached: where images are compared at equal time."""
    return min(run[-1]["render_seconds"] for runs in runs_by_label.values() for run in runs)


def at_time(runs_by_label: dict, seconds: float, metric: str) -> dict:
    """Each configuration's error at `seconds` of render time (log-log interpolation per seed);
    NaN intervals where a run's first checkpoint came later."""
    out = {}
    for label, runs in runs_by_label.items():
        values = [loglog_interpolate([r["render_seconds"] for r in run], [r[metric] for r in run], seconds)
                  for run in runs]
        out[label] = log_interval(values) if not any(math.isnan(v) for v in values) else Interval(math.nan, math.nan, math.nan, 0)
    return out
