"""The one-command training plan (python -m lift_gl.denoise.train.plan): a run stopped by its
time budget or at a step, then run again, ends with the same weights, step count and exported
model as a run that went through at once (same seeds, one device: CPU torch here)."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("onnx")

from lift_gl.denoise.train import plan  # noqa: E402

SCHEDULE = "4:2e-3:0.2,7:1e-3:2.0"  # two stages: a warm restart between them


class Clock:
    """A clock that advances one second each time it is read: a budget then runs out at a
    point of the run that does not depend on this machine's speed."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        self.now += 1.0
        return self.now


def _args(out, *extra, model="rt"):
    return ["--model", model, "--out", str(out), "--scenes", "2", "--val-scenes", "1", "--size", "32",
            "--ref-spp", "8", "--schedule", SCHEDULE, "--batch", "2", "--crop", "32", "--checkpoint-every", "2",
            *extra]


def _weights(out):
    return torch.load(out / "checkpoint.pt", map_location="cpu")["model"]


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """The scenes of the rt (temporal) plan rendered once, by a plan run stopped before training."""
    out = tmp_path_factory.mktemp("data")
    assert plan.main(_args(out, "--stop-at", "0")) == plan.NOT_DONE
    status = json.loads((out / "status.json").read_text())
    assert status["data"] == {"val": "1/1", "train": "2/2"} and status["step"] == 0
    return out


def _copy_data(rendered, out):
    for part in ("train", "val"):
        shutil.copytree(rendered / part, out / part)


def test_stopped_and_resumed_runs_end_as_one_run(rendered, tmp_path):
    whole, stopped, budget = tmp_path / "whole", tmp_path / "stopped", tmp_path / "budget"
    for out in (whole, stopped, budget):
        _copy_data(rendered, out)
    assert plan.main(_args(whole)) == 0

    # stopped at a step inside the first stage, then resumed
    assert plan.main(_args(stopped, "--stop-at", "3")) == plan.NOT_DONE
    assert json.loads((stopped / "status.json").read_text())["step"] == 3
    assert plan.main(_args(stopped)) == 0

    # stopped by the time budget (a clock that ticks once a read), then twice more
    budget_s = plan.EXPORT_RESERVE_S + 12
    codes, steps = [], []
    for _ in range(6):
        codes.append(plan.main(_args(budget, "--time-budget-s", str(budget_s)), clock=Clock()))
        steps.append(json.loads((budget / "status.json").read_text())["step"])
        if codes[-1] == 0:
            break
    assert codes[0] == plan.NOT_DONE and 0 < steps[0] < 7, (codes, steps)  # the budget stopped it mid-way
    assert codes[-1] == 0 and steps[-1] == 7, (codes, steps)
    assert steps == sorted(steps)

    reference = _weights(whole)
    for out in (stopped, budget):
        status = json.loads((out / "status.json").read_text())
        assert status["done"] and status["phase"] == "done"
        weights = _weights(out)
        assert weights.keys() == reference.keys()
        for name in reference:
            assert torch.equal(weights[name], reference[name]), (out.name, name)
    onnx_files = [whole / "lift_rt.onnx", stopped / "lift_rt.onnx"]
    assert onnx_files[0].read_bytes() == onnx_files[1].read_bytes()
    sidecar = json.loads((whole / "lift_rt.json").read_text())
    assert sidecar["architecture"]["temporal"] and sidecar["training"]["steps"] == 7
    assert (whole / "checkpoint.pt").stat().st_size < 5e6  # small enough to bring back from a device


def test_a_checkpoint_of_another_model_is_refused(rendered, tmp_path):
    out = tmp_path / "run"
    _copy_data(rendered, out)
    assert plan.main(_args(out, "--stop-at", "1")) == plan.NOT_DONE
    with pytest.raises(SystemExit, match="use another --out"):
        plan.main(_args(out, "--no-temporal"))
    for other in (["--passthrough"], ["--encoder", "16,24,32"], ["--bottleneck", "40"], ["--chroma-block", "0"]):
        with pytest.raises(SystemExit, match="use another --out"):
            plan.main(_args(out, *other))
    assert plan.main(_args(out, "--encoder", "24,32,48", "--stop-at", "2")) == plan.NOT_DONE  # the default, named


def test_schedule_parsing():
    stages = plan.parse_schedule(plan.SCHEDULE, 1.0)
    assert [s.end for s in stages] == [11000, 21000, 24000, 30000]
    assert [s.lr for s in stages] == [2e-3, 1e-3, 5e-4, 3e-4] and [s.ssim_weight for s in stages] == [0.2, 0.2, 2.0, 2.0]
    assert all(s.mean_weight == 1.0 for s in stages)
    for bad in ("10:1e-3", "10:1e-3:0.2,5:1e-3:0.2"):
        with pytest.raises(SystemExit):
            plan.parse_schedule(bad, 0.0)


def test_a_crop_larger_than_the_scenes_is_refused_before_rendering(tmp_path, capsys):
    with pytest.raises(SystemExit):
        plan.arguments(["--out", str(tmp_path / "run"), "--size", "64", "--crop", "128"])
    assert "--crop 128 is larger than the scenes' --size 64" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_init_from_loads_an_exported_model_and_refuses_another_architecture(tmp_path):
    import torch
    from lift_gl.denoise.train.export import export, load_onnx_weights
    from lift_gl.denoise.train.model import build_model

    torch.manual_seed(1)
    source = build_model("rt", temporal=True, encoder=(8, 12, 16), bottleneck=16)
    export(source, tmp_path / "source.onnx", {})
    again = build_model("rt", temporal=True, encoder=(8, 12, 16), bottleneck=16)
    load_onnx_weights(again, tmp_path / "source.onnx")
    x = torch.rand(1, 13, 32, 32)
    with torch.no_grad():
        assert torch.equal(again(x), source(x))
    with pytest.raises(SystemExit, match="not a model of this architecture"):
        load_onnx_weights(build_model("rt", temporal=True), tmp_path / "source.onnx")
    with pytest.raises(SystemExit, match="cannot read"):
        load_onnx_weights(again, tmp_path / "missing.onnx")


def test_the_chroma_block_is_refused_for_the_unet(tmp_path, capsys):
    from lift_gl.denoise.train import plan
    with pytest.raises(SystemExit):
        plan.arguments(["--out", str(tmp_path / "run"), "--model", "unet", "--chroma-block", "8"])
    assert "--chroma-block is an option of --model rt" in capsys.readouterr().err
    assert plan.arguments(["--out", str(tmp_path / "run"), "--chroma-block", "4"]).chroma_block == 4
