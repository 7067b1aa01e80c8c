"""`lift-gl render` reports its estimated error with its time: in the summary line, in the
FILE.json written beside the image, and in the progress bar of long renders."""
from __future__ import annotations

import io
import json
import re

import numpy as np
import pytest

from conftest import REPO
from lift_gl.cli import main
from lift_gl.progress import RenderProgress
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

CORNELL = REPO / "scenes" / "cornell.toml"


def test_summary_line_and_record_beside_the_image(capsys, tmp_path):
    out = tmp_path / "cornell.png"
    assert main(["render", str(CORNELL), "--spp", "12", "--size", "24x24", "--seed", "5", "--out", str(out)]) == 0
    line = capsys.readouterr().out
    match = re.search(r"12 spp in ([\d.]+) s \(12 frames\), est\. rel\. std\. error ([\d.]+)%", line)
    assert match, line
    record = json.loads((tmp_path / "cornell.png.json").read_text())
    assert record["spp"] == 12 and record["frames"] == 12 and record["dropped_samples"] == 0
    assert record["size"] == [24, 24] and record["seed"] == 5 and record["integrator"] == "pt"
    assert record["params"]["max_depth"] == 16
    assert record["render_seconds"] == pytest.approx(float(match.group(1)), abs=0.006)
    assert 100 * record["estimated_rel_std_error"] == pytest.approx(float(match.group(2)), abs=0.006)
    # The same render through the API estimates the same error (determinism).
    r = Renderer(load_scene(CORNELL), size=(24, 24), seed=5)
    r.render(spp=12)
    assert r.estimate_error().rel_mse == pytest.approx(record["estimated_rel_mse"], rel=1e-6)
    r.release()


def test_progress_bar_shows_spp_elapsed_and_estimated_error():
    text = io.StringIO()
    r = Renderer(load_scene(CORNELL), size=(16, 16))
    progress = RenderProgress(spp=6, file=text, delay=0, error_every=0)
    r.render(spp=6, progress=progress)
    progress.close()
    updates = text.getvalue().split("\r")
    assert any("6 spp" in u and "est. error" in u and "100%" in u for u in updates), updates[-3:]
    assert any("1 spp" in u and "est. error -" in u for u in updates)  # one frame: no estimate yet
    r.release()


def test_a_timed_render_adds_at_least_one_frame():
    # compare --time asks for the time left to its next checkpoint, which can be shorter than
    # the clock's first reading: it must still get a new sample, or two checkpoints share an spp.
    r = Renderer(load_scene(CORNELL), size=(16, 16), seed=1)
    r.render(seconds=1e-12)
    assert r.stats.spp == 1 and r.stats.frames == 1
    r.render(seconds=1e-12)
    assert r.stats.spp == 2
    r.release()


def test_a_long_render_waits_for_the_gpu_every_few_frames(monkeypatch):
    """render(spp=N) waits for the GPU (ctx.finish) at least every MAX_QUEUED_FRAMES frames, not
    only at its end: an H100 handed 8192 queued frames at once returned a black image."""
    import lift_gl.gpu_waits as gpu_waits

    monkeypatch.setattr(gpu_waits, "MAX_QUEUED_FRAMES", 4)
    r = Renderer(load_scene(CORNELL), size=(16, 16), seed=5)
    finishes = []
    real_finish = type(r.ctx).finish
    monkeypatch.setattr(type(r.ctx), "finish", lambda ctx: (finishes.append(r.stats.spp), real_finish(ctx)))
    r.render(spp=10)
    r.release()
    assert r.samples_per_frame == 1
    assert finishes[:2] == [4, 8] and finishes[-1] == 10   # every 4 frames, and at the end


def test_a_timed_render_queues_frames_between_its_waits(monkeypatch):
    """render(seconds=S) reads the clock after waits, and queues between waits the frames that
    take TIMED_WAIT_FRACTION of S at the frame time measured so far (a wait after every frame
    costs a GPU the submission of the next). A fake clock makes each frame take 10 ms: with a
    5 s budget it waits every 10 frames after the first, and stops at the first wait past 5 s."""
    import lift_gl.gpu_waits as gpu_waits
    import lift_gl.renderer as renderer_module

    r = Renderer(load_scene(CORNELL), size=(8, 8), seed=2)
    clock = {"t": 0.0}
    real_frame = r.render_frame

    def frame(*args, **kwargs):
        clock["t"] += 0.01
        real_frame(*args, **kwargs)

    monkeypatch.setattr(r, "render_frame", frame)
    monkeypatch.setattr(renderer_module.time, "perf_counter", lambda: clock["t"])
    waits = []
    real_finish = type(r.ctx).finish
    monkeypatch.setattr(type(r.ctx), "finish", lambda ctx: (waits.append(r.stats.frames), real_finish(ctx)))
    r.render(seconds=5.0)
    r.release()
    frames = r.stats.frames
    assert gpu_waits.TIMED_WAIT_FRACTION * 5.0 / 0.01 == 10
    gaps = np.diff(waits)
    assert waits[0] == 1 and gaps.max() <= 10 and (gaps == 10).sum() >= 45, str(waits)
    assert 500 <= frames <= 510   # past the budget by under a batch (the last ones shrink to fit it)
