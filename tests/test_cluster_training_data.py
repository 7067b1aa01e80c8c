"""The denoiser's training data rendered on a Ray cluster (render_data.generate with
--executor ray, on a local two-worker cluster the test starts on 127.0.0.1): the same scenes,
bit for bit, as one process renders, written by the driver; a rerun keeps what is there."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("ray", reason="the cluster extra is not installed (pip install 'lift-gl[cluster]')")

from ray_cluster import LocalCluster  # noqa: E402

GENERATE = """
import sys
from pathlib import Path
from lift_gl.cluster.options import ExecutorSettings
from lift_gl.denoise.train.render_data import generate
out, kind, address = Path(sys.argv[1]), sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None
executor = ExecutorSettings(kind, address) if kind == "ray" else None
paths = generate(out, [11, 12, 13], size=(16, 16), ref_spp=16, log=print, samplings=("independent", "coherent"),
                 executor=executor)
print("PATHS", *[p.name for p in paths])
"""


def _generate(out, env, *args) -> str:
    run = subprocess.run([sys.executable, "-c", GENERATE, str(out), *args], env=env, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


def test_training_data_on_a_cluster_equals_one_process(tmp_path):
    cluster = LocalCluster(workers=2)
    try:
        local = _generate(tmp_path / "local", cluster.env, "local")
        on_ray = _generate(tmp_path / "ray", cluster.env, "ray", cluster.address)
        again = _generate(tmp_path / "ray", cluster.env, "ray", cluster.address)   # nothing left to render
    finally:
        cluster.stop()
    names = local.split("PATHS", 1)[1].split()
    assert len(names) == 3 and on_ray.split("PATHS", 1)[1].split() == names
    assert "ray: 2 workers" in on_ray and "(ray)" in on_ray
    for name in names:
        with np.load(tmp_path / "local" / name) as a, np.load(tmp_path / "ray" / name) as b:
            assert sorted(a.files) == sorted(b.files)
            for key in a.files:
                np.testing.assert_array_equal(a[key], b[key], err_msg=f"{name}: {key}")
    assert "ray:" not in again and again.split("PATHS", 1)[1].split() == names   # all kept: no worker started
