"""A class graded on a local Ray cluster of two workers against one process: the same grades?
how long? and with a worker killed in the middle of the run?

    python benchmarks/grade_cluster.py [--class examples/grading/class] [--out benchmarks/results/grade_cluster.json]
                                       [grade options, e.g. --size 48x48 --seeds 16 --spp 8]

Starts the cluster itself (tests/ray_cluster.py: one node of 2 CPUs on 127.0.0.1), grades the
class three times (one process; the cluster; the cluster with worker 0 killed once the first
submission's grades are in), each with a reference cache of its own, and writes the times and
whether grades.csv (less its seconds column) is the same."""
from __future__ import annotations

import argparse
import csv
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

from ray_cluster import LocalCluster  # noqa: E402


def grades(out: Path) -> list[dict]:
    with open(out / "grades.csv", newline="") as f:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(f)]


def run(args, env, kill_first=None):
    start = time.perf_counter()
    process = subprocess.Popen([sys.executable, "-m", "lift_gl", *map(str, args)], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
    lines, pids, killed = [], {}, None
    for line in process.stdout:
        lines.append(line.rstrip())
        if line.startswith("ray: worker ") and "(pid " in line:
            pids[line.split()[2]] = int(line.rsplit("(pid ", 1)[1].rstrip(")\n"))
        if kill_first and killed is None and line.startswith(kill_first + ":") and "0" in pids:
            killed = pids["0"]
            os.kill(killed, signal.SIGKILL)
    code = process.wait()
    return {"seconds": time.perf_counter() - start, "exit": code, "killed_pid": killed,
            "lost_lines": [l for l in lines if "worker was lost" in l], "tail": lines[-3:]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--class", dest="klass", type=Path, default=REPO / "examples" / "grading" / "class")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "grade_cluster.json")
    known, grade_args = parser.parse_known_args()
    first = sorted(p.parent.name for p in known.klass.glob("*/plugin.toml"))[0]
    cluster = LocalCluster(workers=2)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            results = {}
            for name, extra, kill in (("one_process", [], None),
                                      ("ray_2_workers", ["--executor", "ray", "--address", cluster.address], None),
                                      ("ray_2_workers_one_killed", ["--executor", "ray", "--address", cluster.address,
                                                                    "--seeds-per-task", "4"], first)):
                out = tmp / name
                args = ["grade", known.klass, *grade_args, "--cache-dir", tmp / f"cache-{name}", "--out", out, *extra]
                results[name] = run(args, cluster.env, kill)
                results[name]["grades"] = grades(out) if (out / "grades.csv").is_file() else None
                print(name, f"{results[name]['seconds']:.1f} s", flush=True)
            base = results["one_process"]["grades"]
            summary = {"class": str(known.klass.relative_to(REPO)) if known.klass.is_relative_to(REPO) else str(known.klass),
                       "grade_options": grade_args, "submissions": len({g["submission"] for g in base}),
                       "verdicts": {f"{g['submission']}/{g['scene']}": g["verdict"] for g in base}}
            for name, r in results.items():
                summary[name] = {"seconds": round(r["seconds"], 1), "exit": r["exit"],
                                 "same_grades_as_one_process": r["grades"] == base,
                                 **({"worker_killed": r["killed_pid"] is not None, "lost_lines": r["lost_lines"]}
                                    if r["killed_pid"] is not None else {})}
    finally:
        cluster.stop()
    known.out.parent.mkdir(parents=True, exist_ok=True)
    known.out.write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps({k: v for k, v in summary.items() if k != "verdicts"}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
