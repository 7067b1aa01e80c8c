"""Made-up submissions for trying `lift-gl grade --lab` on each kit: each is the kit's
solution with one mistake a student makes (or one correct variation), plus the starter and
the solution themselves.

    python labs/example_submissions.py OUT
    lift-gl grade OUT/lab2-path-tracing --lab labs/lab2-path-tracing --out grades-lab2

Writes OUT/LAB/NAME/ (a plugin folder each) and prints what each should get. Never put OUT
where students can read it: every submission but the starter is the solution, nearly.
"""
from __future__ import annotations

import argparse
import shutil
from dataclasses import dataclass
from pathlib import Path

LABS = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Mistake:
    lab: str
    name: str
    expect: str      # the verdicts the grader should give, in words
    file: str        # the solution's file to change
    edits: tuple     # (old, new) pairs: each old text appears once in it


MISTAKES = [
    Mistake("lab1-distribution-rt", "uniform_radius_lens",
            "pass on every scene (a blur's shape hardly moves an 8x8 block's mean); lift-gl warptest rejects its lens",
            "lens.glsl", (("float r = sqrt(u.x);", "float r = u.x;"),)),
    Mistake("lab1-distribution-rt", "no_glossy_mis", "biased on lab1_dof (the light counted twice in the gold sphere)",
            "drt_lab.glsl", (("float w = branch_goes_on && !ls.is_delta ? power_heuristic",
                              "float w = false ? power_heuristic"),)),
    Mistake("lab1-distribution-rt", "raster_hit_at_shutter_open",
            "biased on lab1_motion (the camera sees time 0, the shadows move)",
            "drt_lab.glsl", (("    own_camera_ray = true;       // the raster saw the scene at the shutter's opening\n",
                              ""),)),
    Mistake("lab2-path-tracing", "light_counted_twice", "biased everywhere light is found (too bright)",
            "pt_lab.glsl", (("    if (specular_prev) return 1.0;\n", "    return 1.0;\n"),)),
    Mistake("lab2-path-tracing", "roulette_not_reweighted",
            "biased (too dark) on cornell and glass; furnace and lab2_lights end before rr_depth",
            "pt_lab.glsl", (("            throughput /= survive;\n", ""),)),
    Mistake("lab2-path-tracing", "balance_heuristic", "pass: another correct MIS weight (on both strategies)",
            "pt_lab.glsl", (("power_heuristic(bsdf_pdf_prev, light_pdf_here)",
                             "balance(bsdf_pdf_prev, light_pdf_here)"),
                            ("power_heuristic(ls.pdf, pdf_bsdf)", "balance(ls.pdf, pdf_bsdf)"),
                            ("// ---- Step 2:",
                             "float balance(float a, float b) { return a + b > 0.0 ? a / (a + b) : 0.0; }\n\n"
                             "// ---- Step 2:"))),
    Mistake("lab2-path-tracing", "does_not_compile", "error, naming pt_lab.glsl and the line",
            "pt_lab.glsl", (("    vec3 L = vec3(0.0);           // radiance found so far\n",
                             "    vec3 L = vec3(0.0)            // the semicolon forgotten\n"),)),
    Mistake("lab3-bdpt", "no_mis_weights", "biased (too bright): steps 1 and 2 done, every strategy weight 1",
            "bdpt_mis.glsl", (("    return 1.0 / (1.0 + camera_side + light_side);", "    return 1.0;"),)),
    Mistake("lab3-bdpt", "connection_without_distance", "biased: the connections miss the 1 / d^2",
            "bdpt_strategies.glsl", (("vec3 contribution = z.beta * at_z.f * at_y.f * y.beta / dist2;",
                                      "vec3 contribution = z.beta * at_z.f * at_y.f * y.beta;"),)),
    Mistake("lab3-bdpt", "balance_heuristic", "pass: the balance heuristic is MIS too",
            "plugin.toml", (("default = 2.0\nmin = 0.0\nmax = 16.0", "default = 1.0\nmin = 0.0\nmax = 16.0"),)),
]


def plugin_folder(side: Path) -> Path:
    return next(side.glob("*/plugin.toml")).parent


def write_submissions(out: Path) -> list[tuple[Path, str]]:
    written = []
    for lab in sorted({m.lab for m in MISTAKES}):
        folder = out / lab
        if folder.exists():
            shutil.rmtree(folder)
        starter, solution = plugin_folder(LABS / lab / "starter"), plugin_folder(LABS / lab / "solution")
        expect_starter = "pass (correct, noisy: a high variance ratio)" if lab == "lab2-path-tracing" else "biased"
        for name, source, expect in (("starter", starter, expect_starter), ("solution", solution, "pass")):
            shutil.copytree(source, folder / name / source.name)
            written.append((folder / name, expect))
        for m in (m for m in MISTAKES if m.lab == lab):
            target = folder / m.name / solution.name
            shutil.copytree(solution, target)
            path = target / m.file
            text = path.read_text()
            for old, new in m.edits:
                if text.count(old) != 1:
                    raise SystemExit(f"{m.lab}/{m.name}: {m.file} no longer holds the text to change once: {old!r}")
                text = text.replace(old, new)
            path.write_text(text)
            written.append((folder / m.name, m.expect))
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="folder for OUT/LAB/NAME/")
    args = parser.parse_args()
    for folder, expect in write_submissions(args.out):
        print(f"{folder}: {expect}")


if __name__ == "__main__":
    main()
