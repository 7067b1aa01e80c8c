"""benchmarks/gpu.py's bookkeeping: merging interleaved runs, the ratio tables, and results
that keep no paths of the machine that ran them."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location("gpu_bench", Path(__file__).resolve().parent.parent / "benchmarks" / "gpu.py")
gpu = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(gpu)


def frame(scene, trace_ms, label_rays=100.0):
    return {"kind": "frame", "scene_name": scene, "size": [1920, 1080], "integrator": "pt", "triangles": 36,
            "pass_ms_query": {"gbuffer": 1.0, "trace": trace_ms}, "pass_ms_sync": {"gbuffer": 1.0, "trace": trace_ms},
            "frame_ms": trace_ms + 1.0, "rays_per_second": label_rays * 1e6}


def rays(scene, mrays):
    return {"kind": "rays", "scene_name": scene, "size": [1920, 1080], "triangles": 36,
            "rays": {k: {"mrays_per_s": mrays, "rays": 1, "hits": 1, "ms": 1.0} for k in gpu.RAY_KINDS}}


def record(label, results):
    return {"label": label, "machine": {"software_gl": False}, "gl": "test GPU", "max_depth": 32, "results": results}


def test_best_of_takes_each_cases_fastest_and_keeps_cases_of_cut_runs():
    a = record("base", [frame("cornell-box", 12.0), rays("cornell-box", 900.0), frame("classroom", 150.0)])
    b = record("base", [frame("cornell-box", 11.0), rays("cornell-box", 1000.0)])  # cut short: no classroom
    merged = gpu.best_of([a, b])
    by = {(r["kind"], r["scene_name"]): r for r in merged["results"]}
    assert by[("frame", "cornell-box")]["pass_ms_query"]["trace"] == 11.0
    assert by[("rays", "cornell-box")]["rays"]["bounce"]["mrays_per_s"] == 1000.0
    assert by[("frame", "classroom")]["pass_ms_query"]["trace"] == 150.0


def test_tables_give_ratios_to_the_first_run_and_the_paper_at_1080p():
    base = record("base", [frame("cornell-box", 10.0), rays("cornell-box", 800.0)])
    new = record("new", [frame("cornell-box", 15.0), rays("cornell-box", 400.0)])
    text = gpu.render_tables([base, new])
    row = next(line for line in text.splitlines() if line.startswith("| cornell-box") and "pt" in line)
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[-2] == "1.500" and cells[-1] == "4.8"   # trace new/base, Lift's 4.8 ms
    ray_row = [line for line in text.splitlines() if line.startswith("| cornell-box")][-1]
    assert ray_row.rstrip(" |").endswith("0.500")


@pytest.mark.parametrize("path, expect", [
    ("/somewhere/shared/scenes_lift/classroom/scene.pbrt", "../shared/scenes_lift/classroom/scene.pbrt"),
    ("/home/x/checkout/scenes/covered_dragon.toml", "scenes/covered_dragon.toml"),
    ("/tmp/elsewhere/mine.toml", "mine.toml"),
])
def test_results_keep_no_machine_paths(path, expect):
    assert gpu.portable(path) == expect


def test_ray_kinds_run_in_the_trace_pass_layout():
    """The ray-kind shader takes the plain trace programs' work-group shape and stack placement
    (the option bvh_stack), and finds the same hits either way (here: llvmpipe, both forced)."""
    from lift_gl.options import Options
    from lift_gl.renderer import Renderer
    from lift_gl.testing import cornell_scene

    size = (40, 24)
    hits = {}
    for mode in ("shared", "local"):
        r = Renderer(cornell_scene(), size=size, integrator="pt", options=Options(bvh_stack=mode))
        program, local = gpu.ray_program(r.ctx, {"HAS_SPHERES": True}, stack=r.choices.gbuffer_stack)
        program.release()
        assert local == ((8, 4) if mode == "shared" else (8, 8))
        rays = gpu.ray_throughput(r, size, repeat=1)
        hits[mode] = [rays[k]["hits"] for k in gpu.RAY_KINDS]
        r.release()
    assert hits["shared"] == hits["local"] and hits["shared"][0] > 0.5 * size[0] * size[1]


def test_ab_compares_defines_on_the_wide_tree(tmp_path, monkeypatch, shared_dir):  # the dragon's mesh
    """`gpu.py ab` with 4-wide layouts: the binary tree and its 4-wide collapses (float and
    8-bit boxes) find the same primary hits and block the same shadow rays."""
    repo = Path(__file__).resolve().parent.parent
    monkeypatch.syspath_prepend(str(repo / "benchmarks"))   # ab's bvh_records, as when run as a script
    out = tmp_path / "ab.json"
    assert gpu.main(["ab", str(repo / "scenes" / "covered_dragon.toml"), "--sizes", "40x24", "--reps", "1",
                     "--variant", f"bin={repo}:binary", "--variant", f"w4={repo}:4",
                     "--variant", f"w4q={repo}:4q",
                     "--out", str(out)]) == 0
    import json
    case = json.loads(out.read_text())["results"][0]
    assert len(set(case["primary_hits"].values())) == 1 and case["primary_hits"]["bin"] > 0.5 * 40 * 24
    blocked = case["shadow_blocked"]
    assert len(set(blocked.values())) == 1 and 0 < blocked["bin"] < case["primary_hits"]["bin"]


def test_measure_takes_plugin_settings_as_compare_does(tmp_path):
    """`--integrators pt,pt:rr_depth=1:rr_min_survival=0` (Lift's roulette): two cases, the
    settings reach the plugin (Russian roulette from the first bounce traces fewer rays a path
    than from the fourth: paths that stay in the box trace at least 7 with the default)."""
    out = tmp_path / "m.json"
    assert gpu.main(["measure", "scenes/cornell.toml", "--sizes", "32x24", "--no-rays", "--frames", "2",
                     "--repeat", "1", "--max-depth", "8",
                     "--integrators", "pt,pt:rr_depth=1:rr_min_survival=0", "--out", str(out)]) == 0
    import json
    cases = {r["integrator"]: r for r in json.loads(out.read_text())["results"]}
    assert set(cases) == {"pt", "pt:rr_depth=1:rr_min_survival=0"}
    lift = cases["pt:rr_depth=1:rr_min_survival=0"]
    assert lift["plugin"] == "pt" and lift["settings"] == {"rr_depth": "1", "rr_min_survival": "0"}
    assert lift["rays_per_path"] < 0.8 * cases["pt"]["rays_per_path"]


def test_measure_option_axis_sets_the_option_case_by_case(tmp_path):
    """`--option KEY=a,b`: each case measured under each value, one file per value: the records
    name the binary and the 4-wide tree, and the options each case ran with."""
    out = tmp_path / "m.json"
    assert gpu.main(["measure", "scenes/cornell.toml", "--sizes", "32x24", "--no-rays", "--frames", "2",
                     "--repeat", "1", "--max-depth", "4", "--split-rounds", "1", "--integrators", "pt",
                     "--option", "bvh_width=2,4", "--out", str(out)]) == 0
    import json
    nodes = {}
    for width in ("2", "4"):
        record = json.loads((tmp_path / f"m.bvh_width-{width}.json").read_text())
        assert record["option"] == {"bvh_width": width}
        [case] = record["results"]
        nodes[width] = case["bvh"]["nodes"]
        assert case["bvh"]["width"] == int(width) and case["options"]["bvh_width"]["value"] == width
    assert nodes["2"] > nodes["4"] > 0
    with pytest.raises(SystemExit, match="--option"):
        gpu.main(["measure", "scenes/cornell.toml", "--option", "bvh_width"])
    with pytest.raises(Exception, match="bvh_width"):
        gpu.main(["measure", "scenes/cornell.toml", "--option", "bvh_width=3"])
