"""The convergence plot of `lift-gl compare`: error against render time, log-log, one curve
per configuration (geometric mean over seeds) with its confidence band. matplotlib is
imported here only, with the Agg backend (no display needed)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path

PANELS = (("rel_mse", "relMSE"), ("dssim", "DSSIM (1/SSIM − 1)"))


def plot_convergence(curves: dict, path_stem: Path, title: str, targets: dict | None = None,
                     biased=frozenset()) -> list[Path]:
    """curves: label -> {"seconds": [...], "<metric>": [Interval, ...]} for the PANELS metrics.
    targets: metric -> the error the verdict uses (a dotted line). biased: labels the bias test
    found inconsistent with the reference (dashed, and labelled so). Writes STEM.png and
    STEM.svg; returns their paths."""
    try:
        import matplotlib
    except ImportError as exc:
        from ..errors import LiftError
        raise LiftError("the plot needs matplotlib: pip install 'lift-gl[report]'") from exc
    # A Figure of its own, without pyplot: the backend of whoever called (a notebook's inline
    # one) stays as it was
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter

    fig = Figure(figsize=(9.6, 3.9))
    axes = fig.subplots(1, len(PANELS))
    fig.subplots_adjust(left=0.08, right=0.985, bottom=0.13, top=0.9, wspace=0.25)  # fixed: layout engines are slow
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (metric, name) in zip(axes, PANELS):
        for i, (label, curve) in enumerate(curves.items()):
            seconds = np.asarray(curve["seconds"], np.float64)
            values = curve[metric]
            mean = np.array([v.mean for v in values])
            lo = np.array([v.lo for v in values])
            hi = np.array([v.hi for v in values])
            keep = (seconds > 0) & np.isfinite(mean) & (mean > 0)
            color = colors[i % len(colors)]
            is_biased = label in biased
            ax.plot(seconds[keep], mean[keep], "o--" if is_biased else "o-", ms=3, lw=1.5, color=color,
                    label=f"{label} (biased)" if is_biased else label)
            if any(v.n > 1 for v in values):
                ax.fill_between(seconds[keep], lo[keep], hi[keep], color=color, alpha=0.2, lw=0)
        if metric == "rel_mse":  # the rate of an unbiased Monte Carlo estimator
            first = next(iter(curves.values()))
            s = np.asarray(first["seconds"], np.float64)
            m = np.array([v.mean for v in first[metric]])
            ok = (s > 0) & np.isfinite(m) & (m > 0)
            if ok.sum() >= 2:
                s0, m0 = s[ok][0], m[ok][0]
                ends = np.array([s0, s[ok][-1]])
                ax.plot(ends, m0 * s0 / ends, ":", color="grey", lw=1, label="∝ 1/time")
        if targets and metric in targets and np.isfinite(targets[metric]):
            ax.axhline(targets[metric], color="black", lw=0.8, ls="--", alpha=0.6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        plain = FuncFormatter(lambda v, _: f"{v:g}")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(plain)
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
        ax.set_xlabel("render time (s)")
        ax.set_ylabel(name)
        ax.grid(True, which="both", alpha=0.25)
    axes[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    paths = [Path(f"{path_stem}.png"), Path(f"{path_stem}.svg")]
    for path, dpi in zip(paths, (90, "figure")):
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi)
    return paths
