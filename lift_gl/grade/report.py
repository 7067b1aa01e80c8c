"""What `lift-gl grade` writes: grades.csv (a row per submission and scene, as they arrive),
pictures/SUBMISSION/SCENE.png (the submission's mean, the reference's, and where they differ),
and report.md (the verdict table, then each submission's messages and pictures)."""
from __future__ import annotations

import csv
import math
import re
import time
from pathlib import Path

import numpy as np

from ..atomic import atomic_path, write_text
from .grading import CSV_COLUMNS, Grade
from .settings import GradeSettings

Z_SIGNIFICANT = 3.0  # the picture colours the blocks whose difference is this many standard errors


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_") or "submission"


class Writer:
    def __init__(self, out: Path, settings: GradeSettings):
        self.out, self.settings = Path(out), settings
        self.out.mkdir(parents=True, exist_ok=True)
        self.csv_path = self.out / "grades.csv"
        self.written: list[dict] = []  # grades.csv is rewritten whole (atomically) as rows arrive
        self.rows([])

    def rows(self, grades: list[Grade]) -> None:
        self.written += [g.row(self.settings) for g in grades]
        with atomic_path(self.csv_path) as tmp, open(tmp, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            writer.writerows(self.written)

    def picture(self, grade: Grade, data: dict) -> str:
        """Three panels: the submission's mean, the reference's, and each block's z."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ..tonemap import to_srgb8

        relative = Path("pictures") / _safe(grade.submission) / f"{_safe(grade.scene)}.png"
        path = self.out / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        fig, axes = plt.subplots(1, 3, figsize=(7.5, 2.9), dpi=100)
        for ax, image, title in ((axes[0], data["mean"], "submission (mean of seeds)"),
                                 (axes[1], data["reference"], "reference")):
            ax.imshow(to_srgb8(image), interpolation="nearest")
            ax.set_title(title, fontsize=8)
        h, w = data["mean"].shape[:2]
        # Where: each block's relative difference, shown only where the noise cannot explain it.
        z, block_bias = data["block_z"], data["block_bias"]
        significant = np.abs(z) >= Z_SIGNIFICANT
        shown_values = np.where(significant, block_bias, 0.0)
        scale = max(0.05, float(np.nanmax(np.abs(np.where(significant, block_bias, np.nan)), initial=0.0)))
        scale = min(scale, 1.0)
        shown = axes[2].imshow(np.where(np.isnan(z), np.nan, shown_values), cmap="RdBu_r", vmin=-scale, vmax=scale,
                               extent=(0, z.shape[1] * data["block"], z.shape[0] * data["block"], 0),
                               interpolation="nearest")
        axes[2].set_xlim(0, w)
        axes[2].set_ylim(h, 0)
        axes[2].set_title(f"difference where |z| >= {Z_SIGNIFICANT:g} (red: too bright)", fontsize=8)
        bar = fig.colorbar(shown, ax=axes[2], fraction=0.046, pad=0.04, format=lambda v, _: f"{100 * v:+.0f}%")
        bar.ax.tick_params(labelsize=7)
        for ax in axes:
            ax.set_xticks([])
            ax.set_yticks([])
        bias = f", {100 * data['bias']:+.2f}%" if math.isfinite(data["bias"]) else ""
        fig.suptitle(f"{data['title']} (z = {data['z']:+.1f}{bias})", fontsize=9)
        fig.tight_layout()
        with atomic_path(path) as tmp:
            fig.savefig(tmp)
        plt.close(fig)
        return str(relative)

    def finish(self, grades: list[Grade], references: dict, timings: dict, seconds: float, submissions) -> None:
        write_text(self.out / "report.md", render_report(grades, references, timings, seconds, self.settings,
                                                         submissions))


def _cell(g: Grade) -> str:
    if g.verdict == "biased":
        return f"**biased** ({'too bright' if g.z > 0 else 'too dark'}, z = {g.z:+.1f})"
    if g.verdict == "pass":
        return f"pass ({g.variance_ratio:.3g}x var.)" if math.isfinite(g.variance_ratio) else "pass"
    return f"**{g.verdict}**"


def render_report(grades: list[Grade], references: dict, timings: dict, seconds: float, settings: GradeSettings,
                  submissions) -> str:
    from ..report.machine import describe_machine, machine_line

    scenes = list(dict.fromkeys(g.scene for g in grades))
    subs = list(dict.fromkeys(g.submission for g in grades))
    by = {(g.submission, g.scene): g for g in grades}
    s = settings
    lines = [f"# Grades: {submissions}", "",
             f"{len(subs)} submissions on {len(scenes)} scenes, graded {time.strftime('%Y-%m-%d %H:%M')} in "
             f"{seconds:.0f} s on {machine_line(describe_machine())}.", "",
             "Each submission rendered every scene "
             f"{s.seeds} times with independent seeds ({s.spp} spp each, {s.size[0]}x{s.size[1]}); the reference "
             f"`{s.reference}` {s.reference_seeds} seeds of the same spp. Their expectations are compared block by "
             f"block ({s.block}x{s.block} pixels) and over the whole image (lift_gl/consistency.py); a difference of "
             f"more than {100 * s.tolerance:g}% that the noise cannot explain is a bias. A correct submission fails "
             f"anywhere with probability at most {s.alpha:g}.", "",
             "- **pass**: consistent with the reference (and the analytic answer, where there is one); it may be "
             "far noisier — `var.` is its variance per sample against the reference's.",
             "- **biased**: its image converges to something else. z is the difference in standard errors "
             "(z > 0: too bright); the picture shows where.",
             "- **error**: it does not compile or its render crashed; **timeout**: no result in "
             f"{s.timeout:g} s.", "",
             "| submission | " + " | ".join(scenes) + " | seconds |",
             "|---|" + "---|" * len(scenes) + "---|"]
    for sub in subs:
        lines.append(f"| {sub} | " + " | ".join(_cell(by[(sub, sc)]) for sc in scenes)
                     + f" | {timings.get(sub, math.nan):.1f} |")
    lines.append("")
    checks = [(name, ref.analytic_check) for name, ref in references.items() if ref.analytic_check is not None]
    for name, check in checks:
        state = "agrees with" if check.consistent else "**disagrees with**"
        lines.append(f"The reference {state} the analytic answer on {name} (z = {check.z:+.2f}).")
    if checks:
        lines.append("")
    for sub in subs:
        lines += [f"## {sub}", ""]
        for sc in scenes:
            g = by[(sub, sc)]
            lines.append(f"- **{sc}: {g.verdict}** ({g.seconds:.1f} s). {g.message}")
        lines.append("")
        for sc in scenes:
            g = by[(sub, sc)]
            if g.picture and g.verdict != "pass":
                lines += [f"![{sub} on {sc}]({g.picture})", ""]
    return "\n".join(lines) + "\n"
