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
    already: bool = False                # some seed was below the target at its first checkpoint:
                                         # its time is an upper bound (the target was met sooner)
    consistent: bool | None = None       # the bias test's answer (None: not tested)

    @property
    def reached(self) -> bool:
        return math.isfinite(self.seconds.mean)


@dataclass
class Verdict:
    metric: str
    target: float
    target_given: bool
    reaches: list[Reach]                 # fastest first; inf: never reached
    winner: str | None = None            # the fastest consistent configuration that reached the target

    def ratio_text(self, r: Reach, best: Reach) -> str:
        """r's time over the winner's, as a bound where either time is one."""
        if r.already and best.already:
            return "at its first checkpoint too (no ratio: both met it before they were first measured)"
        value = r.ratio.format(".2f", "×")
        if best.already:
            return f"at least {r.ratio.mean:.2f}× as long (the winner met it before its first checkpoint)"
        if r.already:
            return f"at most {r.ratio.mean:.2f}× as long (it met it before its first checkpoint)"
        return f"{value} as long"

    def sentence(self) -> str:
        name = NAMES[self.metric]
        best = next((r for r in self.reaches if r.label == self.winner), None)
        if best is None:
            return f"No configuration reaches {name} {self.target:.3g} within its budget."
        how = "(the target given)" if self.target_given else "(the highest final error of any run: every run got there)"
        unbiased = " among the configurations consistent with the reference" if any(
            r.consistent is False for r in self.reaches) else ""
        parts = [f"**{best.label}** reaches {name} {self.target:.3g} {how} first{unbiased}, in "
                 f"{'at most ' if best.already else ''}{best.seconds.format('.3g', ' s')}"]
        for r in self.reaches:
            if r is best:
                continue
            tag = " (**biased**: it converges to another image)" if r.consistent is False else ""
            if not r.reached:
                parts.append(f"{r.label}{tag} does not reach it within its budget")
            elif r.ratio is None:
                parts.append(f"{r.label}{tag} takes {r.seconds.format('.3g', ' s')}")
            else:
                parts.append(f"{r.label}{tag} takes {'at most ' if r.already else ''}"
                             f"{r.seconds.format('.3g', ' s')}: {self.ratio_text(r, best)}")
        return "; ".join(parts) + "."

    def as_json(self) -> dict:
        return {"metric": self.metric, "target": self.target, "sentence": self.sentence(), "winner": self.winner,
                "seconds": {r.label: r.seconds.__dict__ for r in self.reaches},
                "bounds": {r.label: ("upper" if r.already else "never" if not r.reached else "measured")
                           for r in self.reaches}}


def verdict(runs_by_label: dict, metric: str, target: float | None = None,
            consistent: dict | None = None) -> Verdict | None:
    """Who reaches `target` error first (default: the highest error of any run's last
    checkpoint, which every run reached), and the ratio of times with its confidence interval.
    consistent: label -> the bias test's answer; a configuration found biased is never the
    winner over one that is not."""
    if any(metric not in runs[0][0] for runs in runs_by_label.values()):
        return None
    consistent = consistent or {}
    given = target is not None
    if target is None:  # the worst last checkpoint of any run: every run got at least there
        target = max(run[-1][metric] for runs in runs_by_label.values() for run in runs)
    reaches = []
    for label, runs in runs_by_label.items():
        times = [time_to_reach([r["render_seconds"] for r in run], [r[metric] for r in run], target) for run in runs]
        already = any(run[0][metric] <= target for run in runs)
        reaches.append(Reach(label, log_interval(times), times, already=already, consistent=consistent.get(label)))
    reaches.sort(key=lambda r: r.seconds.mean)
    reached = [r for r in reaches if r.reached]
    best = next((r for r in reached if r.consistent is not False), reached[0] if reached else None)
    if best is not None:
        for r in reaches:
            if r is not best and r.reached:
                r.ratio = ratio_interval(r.per_seed, best.per_seed)
    return Verdict(metric=metric, target=target, target_given=given, reaches=reaches,
                   winner=best.label if best is not None else None)


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
