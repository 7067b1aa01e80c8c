"""`lift-gl compare` from a notebook: the plot and the table shown in the cell.

    from lift_gl.notebook import compare
    compare("scenes/cornell.toml", integrators="pt,ao", spp=64, size=(64, 64), out="cmp")

runs the command itself (the same files: metrics.csv, convergence.png, report.md, summary.json)
and returns a `Comparison`, which Jupyter shows as the verdict, the convergence plot and the
table at the end of the runs.
"""
from __future__ import annotations

import base64
import csv
import html
import json
import re
from pathlib import Path

from ..errors import LiftError


def compare(scene, integrators: str = "pt", out="compare", spp: int | None = None, seconds: float | None = None,
            size=None, seeds: int | None = None, ref=None, ref_spp: int | None = None, extra=()) -> "Comparison":
    """Run `lift-gl compare SCENE ...` (the keywords are its options; `extra`: more of its
    arguments as strings, e.g. ["--denoise", "off,final"]) and return its results."""
    from ..cli import main

    if (spp is None) == (seconds is None):
        raise LiftError("compare needs spp or seconds (one of them)")
    argv = ["compare", str(scene), "--integrators", integrators, "--out", str(out)]
    argv += ["--spp", str(spp)] if spp is not None else ["--time", str(seconds)]
    if size is not None:
        argv += ["--size", f"{int(size[0])}x{int(size[1])}"]
    if seeds is not None:
        argv += ["--seeds", str(seeds)]
    if ref is not None:
        argv += ["--ref", str(ref)]
    if ref_spp is not None:
        argv += ["--ref-spp", str(ref_spp)]
    argv += [str(a) for a in extra]
    code = main(argv)
    if code != 0:
        raise LiftError(f"lift-gl compare exited with {code} (its error is printed above)")
    return Comparison(out)


class Comparison:
    """What `lift-gl compare` wrote into a folder: `summary`, `rows` (metrics.csv), `report`."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.summary = json.loads((self.folder / "summary.json").read_text())
        with open(self.folder / "metrics.csv", newline="") as f:
            self.rows = list(csv.DictReader(f))
        self.report = (self.folder / "report.md").read_text()

    def _repr_html_(self) -> str:
        plot = base64.b64encode((self.folder / "convergence.png").read_bytes()).decode()
        verdicts = [_inline(line[2:]) for line in _section(self.report, "## Verdict") if line.startswith("- ")]
        table = _table_html([line for line in _section(self.report, "## At the end of each run")
                             if line.startswith("|")])
        return ("<div class='lift-gl-compare'>"
                + "".join(f"<p>{v}</p>" for v in verdicts)
                + f"<img alt='error against render time' style='max-width: 640px' src='data:image/png;base64,{plot}'>"
                + table + f"<p><small>{html.escape(str(self.folder / 'report.md'))}</small></p></div>")

    def __repr__(self) -> str:
        return f"<lift_gl Comparison of {', '.join(self.summary['configurations'])} in {self.folder}>"


def _section(markdown: str, heading: str) -> list[str]:
    """The lines under `heading`, up to the next heading."""
    lines = markdown.splitlines()
    if heading not in lines:
        return []
    body = []
    for line in lines[lines.index(heading) + 1:]:
        if line.startswith("#"):
            break
        body.append(line)
    return body


def _inline(text: str) -> str:
    """report.md's inline marks as HTML: `code`, **bold**."""
    text = html.escape(text, quote=False)
    text = re.sub(r"`([^`]*)`", r"<code>\1</code>", text)
    return re.sub(r"\*\*([^*]*)\*\*", r"<b>\1</b>", text)


def _table_html(lines: list[str]) -> str:
    """A Markdown table (header, rule, rows) as an HTML table."""
    rows = [[cell.strip() for cell in line.strip().strip("|").split("|")] for line in lines]
    rows = [r for r in rows if not all(set(c) <= set("-:") for c in r)]
    if not rows:
        return ""
    head = "".join(f"<th>{_inline(c)}</th>" for c in rows[0])
    body = "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>" for r in rows[1:])
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
