"""`lift-gl grade` and `lift-gl compare` with `--executor ray`, on a Ray cluster of two workers
that the test starts on 127.0.0.1 (tests/ray_cluster.py): the grades (verdicts, z, variance
ratios, messages) and compare's metrics equal one process's, also when a worker is killed in the
middle of the run."""
from __future__ import annotations

import csv
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("ray", reason="the cluster extra is not installed (pip install 'lift-gl[cluster]')")

from ray_cluster import LocalCluster  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
CLASS = REPO / "examples" / "grading" / "class"
STUDENTS = ("alice", "dan", "ivan", "judy", "leo")   # correct, correct and noisy, biased, biased, broken
GRADE = ["--scenes", "furnace,cornell", "--size", "32x32", "--spp", "4", "--seeds", "16", "--reference-seeds", "32"]
TIMED = {"seconds"}   # columns that differ from run to run


@pytest.fixture(scope="module")
def cluster():
    c = LocalCluster(workers=2)
    yield c
    c.stop()


@pytest.fixture(scope="module")
def small_class(tmp_path_factory):
    root = tmp_path_factory.mktemp("class")
    for name in STUDENTS:
        shutil.copytree(CLASS / name, root / name)
    return root


def lift_gl(args) -> list:
    return [sys.executable, "-m", "lift_gl", *[str(a) for a in args]]


def grades(out: Path) -> list[dict]:
    with open(out / "grades.csv", newline="") as f:
        return [{k: v for k, v in row.items() if k not in TIMED} for row in csv.DictReader(f)]


@pytest.fixture(scope="module")
def one_process(small_class, tmp_path_factory, cluster):
    tmp = tmp_path_factory.mktemp("local")
    subprocess.run(lift_gl(["grade", small_class, *GRADE, "--cache-dir", tmp / "cache", "--out", tmp / "out"]),
                   env=cluster.env, check=True, capture_output=True, timeout=600)
    return grades(tmp / "out")


def test_cluster_grades_equal_one_process(cluster, small_class, one_process, tmp_path):
    run = subprocess.run(lift_gl(["grade", small_class, *GRADE, "--cache-dir", tmp_path / "cache",
                                  "--out", tmp_path / "out", "--executor", "ray", "--address", cluster.address,
                                  "--seeds-per-task", "4"]),
                         env=cluster.env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "ray: 2 workers" in run.stdout
    assert grades(tmp_path / "out") == one_process      # the reference rendered on the cluster too
    verdicts = {(r["submission"], r["scene"]): r["verdict"] for r in one_process}
    assert verdicts[("alice", "cornell")] == "pass" and verdicts[("ivan", "furnace")] == "biased"
    assert verdicts[("leo", "furnace")] == "error"


def test_cluster_survives_a_killed_worker(cluster, small_class, one_process, tmp_path):
    """Worker 0's process is killed once the first submission's grades are in: its task runs
    again on a new worker, and every grade is still the one-process one."""
    process = subprocess.Popen(lift_gl(["grade", small_class, *GRADE, "--cache-dir", tmp_path / "cache",
                                        "--out", tmp_path / "out", "--executor", "ray", "--address", cluster.address,
                                        "--seeds-per-task", "2"]),
                               env=cluster.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines, pids, killed = [], {}, None
    for line in process.stdout:
        lines.append(line.rstrip())
        if line.startswith("ray: worker ") and "(pid " in line:
            pids[line.split()[2]] = int(line.rsplit("(pid ", 1)[1].rstrip(")\n"))
        if killed is None and line.startswith(STUDENTS[0] + ":") and "0" in pids:
            killed = pids["0"]
            os.kill(killed, signal.SIGKILL)   # a worker this test's cluster started
    assert process.wait(timeout=600) == 0, "\n".join(lines)
    assert killed is not None, "\n".join(lines)
    assert any("a worker was lost" in line for line in lines), "\n".join(lines)
    assert grades(tmp_path / "out") == one_process


def test_cluster_compare_equals_one_process(cluster, tmp_path):
    args = ["compare", REPO / "scenes" / "cornell_diffuse.toml", "--integrators", "pt,template", "--spp", "8",
            "--size", "32x32", "--seeds", "2", "--ref-spp", "64"]
    for name, extra in (("local", []), ("ray", ["--executor", "ray", "--address", cluster.address])):
        run = subprocess.run(lift_gl(args + ["--out", tmp_path / name] + extra), env=cluster.env,
                             capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, run.stdout + run.stderr

    def metrics(name):
        with open(tmp_path / name / "metrics.csv", newline="") as f:
            return [(r["configuration"], r["seed"], r["spp"], r["rel_mse"], r["dssim"]) for r in csv.DictReader(f)]

    assert metrics("ray") == metrics("local") and len(metrics("local")) > 4
