"""benchmarks/roulette_efficiency.py: the same seeds give a configuration equal to the
default the default's errors exactly, another setting its own; the table's ratios come from
relMSE x frame ms of gpu.py measure records."""
from __future__ import annotations

import importlib.util
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
_SPEC = importlib.util.spec_from_file_location("roulette_efficiency", REPO / "benchmarks" / "roulette_efficiency.py")
roulette = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(roulette)


def test_same_settings_same_errors_other_settings_other_errors():
    res = roulette.measure_scene(str(REPO / "scenes" / "cornell.toml"), ["pt", "pt:rr_depth=4", "pt:rr_depth=1"],
                                 (24, 16), spp=4, seeds=2, ref_spp=64)
    c = res["configs"]
    assert c["pt"]["rel_mse"] == c["pt:rr_depth=4"]["rel_mse"]   # rr_depth 4 is pt's default
    assert c["pt:rr_depth=1"]["rel_mse"] != c["pt"]["rel_mse"]
    assert all(0 < e < 10 for e in c["pt"]["rel_mse"])


def test_table_time_to_an_error_is_relmse_times_frame_ms():
    records = [{"results": [{"kind": "frame", "scene_name": "room", "integrator": "pt", "frame_ms": 10.0},
                            {"kind": "frame", "scene_name": "room", "integrator": "pt", "frame_ms": 12.0},
                            {"kind": "frame", "scene_name": "room", "integrator": "pt:rr_depth=1", "frame_ms": 4.0}]}]
    times = roulette.frame_ms(records)
    assert times[("room", "pt")] == 10.0   # the fastest of repeats
    results = [{"scene_name": "room", "configs": {
        "pt": {"rel_mse_mean": 0.01, "rel_mse_sem": 0.001, "per_sample": 2.56},
        "pt:rr_depth=1": {"rel_mse_mean": 0.03, "rel_mse_sem": None, "per_sample": 7.68}}}]
    row = [line for line in roulette.table(results, times).splitlines() if "rr_depth=1" in line][0]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[4] == "3.00" and cells[5] == "4.000" and cells[6] == "1.20"


def test_a_record_at_a_max_depth_answers_for_that_configuration(tmp_path, capsys):
    """gpu.py measure --max-depth 32 labels its frames `bdpt:rr_depth=1`; the errors were measured
    as `bdpt:max_depth=32:rr_depth=1`: the same setting. --results tabulates saved errors."""
    import json

    record = {"max_depth": 32, "results": [
        {"kind": "frame", "scene_name": "room", "integrator": "bdpt", "frame_ms": 20.0},
        {"kind": "frame", "scene_name": "room", "integrator": "bdpt:rr_depth=1", "frame_ms": 10.0}]}
    times_file = tmp_path / "times.json"
    times_file.write_text(json.dumps(record))
    saved = tmp_path / "errors.json"
    saved.write_text(json.dumps({"results": [{"scene_name": "room", "configs": {
        "bdpt:max_depth=32": {"rel_mse_mean": 0.01, "rel_mse_sem": None, "per_sample": 1.0},
        "bdpt:max_depth=32:rr_depth=1": {"rel_mse_mean": 0.03, "rel_mse_sem": None, "per_sample": 3.0}}}]}))
    assert roulette.frame_ms([record])[("room", "bdpt:max_depth=32:rr_depth=1")] == 10.0
    assert roulette.main(["--results", str(saved), "--times", str(times_file)]) == 0
    row = [line for line in capsys.readouterr().out.splitlines() if "rr_depth=1" in line][0]
    assert [c.strip() for c in row.strip("|").split("|")][6] == "1.50"   # 3x the error in half the time
