"""Paths carried into the next frame (lift_gl/passes/carry.py, LIFT_CARRY_PATHS in the queued
megakernel of passes/trace.py). On GPUs a path still under way when a frame's pixel queue has
run out is parked and finished in the next frame's dispatch, its sample added then through the
late image. The estimate must not change: the same samples (each pixel's random numbers are its
own), so the same image up to the order of float additions, and every pixel exactly its number
of samples once a render has ended. On this machine's CPU rasterizer lanes rarely see the queue
run out while a path is under way, so the tests use the option carry_paths=always: every new path
parks after its first vertex, which puts every pixel's sample through the mechanism."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lift_gl import load_scene
from lift_gl.options import Device, OptionError, Options, Workload, resolve
from lift_gl.renderer import Renderer

REPO = Path(__file__).resolve().parent.parent
SIZE = (40, 24)


def _renderer(monkeypatch, carry: str, scene="cornell.toml", coherent="off") -> Renderer:
    return Renderer(load_scene(REPO / "scenes" / scene), size=SIZE, integrator="pt",
                    options=Options(pixel_queue="on", carry_paths=carry, coherent_sampling=coherent))


def _parked(r: Renderer) -> int:
    r.ctx.finish()
    counts = np.frombuffer(r.trace.carry.buffer.read(size=8), np.uint32)
    return int(counts[r.trace.carry.side])


@pytest.mark.parametrize("scene, coherent", [
    ("cornell.toml", "off"), ("showcase.toml", "off"),
    ("cornell.toml", "on"),   # a parked path keeps its tile's numbers as the grid moves
])
def test_carried_paths_give_the_same_samples(monkeypatch, scene, coherent):
    images, totals = {}, {}
    for carry in ("off", "always"):
        r = _renderer(monkeypatch, carry, scene, coherent)
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


def test_carry_settings():
    """auto: chosen once from the device and the scene, as measured (lift_gl/options.py
    CARRY_FROM_LEVELS, docs/gpu.md): on GPUs for 4-wide trees of 16 levels or more (the rooms),
    off for shallower ones (the Covered Dragon's 15, the cornell-box's 3), with coherent
    sampling, on CPU rasterizers and wherever there is no pixel queue."""
    from lift_gl.options import CARRY_FROM_LEVELS, TreeShape

    def work(levels, width=4, path_steps=True):
        return Workload(path_steps=path_steps, tree=TreeShape(width=width, levels=levels))

    gpu, cpu = Device(software=False), Device(software=True)
    assert CARRY_FROM_LEVELS == 16
    assert resolve(Options(), gpu, work(17))["carry_paths"] == "on"        # dining room
    assert resolve(Options(), gpu, work(16))["carry_paths"] == "on"        # classroom
    assert resolve(Options(), gpu, work(15))["carry_paths"] == "off"       # Covered Dragon
    assert resolve(Options(), gpu, work(3))["carry_paths"] == "off"        # cornell-box
    assert resolve(Options(), gpu, work(0, width=2))["carry_paths"] == "off"   # binary tree: not measured
    assert resolve(Options(), gpu, Workload(path_steps=True))["carry_paths"] == "off"   # no tree yet
    assert resolve(Options(coherent_sampling="on"), gpu, work(17))["carry_paths"] == "off"
    assert resolve(Options(), cpu, work(17))["carry_paths"] == "off"       # no queue on a CPU
    assert resolve(Options(pixel_queue="on"), cpu, work(17))["carry_paths"] == "off"
    for asked in ("on", "always"):
        assert resolve(Options(carry_paths=asked), cpu, work(17))["carry_paths"] == "off"   # no queue on a CPU
        assert resolve(Options(carry_paths=asked, pixel_queue="on"), cpu, work(3))["carry_paths"] == asked
        assert resolve(Options(carry_paths=asked), gpu, work(17, path_steps=False))["carry_paths"] == "off"
    assert resolve(Options(carry_paths="off"), gpu, work(17))["carry_paths"] == "off"
    why = resolve(Options(), gpu, work(17)).choices["carry_paths"].why
    assert "17 levels" in why
    with pytest.raises(OptionError):
        Options(carry_paths="faster")   # no choice by timing a render's first frames


def test_without_the_pixel_queue_nothing_is_carried(monkeypatch):
    """The plain megakernel (CPU rasterizers' default) has no queue to run out: carrying asked
    for changes nothing, and render() runs as before."""
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=SIZE, integrator="pt",
                 options=Options(pixel_queue="off", carry_paths="on"))
    try:
        assert r.trace.carry is None and "#define LIFT_CARRY_PATHS" not in r.trace.source.text
        r.render(spp=2)
        assert (r.accumulate.read_totals()[..., 3] == 2).all()
    finally:
        r.release()
