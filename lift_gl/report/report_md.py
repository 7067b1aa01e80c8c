"""report.md of `lift-gl compare`: what was compared, the verdict, the plot, the table at the
end of the runs, the images at equal time, and what the numbers mean."""
from __future__ import annotations

import math

from .machine import machine_line
from .summary import NAMES


def _fmt(interval, spec=".3g", unit="") -> str:
    return interval.format(spec, unit) if interval.n else "–"


def _reference_text(ref: dict) -> str:
    if "file" in ref:
        w, h = ref.get("file_size", ["?", "?"])
        return f"the file `{ref['file']}` ({w}x{h}, box-downsampled to the render size where larger)"
    text = (f"a `{ref.get('integrator', 'pt')}` render of {ref.get('spp')} spp "
            f"({'read from the cache' if ref.get('cached') else 'rendered now'}, {ref.get('render_seconds', 0):.1f} s)")
    if "estimated_rel_mse" in ref:
        text += (f"; its own estimated relMSE, {ref['estimated_rel_mse']:.2g}, adds to every relMSE below "
                 "(the reference's noise counts as error)")
    return text


def render(summary: dict, finals: dict, verdicts: list, equal_time: dict, t_equal: float, overhead: dict,
           machine: dict) -> str:
    size = "x".join(str(v) for v in summary["size"])
    budget = (f"equal spp: {summary['budget']} samples per pixel each" if summary["mode"] == "spp"
              else f"equal time: {summary['budget']:g} s of render time each")
    metrics = [m for m in ("rel_mse", "rmse", "ssim", "dssim", "flip") if m in next(iter(finals.values()))]
    lines = [f"# Error against render time: `{summary['scene']}`", "",
             f"- configurations: {', '.join(f'`{c}`' for c in summary['configurations'])}",
             f"- {size} pixels; {budget}; {summary['seeds']} independent seed(s) per configuration, "
             "runs interleaved; 95% confidence intervals over seeds (t distribution, on log values)",
             f"- reference: {_reference_text(summary['reference'])}",
             f"- machine: {machine_line(machine)}; started {summary['started']}"]
    lines += [f"- **BIASED** `{label}`: {why}" for label, why in summary.get("biased", {}).items()]
    lines += ["",
             "## Verdict", ""]
    lines += [f"- {v.sentence()}" for v in verdicts] or ["- (no verdict: no metric in common)"]
    best = {}
    for m in ("rel_mse", "dssim"):
        values = {k: v for k, v in equal_time[m].items() if v.n and math.isfinite(v.mean)}
        if values:
            best[m] = min(values, key=lambda k: values[k].mean)
    if best:
        parts = []
        for m, winner in best.items():
            others = ", ".join(f"{k} {v.mean:.3g} ({v.mean / equal_time[m][winner].mean:.2f}× the error)"
                               for k, v in equal_time[m].items() if k != winner and v.n)
            parts.append(f"{NAMES[m]}: **{winner}** {equal_time[m][winner].format()}" + (f"; {others}" if others else ""))
        lines += [f"- At equal render time ({t_equal:.3g} s, the shortest run's end): " + "; ".join(parts) + "."]
    lines += ["", "## Convergence", "", "![error against render time](convergence.png)", "",
              "Geometric mean over seeds, shaded: 95% confidence interval; dotted: a 1/time slope, the rate of "
              "an unbiased Monte Carlo estimator at constant cost per sample; dashed: the verdict's target. "
              "Vector version: [convergence.svg](convergence.svg); every checkpoint: [metrics.csv](metrics.csv).", "",
              "## At the end of each run", ""]
    header = ["configuration", "spp", "render s", "wall s"] + [NAMES[m] for m in metrics] + ["est. relMSE", "relMSE / est.", "dropped"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for label, f in finals.items():
        ratio = f["rel_mse"].mean / f["est_rel_mse"].mean if f["est_rel_mse"].mean > 0 else math.nan
        cells = [f"`{label}`", f"{f['spp'].mean:.0f}", _fmt(f["render_seconds"], ".3g"), _fmt(f["wall_seconds"], ".3g")]
        cells += [_fmt(f[m]) for m in metrics] + [_fmt(f["est_rel_mse"]), f"{ratio:.2f}", str(f["dropped_samples"])]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "**est. relMSE** is the render's own estimate of its relMSE, without the reference (from two "
              "halves of its frames accumulated apart): the variance part of the error. **relMSE / est.** near 1 means "
              "the error against the reference is all noise; well above 1 means bias (a biased estimator, a short "
              "max_depth) or a reference of another scene or renderer." + (
                  " For a denoised configuration the estimate is of its noisy mean, before the denoiser: there the "
                  "ratio compares the denoised error with the noise it started from (below 1: the denoiser helped)."
                  if any("+denoise=" in label for label in finals) else ""), "",
              "## Images at equal render time", "", "![contact sheet](contact_sheet.png)", "",
              f"Seed 1 of each configuration at its checkpoint nearest to {t_equal:.3g} s of render time; beneath, "
              "each pixel's relative squared error against the reference. Linear images: `images/*.exr`.", ""]
    if overhead:
        lines += ["## Checkpoint overhead", "",
                  "| configuration | checkpoints | plain render s | compare run: wall s | of which render s | wall / plain |",
                  "|---|---|---|---|---|---|"]
        for label, o in overhead.items():
            seconds = lambda values: ", ".join(f"{v:.2f}" for v in values)  # noqa: E731
            lines.append(f"| `{label}` | {o['checkpoints']} | {seconds(o['plain_seconds'])} | "
                         f"{seconds(o['compare_wall_seconds'])} | {seconds(o['compare_render_seconds'])} | "
                         f"{seconds(o['ratios'])} (median **{o['median_ratio']:.2f}**) |")
        lines += ["", "Each seed's checkpointed run against a plain render of the same spp and seed (one `render` "
                  "call and one readback, as `lift-gl render` does) made right after it; both after one warm-up "
                  "frame. The wall time of a run includes every checkpoint's readback, error estimate and "
                  "metrics. A shared machine makes single timings noisy: read the median.", ""]
    lines += ["## How the numbers were measured", "",
              "- **render s**: wall-clock time of the frames with the GPU work finished (`ctx.finish()` before "
              "the clock is read); the readback, metrics and error estimate at checkpoints are left out. "
              "**wall s**: since the run began, everything included.",
              "- relMSE = mean((x − ref)² / (ref² + 0.01)) and RMSE on linear RGB; SSIM (scikit-image, 7×7) on "
              "sRGB-encoded values clipped to [0, 1]; DSSIM = 1/SSIM − 1, as the Lift paper reports it"
              + ("; FLIP: NVIDIA's HDR-FLIP on linear RGB" if "flip" in metrics else "") + ".",
              "- Verdict: each seed's time to reach the target, interpolated on its log-log curve between "
              "checkpoints; the ratio's interval is Welch's, on log times.", ""]
    return "\n".join(lines)
