"""Paths carried into the next frame (lift_gl/passes/carry.py, LIFT_CARRY_PATHS in the queued
megakernel of passes/trace.py). On GPUs a path still under way when a frame's pixel queue has
run out is parked and finished in the next frame's dispatch, its sample added then through the
late image. The estimate must not change: the same samples (each pixel's random numbers are its
own), so the same image up to the order of float additions, and every pixel exactly its number
of samples once a render has ended. On this machine's CPU rasterizer lanes rarely see the queue
run out while a path is under way, so the tests use $LIFT_GL_CARRY_PATHS=always: every new path
parks after its first vertex, which puts every pixel's sample through the mechanism."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lift_gl import load_scene
from lift_gl.errors import LiftError
from lift_gl.passes.carry import carry_mode
from lift_gl.renderer import Renderer

REPO = Path(__file__).resolve().parent.parent
SIZE = (40, 24)


def _renderer(monkeypatch, carry: str, scene="cornell.toml") -> Renderer:
    monkeypatch.setenv("LIFT_GL_PIXEL_QUEUE", "on")
    monkeypatch.setenv("LIFT_GL_CARRY_PATHS", carry)
    return Renderer(load_scene(REPO / "scenes" / scene), size=SIZE, integrator="pt")


def _parked(r: Renderer) -> int:
    r.ctx.finish()
    counts = np.frombuffer(r.trace.carry.buffer.read(size=8), np.uint32)
    return int(counts[r.trace.carry.side])


@pytest.mark.parametrize("scene", ["cornell.toml", "showcase.toml"])
def test_carried_paths_give_the_same_samples(monkeypatch, scene):
    images, totals = {}, {}
    for carry in ("off", "always"):
        r = _renderer(monkeypatch, carry, scene)
        try:
            assert (r.trace.carry is not None) == (carry == "always")
            if carry == "always":
                r.render_frame(park=True)
                assert _parked(r) > SIZE[0] * SIZE[1] // 4, "the mechanism must be exercised"
                r.reset()   # those parked paths are dropped with the accumulation
            images[carry] = r.render(spp=6)
            totals[carry] = r.accumulate.read_totals()
        finally:
            r.release()
    # exactly 6: a late texel of an earlier frame (nothing clears the late image; its tag says
    # which frame wrote it) added again would make more (the parked pixels differ frame to frame)
    assert (totals["always"][..., 3] == 6).all() and (totals["off"][..., 3] == 6).all()
    np.testing.assert_allclose(images["always"], images["off"], rtol=1e-5, atol=1e-7)


def test_a_parking_frame_counts_its_late_samples_in_the_next(monkeypatch):
    """Mid-render the mean stays exact: a parked pixel's frame holds no sample (count 0) and
    its sample arrives with the next frame's, so it has one sample fewer, never a wrong one."""
    r = _renderer(monkeypatch, "always")
    try:
        r.render_frame(park=True)
        parked = _parked(r)
        counts = r.accumulate.read_totals()[..., 3]
        assert (counts == 0).sum() == parked and set(np.unique(counts)) <= {0.0, 1.0}
        r.render_frame(park=False)
        counts = r.accumulate.read_totals()[..., 3]
        assert (counts == 2).all()
    finally:
        r.release()


def test_carry_settings(monkeypatch):
    monkeypatch.delenv("LIFT_GL_CARRY_PATHS", raising=False)
    assert carry_mode() == "off"   # auto: measured slower on two of four scenes (docs/gpu.md)
    assert carry_mode("on") == "on" and carry_mode("always") == "always"
    with pytest.raises(LiftError, match="LIFT_GL_CARRY_PATHS"):
        carry_mode("sometimes")


def test_without_the_pixel_queue_nothing_is_carried(monkeypatch):
    """The plain megakernel (CPU rasterizers' default) has no queue to run out: carrying asked
    for changes nothing, and render() runs as before."""
    monkeypatch.setenv("LIFT_GL_PIXEL_QUEUE", "off")
    monkeypatch.setenv("LIFT_GL_CARRY_PATHS", "on")
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=SIZE, integrator="pt")
    try:
        assert r.trace.carry is None and "#define LIFT_CARRY_PATHS" not in r.trace.source.text
        r.render(spp=2)
        assert (r.accumulate.read_totals()[..., 3] == 2).all()
    finally:
        r.release()
