"""benchmarks/bvh_quality.py: each build it reports is made with the bins it names."""
from __future__ import annotations

import sys

import numpy as np

from conftest import REPO
from lift_gl.accel import bvh as bvh_mod
from lift_gl.accel import cache as cache_mod

sys.path.insert(0, str(REPO / "benchmarks"))
import bvh_quality  # noqa: E402


def test_each_build_uses_the_bins_it_names(tmp_path, monkeypatch):
    trimesh = __import__("trimesh")
    # rows of small triangles whose gaps fall between 32 bins' planes (test_bvh's finer bins)
    rng = np.random.default_rng(31)
    rows = np.repeat(np.arange(37) / 37.0 + 0.003, 80)
    base = np.stack([rows + 0.015 * rng.random(rows.size), rng.random(rows.size), rng.random(rows.size)], axis=1)
    tris = (base[:, None, :] + 0.004 * rng.standard_normal((rows.size, 3, 3))).astype(np.float32)
    path = tmp_path / "rows.ply"
    trimesh.Trimesh(vertices=tris.reshape(-1, 3), faces=np.arange(tris.size // 3).reshape(-1, 3),
                    process=False).export(path)
    monkeypatch.setenv(cache_mod.ENV_VAR, str(tmp_path / "cache"))
    r = bvh_quality.scene_quality(str(path), ["8", "32", "auto"], ["off"])
    cost = {b["bins"]: b["sah_cost"] for b in r["builds"]}
    loaded = bvh_quality._triangles(str(path))
    for bins, expect in (("8", bvh_mod.build_bvh(loaded, bins=8)), ("32", bvh_mod.build_bvh(loaded, bins=32))):
        assert np.isclose(cost[bins], bvh_mod.sah_cost(expect), rtol=1e-12)
    assert cost["auto"] < cost["32"] and cost["8"] != cost["32"]
