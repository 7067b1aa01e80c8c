"""How often does `lift-gl grade` fail a correct submission, and catch a biased one?

Each submission of the example class (examples/grading/class) renders a pool of seeds on each
default scene, once; the pool is cut into disjoint blocks of `seeds` seeds, each a grading
run of its own, and each is judged (lift_gl/grade/grading.judge, the grader's own verdict code)
against each of several disjoint reference pools of pt. A correct submission's false-fail rate
is the share of its (block, reference) trials that are not `pass` on some scene; a biased
one's detection rate the share that are `biased` on some scene.

    python benchmarks/grade_calibration.py --blocks 6 --references 3 --out benchmarks/results/grade_calibration

Also the pure test's calibration: the share of correct trials rejected per scene with no
tolerance at levels 0.01, 0.05 and 0.2, which should be at most the level.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from lift_gl.consistency import Blocks, Estimate, compare_estimates
from lift_gl.grade.grading import ReferenceRun, judge
from lift_gl.grade.runner import SceneRun
from lift_gl.grade.scenes import DEFAULT_SCENES, analytic_image, resolve_scene
from lift_gl.grade.settings import REFERENCE_SEED_BASE, GradeSettings
from lift_gl.grade.worker import render_scene
from lift_gl.report.machine import describe_machine, machine_line
from lift_gl.scene.loader import load_scene

REPO = Path(__file__).resolve().parent.parent
CLASS = REPO / "examples" / "grading" / "class"
CORRECT = ("alice", "dan", "erin", "frank", "gina", "hank")
BIASED = ("bob", "carol", "ivan", "judy", "kate")
LEVELS = (0.01, 0.05, 0.2)


def pool(plugin: str, scene, settings: GradeSettings, seeds: list[int]) -> np.ndarray:
    spec = {"name": scene.name, "path": str(scene.path), "size": list(settings.size), "spp": settings.spp,
            "seeds": seeds, "params": {}}
    images, _ = render_scene(plugin, spec)
    return images


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--blocks", type=int, default=6, help="grading runs per correct submission")
    parser.add_argument("--references", type=int, default=3, help="disjoint reference pools")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "grade_calibration")
    args = parser.parse_args()
    settings = GradeSettings()
    scenes = [resolve_scene(s) for s in DEFAULT_SCENES]
    alpha_scene = settings.alpha / len(scenes)
    start = time.time()
    references = {}
    for scene in scenes:
        analytic = analytic_image(load_scene(scene.path), settings.size)
        for r in range(args.references):
            seeds = [REFERENCE_SEED_BASE + 10_000 * r + i for i in range(settings.reference_seeds)]
            references[(scene.name, r)] = ReferenceRun(scene, pool("pt", scene, settings, seeds), analytic, {})
        print(f"reference pools of {scene.name}: {time.time() - start:.0f} s", flush=True)

    results = {}
    for name in CORRECT + BIASED:
        blocks = args.blocks if name in CORRECT else 1
        seeds = [settings.first_seed + i for i in range(blocks * settings.seeds)]
        outcomes = []          # per (block, reference): the verdicts per scene
        levels = {level: [] for level in LEVELS}
        for scene in scenes:
            images = pool(str(CLASS / name), scene, settings, seeds).reshape(blocks, settings.seeds,
                                                                              *settings.size[::-1], 3)
            for b in range(blocks):
                run = SceneRun("ok", images=images[b], info={"warnings": [], "dropped_fraction": 0.0})
                for r in range(args.references):
                    ref = references[(scene.name, r)]
                    grade, _ = judge(name, scene.name, run, ref, settings, alpha_scene)
                    outcomes.append({"block": b, "reference": r, "scene": scene.name, "verdict": grade.verdict,
                                     "z": grade.z, "bias": grade.bias})
                    h, w = settings.size[1], settings.size[0]
                    grid = Blocks.grid(h, w, settings.block)
                    est = Estimate.from_seeds(images[b], grid, settings.spp)
                    ref_est = Estimate.from_seeds(ref.images, grid, settings.spp)
                    for level in LEVELS:
                        levels[level].append(not compare_estimates(est, ref_est, level, tolerance=0.0, block_tolerance=None).consistent)
            print(f"{name} on {scene.name}: {time.time() - start:.0f} s", flush=True)
        trials = {}
        for o in outcomes:
            trials.setdefault((o["block"], o["reference"]), []).append(o["verdict"])
        failed = sum(any(v != "pass" for v in verdicts) for verdicts in trials.values())
        results[name] = {"correct": name in CORRECT, "trials": len(trials), "not_pass": failed,
                         "rate": failed / len(trials),
                         "rejected_without_tolerance": {str(level): float(np.mean(v)) for level, v in levels.items()},
                         "outcomes": outcomes}
        print(f"{name}: {failed} of {len(trials)} trials not pass", flush=True)

    args.out.mkdir(parents=True, exist_ok=True)
    record = {"settings": settings.as_dict(), "blocks": args.blocks, "references": args.references,
              "machine": describe_machine(), "seconds": time.time() - start, "results": results}
    (args.out / "calibration.json").write_text(json.dumps(record, indent=1, default=str))
    lines = [f"Grade calibration on {machine_line(record['machine'])}, {record['seconds']:.0f} s; grader defaults "
             f"({settings.seeds} seeds x {settings.spp} spp, {settings.size[0]}x{settings.size[1]}, alpha "
             f"{settings.alpha:g}, tolerance {settings.tolerance:g}); {args.references} disjoint reference pools.", "",
             "| submission | right? | trials | not pass | share | rejected per scene, no tolerance, at 0.01 / 0.05 / 0.2 |",
             "|---|---|---|---|---|---|"]
    for name, r in results.items():
        rej = " / ".join(f"{r['rejected_without_tolerance'][str(level)]:.3f}" for level in LEVELS)
        lines.append(f"| {name} | {'yes' if r['correct'] else 'no'} | {r['trials']} | {r['not_pass']} | "
                     f"{r['rate']:.3f} | {rej} |")
    correct = [r for r in results.values() if r["correct"]]
    total, fails = sum(r["trials"] for r in correct), sum(r["not_pass"] for r in correct)
    lines += ["", f"Correct submissions: {fails} of {total} trials not pass ({fails / total:.3%})."]
    (args.out / "calibration.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
