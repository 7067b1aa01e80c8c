"""benchmarks/frame_waits.py (issue 10): the same frames give the same image whatever the
interval between the CPU's waits, every frame is timed, and the settings asked for reach the
renderer."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
_SPEC = importlib.util.spec_from_file_location("frame_waits", REPO / "benchmarks" / "frame_waits.py")
frame_waits = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(frame_waits)


def test_waits_change_the_timing_only():
    record = frame_waits.measure(str(REPO / "scenes" / "cornell.toml"), "pt:max_depth=3", (24, 16), [1, 3], 3, 2)
    assert record["params"]["max_depth"] == 3 and record["scene"] == "scenes/cornell.toml"
    runs = record["runs"]
    assert [r["wait_every"] for r in runs] == [1, 3, 3, 1]   # the order reversed every other round
    for r in runs:
        assert r["frames"] == 3 and len(r["gpu_ms"]) == 3 and r["wall_ms_per_frame"] > 0
        assert r["max_abs_diff_vs_first"] == 0.0
        assert np.isfinite(r["image_mean"]) and r["image_mean"] > 0


def test_timed_renders_both_ways_and_the_setting_restored():
    import lift_gl.gpu_waits as gpu_waits

    before = gpu_waits.TIMED_WAIT_FRACTION
    record = frame_waits.measure(str(REPO / "scenes" / "cornell.toml"), "pt:max_depth=2", (16, 16), [1], 1, 2,
                                 timed_seconds=0.05)
    timed = record["timed_renders"]
    assert [t["waits"] for t in timed] == ["queued", "each frame", "each frame", "queued"]
    assert all(t["frames"] >= 1 and t["seconds"] >= 0.05 for t in timed)
    assert gpu_waits.TIMED_WAIT_FRACTION == before
