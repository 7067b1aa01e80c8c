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


def _bias_cell(c) -> str:
    if c is None:
        return "not tested"
    if c.consistent:
        return f"consistent (z = {c.z:+.1f}; bias < {100 * c.resolution:.2g}%)"
    return f"**biased** ({100 * c.bias:+.2f}%, z = {c.z:+.1f})"


def render(summary: dict, finals: dict, verdicts: list, equal_time: dict, t_equal: float, overhead: dict,
           machine: dict, consistency: dict | None = None) -> str:
    consistency = consistency or {}
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
    lines += [f"- **BIASED** `{label}` (the bias test: it converges to another image than the reference): "
              f"{c.sentence()}" for label, c in consistency.items()
              if c is not None and not c.consistent and label not in summary.get("biased", {})]
    lines += ["",
             "## Verdict", ""]
    lines += [f"- {v.sentence()}" for v in verdicts] or ["- (no verdict: no metric in common)"]
    best = {}
    for m in ("rel_mse", "dssim"):
        values = {k: v for k, v in equal_time[m].items() if v.n and math.isfinite(v.mean)}
        unbiased = {k: v for k, v in values.items() if consistency.get(k) is None or consistency[k].consistent}
        if unbiased or values:
            pool = unbiased or values
            best[m] = min(pool, key=lambda k: pool[k].mean)
    if best:
        parts = []
        for m, winner in best.items():
            tag = lambda k: " (biased)" if consistency.get(k) is not None and not consistency[k].consistent else ""  # noqa: E731
            others = ", ".join(f"{k}{tag(k)} {v.mean:.3g} ({v.mean / equal_time[m][winner].mean:.2f}× the error)"
                               for k, v in equal_time[m].items() if k != winner and v.n)
            parts.append(f"{NAMES[m]}: **{winner}** {equal_time[m][winner].format()}" + (f"; {others}" if others else ""))
        lines += [f"- At equal render time ({t_equal:.3g} s, the shortest run's end): " + "; ".join(parts) + "."]
    lines += ["", "## Convergence", "", "![error against render time](convergence.png)", "",
              "Geometric mean over seeds, shaded: 95% confidence interval; dotted: a 1/time slope, the rate of "
              "an unbiased Monte Carlo estimator at constant cost per sample; dashed: the verdict's target. "
              "Vector version: [convergence.svg](convergence.svg); every checkpoint: [metrics.csv](metrics.csv).", "",
              "## At the end of each run", ""]
    header = ["configuration", "spp", "render s", "wall s"] + [NAMES[m] for m in metrics] + ["est. relMSE", "bias test", "dropped"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for label, f in finals.items():
        cells = [f"`{label}`", f"{f['spp'].mean:.0f}", _fmt(f["render_seconds"], ".3g"), _fmt(f["wall_seconds"], ".3g")]
        cells += [_fmt(f[m]) for m in metrics] + [_fmt(f["est_rel_mse"]), _bias_cell(consistency.get(label)),
                                                  str(f["dropped_samples"])]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "**est. relMSE** is the render's own estimate of its relMSE, without the reference (from two "
              "halves of its frames accumulated apart): the variance part of the error. **bias test**: whether the "
              "configuration's expectation is the reference's (lift_gl/consistency.py): the final images of its "
              "seeds, with each pixel's variance from its two halves, against the reference's "
              + ("(its own variance from its halves)" if summary["reference"].get("spp") and "file" not in
                 summary["reference"] else "(a file, taken as exact: its own noise is not known)")
              + f", per {8}x{8} block and over the image; a difference beyond the tolerance that the noise cannot "
              "explain is a bias (z: the image's difference in standard errors; `bias <`: what the test would have "
              "seen). A biased configuration is never named the winner over a consistent one." + (
                  " For a denoised configuration the variance is that of its noisy mean, larger than the denoised "
                  "image's: its test is lenient." if any("+denoise=" in label for label in finals) else ""), "",
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
