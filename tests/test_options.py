"""The renderer's options (lift_gl/options.py): KEY=VALUE parsing and its errors, "auto" resolved
per device in one place, and --option reaching the renderer, --explain and the render's JSON."""
from __future__ import annotations

import json
import re

import pytest

from conftest import REPO
from lift_gl.options import (OPTION_FIELDS, Device, OptionError, Options, TreeShape, Workload, parse_options,
                             resolve, work_group)

CPU = Device(software=True, renderer="llvmpipe (LLVM 15.0.6, 256 bits)")
GPU = Device(software=False, renderer="NVIDIA H200/PCIe/SSE2")
DINING_ROOM = TreeShape(width=4, stack_bound=54, levels=18, nodes=72647)   # Lift's dining room, 4-wide
CORNELL_BOX = TreeShape(width=4, stack_bound=11, levels=4, nodes=7)


def test_parsing_normalises_and_a_later_key_wins():
    o = parse_options(["BVH_Width=4Q", " pixel_queue = ON ", "coherent_interleave=2", "bvh_width=4"])
    assert (o.bvh_width, o.pixel_queue, o.coherent_interleave) == ("4", "on", 2)
    assert o.changed() == {"bvh_width": "4", "pixel_queue": "on", "coherent_interleave": 2}
    assert parse_options(o.as_pairs()) == o          # what a grading child reads back
    assert parse_options([]) == Options() and Options().changed() == {}
    assert Options(max_buffer_bytes="4096").max_buffer_bytes == 4096
    assert Options(bvh_width=4).bvh_width == "4"     # a number where the choices are words


@pytest.mark.parametrize("pair, message", [
    ("bvh_widht=4", "unknown option 'bvh_widht'; did you mean bvh_width?"),
    ("gpu=fast", "unknown option 'gpu' (options: bvh_width, "),
    ("bvh_width", "--option expects KEY=VALUE, not 'bvh_width'"),
    ("=4", "--option expects KEY=VALUE"),
    ("bvh_width=8", "option bvh_width: '8' is not allowed; use 2, 4, 4q, auto"),
    ("coherent_sampling=auto", "option coherent_sampling: 'auto' is not allowed; use on, off"),
    ("coherent_interleave=0", "option coherent_interleave: '0' is not allowed; use a whole number from 1 to 8"),
    ("coherent_interleave=2.5", "option coherent_interleave"),
    ("max_buffer_bytes=8", "option max_buffer_bytes: '8' is not allowed; use auto or a whole number from 16"),
    ("max_buffer_bytes=lots", "option max_buffer_bytes"),
])
def test_one_clear_error_names_the_key_and_what_it_takes(pair, message):
    with pytest.raises(OptionError) as err:
        parse_options([pair])
    assert message in str(err.value)


def test_every_option_has_a_default_it_allows_and_a_help():
    for name, f in OPTION_FIELDS.items():
        assert f.metadata["help"], name
        assert Options(**{name: f.default}).changed() == {}, name


def test_auto_resolves_per_device():
    """Each device's own rule (the measurements: docs/gpu.md, docs/cpu-speed.md)."""
    pt = Workload(path_steps=True, tree=DINING_ROOM)
    cpu, gpu = resolve(Options(), CPU, pt), resolve(Options(), GPU, pt)
    expect_cpu = {"bvh_width": "4q", "bvh_slot_order": "build", "bvh_builder": "sah", "pixel_queue": "off",
                  "bvh_stack": "local", "bvh_stack_entries": "children", "trace_paired": "off", "carry_paths": "off",
                  "gbuffer": "raster", "uniform_blocks": "on", "coherent_sampling": "off"}
    expect_gpu = {"bvh_width": "4", "bvh_slot_order": "area", "bvh_builder": "sah", "pixel_queue": "on",
                  "bvh_stack": "local", "bvh_stack_entries": "groups", "trace_paired": "on", "carry_paths": "on",
                  "gbuffer": "traced", "uniform_blocks": "off", "coherent_sampling": "off"}
    assert {k: cpu[k] for k in expect_cpu} == expect_cpu
    assert {k: gpu[k] for k in expect_gpu} == expect_gpu
    assert cpu.gbuffer_stack == "local" and gpu.gbuffer_stack == "shared"
    # every auto choice says why
    assert all(c.why for name, c in gpu.choices.items() if c.asked == "auto")
    # what was asked is kept, on either device
    asked = Options(bvh_width="2", pixel_queue="off", bvh_stack="shared", gbuffer="raster", uniform_blocks="on")
    for device in (CPU, GPU):
        r = resolve(asked, device, pt)
        assert (r["bvh_width"], r["pixel_queue"], r["bvh_stack"], r["gbuffer"], r["uniform_blocks"]) == \
               ("2", "off", "shared", "raster", "on")


def test_the_tree_and_the_plugin_refine_the_gpus_choices():
    shallow = resolve(Options(), GPU, Workload(path_steps=True, tree=CORNELL_BOX))
    assert shallow["bvh_stack_entries"] == "children" and "16 entries" in shallow.choices["bvh_stack_entries"].why
    assert shallow["trace_paired"] == "off" and "4 levels" in shallow.choices["trace_paired"].why
    assert shallow["carry_paths"] == "off" and "4 levels" in shallow.choices["carry_paths"].why
    drt = resolve(Options(), GPU, Workload(path_steps=False, tree=DINING_ROOM))   # no path steps: no queue
    assert (drt["pixel_queue"], drt["carry_paths"], drt["bvh_stack"]) == ("off", "off", "shared")
    bdpt = resolve(Options(), GPU, Workload(splats=True, tree=DINING_ROOM))
    assert bdpt["bvh_stack_entries"] == "children" and "splats" in bdpt.choices["bvh_stack_entries"].why
    huge = TreeShape(width=4, stack_bound=54, levels=18, nodes=1 << 24)   # node ids past 24 bits
    assert resolve(Options(bvh_stack_entries="groups"), GPU, Workload(tree=huge))["bvh_stack_entries"] == "children"
    binary = resolve(Options(bvh_width="4"), GPU, Workload(motion=True))
    assert binary["bvh_width"] == "2" and "motion blur" in binary.choices["bvh_width"].why
    assert binary["bvh_stack_entries"] is None and binary["trace_paired"] is None
    cl = resolve(Options(coherent_sampling="on"), GPU, Workload(language="opencl"))
    assert cl["bvh_width"] == "2" and cl["coherent_sampling"] == "off"
    unheld = resolve(Options(), GPU, Workload(tree=TreeShape(width=2)))   # the wide layout could not hold it
    assert unheld["bvh_width"] == "2" and "cannot hold" in unheld.choices["bvh_width"].why
    assert resolve(Options(), GPU, Workload(triangles=2_000_000))["bvh_builder"] in ("lbvh", "sah")
    raster_gpu = Device(software=False, renderer="NVIDIA GeForce RTX 4090/PCIe/SSE2")
    assert resolve(Options(), raster_gpu)["gbuffer"] == "raster"


def test_work_groups_follow_the_stack():
    assert work_group("shared", CPU) == work_group("shared", GPU) == work_group("local", GPU) == (8, 4)
    assert work_group("local", CPU) == (8, 8)


def test_the_record_is_json_and_says_what_was_asked():
    r = resolve(Options(bvh_width="4"), CPU, Workload(path_steps=True, tree=CORNELL_BOX))
    record = json.loads(json.dumps(r.record()))
    assert set(record) == set(OPTION_FIELDS)
    assert record["bvh_width"] == {"value": "4", "asked": "4"}
    assert record["bvh_slot_order"]["asked"] == "auto" and record["bvh_slot_order"]["value"] == "build"
    assert "4% faster" in record["bvh_slot_order"]["why"]
    lines = r.explain()
    assert any(re.match(r"\s+bvh_slot_order\s+auto -> build because ", line) for line in lines)
    assert any(re.match(r"\s+bvh_width\s+4$", line) for line in lines)


def test_option_on_the_command_line_reaches_the_renderer_the_record_and_explain(tmp_path, capsys):
    from lift_gl.cli import main

    out = tmp_path / "c.npy"
    assert main(["render", str(REPO / "scenes" / "cornell.toml"), "--size", "16x12", "--spp", "1", "--explain",
                 "--option", "bvh_width=4", "--option", "pixel_queue=on", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "options (--option KEY=VALUE" in text
    assert re.search(r"\n\s+bvh_width\s+4\n", text) and re.search(r"\n\s+pixel_queue\s+on\n", text)
    assert re.search(r"\n\s+bvh_slot_order\s+auto -> build because llvmpipe", text)
    assert "BVH: 2 4-wide nodes" in text                       # float boxes: 4, not the CPU's 4q
    assert "its lanes taking their next pixel from a queue" in text
    record = json.loads(out.with_name("c.npy.json").read_text())
    assert record["options"]["bvh_width"] == {"value": "4", "asked": "4"}
    assert record["options"]["pixel_queue"] == {"value": "on", "asked": "on"}
    assert record["options"]["bvh_stack"]["asked"] == "auto" and record["options"]["bvh_stack"]["why"]


def test_a_bad_option_stops_the_command_before_any_work(tmp_path, capsys):
    from lift_gl.cli import main

    with pytest.raises(SystemExit):
        main(["render", str(tmp_path / "absent.toml"), "--option", "bvh_width=8", "--out", str(tmp_path / "x.png")])
    err = capsys.readouterr().err
    assert "argument --option: option bvh_width: '8' is not allowed; use 2, 4, 4q, auto" in err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("command", [["compare", "s.toml", "--spp", "1", "--out", "o"], ["bench", "s.toml"],
                                     ["view"], ["grade", "subs", "--out", "o"]])
def test_every_command_that_renders_takes_options(command, capsys):
    """--option on render, compare, bench, view and grade, listed in each one's help."""
    from lift_gl.cli import main

    with pytest.raises(SystemExit):
        main([command[0], "--help"])
    assert "--option KEY=VALUE" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(command + ["--option", "carry_paths=sometimes"])
    assert "option carry_paths: 'sometimes' is not allowed" in capsys.readouterr().err


def test_grading_passes_the_options_to_its_children(tmp_path):
    """grade's job spec carries the options (grade/worker.py reads them back) and the reference
    cache keys on them."""
    from lift_gl.grade.runner import scene_spec
    from lift_gl.grade.settings import GradeSettings
    from lift_gl.grade.worker import render_scene

    settings = GradeSettings(scenes=("cornell",), size=(8, 8), spp=1, seeds=2, options=("bvh_width=2",))
    spec = scene_spec("c", REPO / "scenes" / "cornell.toml", (8, 8), 1, [1], {}, settings.options)
    assert json.loads(json.dumps(spec))["options"] == ["bvh_width=2"]
    images, info = render_scene("pt", spec)
    assert images.shape == (1, 8, 8, 3) and info["status"] == "ok"
    with pytest.raises(OptionError, match="bvh_width"):
        GradeSettings(options=("bvh_width=3",))


def test_the_environment_holds_paths_only():
    """lift_gl/ reads no LIFT_GL_* variable but the three paths (docs: the cache, more plugins,
    Lift's scenes)."""
    names = set()
    for path in (REPO / "lift_gl").rglob("*.py"):
        names |= set(re.findall(r"\bLIFT_GL_[A-Z0-9_]+", path.read_text(encoding="utf-8")))
    assert names == {"LIFT_GL_CACHE_DIR", "LIFT_GL_PLUGIN_PATH", "LIFT_GL_SCENES"}, names
