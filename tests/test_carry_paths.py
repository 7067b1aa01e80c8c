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
from lift_gl.options import Device, Options, Workload, resolve
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
    # auto: timed on GPUs (slower on two of four scenes there, docs/gpu.md), off on CPU rasterizers;
    # only the queued megakernel carries
    queued = Workload(path_steps=True)
    gpu, cpu = Device(software=False), Device(software=True)
    assert resolve(Options(), gpu, queued)["carry_paths"] == "faster"
    assert resolve(Options(), cpu, queued)["carry_paths"] == "off"
    for asked in ("on", "always", "faster"):
        assert resolve(Options(carry_paths=asked), cpu, queued)["carry_paths"] == "off"   # no queue on a CPU
        assert resolve(Options(carry_paths=asked, pixel_queue="on"), cpu, queued)["carry_paths"] == asked
    assert resolve(Options(carry_paths="on"), gpu, Workload(path_steps=False))["carry_paths"] == "off"


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


def _tuning_renderer(monkeypatch, scene="cornell.toml") -> Renderer:
    """carry_paths=faster with the carrying megakernel parking every new path after its
    first vertex (as `always`: on this CPU rasterizer lanes rarely see the queue run out), and
    frames timed from the first (no wait for a clock to rise)."""
    from lift_gl.passes import trace

    monkeypatch.setattr(trace, "TUNING_DELAY_S", 0.0)
    r = _renderer(monkeypatch, "faster", scene)
    assert r.trace.carry is None and r.trace.carry_tuning is not None and "u_park" not in r.trace.program
    r.trace.carry_tuning.defines["LIFT_CARRY_PARK_ALWAYS"] = True
    return r


def _late_frames(monkeypatch, r: Renderer) -> list:
    """Whether each frame's accumulation got late samples (a carrying frame resumed paths)."""
    seen = []
    run = r.accumulate.run

    def spy(frame, late=None):
        seen.append(late is not None)
        return run(frame, late=late)

    monkeypatch.setattr(r.accumulate, "run", spy)
    return seen


@pytest.mark.parametrize("kept", ["carry", "plain"])
def test_carry_tuning_keeps_a_way_and_the_same_samples(monkeypatch, kept):
    """faster: blocks of frames of either megakernel (passes/carry.py CarryTuning), then the one
    timed faster (forced here both ways) runs on. Every block finishes its paths, so the render
    has exactly its samples and the image of the megakernel that never carries."""
    from lift_gl.passes.carry import CARRY_BLOCK, CARRY_ORDER, CARRY_ROUNDS, CarryTuning

    monkeypatch.setattr(CarryTuning, "faster", lambda self: kept)
    tuning = CARRY_BLOCK * 2 * CARRY_ROUNDS   # frames of the timed blocks (after one untimed)
    frames = 1 + tuning + 6
    r = _tuning_renderer(monkeypatch)
    try:
        late = _late_frames(monkeypatch, r)
        image = r.render(spp=frames)
        totals = r.accumulate.read_totals()
        assert r.trace.carry_tuning is None and set(r.trace.carry_tuned_ms) == {"carry", "plain"}
        assert (r.trace.carry is not None) == (kept == "carry") and ("u_park" in r.trace.program) == (kept == "carry")
        # the carry blocks' frames 2 .. CARRY_BLOCK resumed paths, and the kept way's frames after
        assert [way for way in CARRY_ORDER * CARRY_ROUNDS][:2 * CARRY_ROUNDS].count("carry") == CARRY_ROUNDS
        assert sum(late[1:1 + tuning]) == CARRY_ROUNDS * (CARRY_BLOCK - 1)
        assert all(late[1 + tuning + 1:]) == (kept == "carry") and any(late[1 + tuning:]) == (kept == "carry")
    finally:
        r.release()
    plain = _renderer(monkeypatch, "off")
    try:
        reference = plain.render(spp=frames)
    finally:
        plain.release()
    assert (totals[..., 3] == frames).all()
    np.testing.assert_allclose(image, reference, rtol=1e-5, atol=1e-7)


def test_carry_tuning_finishes_parked_paths_when_a_frame_may_not_park(monkeypatch):
    """A block cut short (a frame that may not park: a render's last) still finishes the paths its
    frames parked: that frame runs the carrying megakernel, and every pixel has its samples."""
    r = _tuning_renderer(monkeypatch)
    try:
        r.render_frame(park=True)    # builds the carrying megakernel; its first dispatch, untimed, parks nothing
        r.render_frame(park=True)    # a carry block's first frame: every path alive after its first vertex parks
        counts = r.accumulate.read_totals()[..., 3]
        assert set(np.unique(counts)) == {1.0, 2.0} and (counts == 1).mean() > 0.25
        assert r.trace.carry_tuning.way == "carry" and r.trace.carry.parked
        r.render_frame(park=False)
        assert (r.accumulate.read_totals()[..., 3] == 3).all()
        assert r.trace.carry_tuning.way is None and not r.trace.carry.parked
    finally:
        r.release()


def test_carry_tuning_blocks():
    """CarryTuning's bookkeeping: blocks in CARRY_ORDER, the carry block's last frame parking
    nothing, a cut block not counted, only a block's middle frames timed (the carry way's first
    frame resumes nothing and its last runs the whole tail, which a carrying render never does),
    and the way of less time per frame kept."""
    from lift_gl.passes.carry import CARRY_BLOCK, CARRY_ORDER, CARRY_ROUNDS, CARRY_TIMED, CarryTuning

    t = CarryTuning({})
    clock = 0.0
    for block in range(2 * CARRY_ROUNDS):
        way = t.start()
        assert way == CARRY_ORDER[block % len(CARRY_ORDER)]
        if block == 1:   # a block cut short is not counted, and the same way comes next
            t.frames += 1
            t.abort()
            assert t.start() == way and t.frames == 0
        parks, reads = [], 0
        while True:
            last = t.last()
            parks.append(t.parks(True))
            # a frame: the carry way's steady frames 0.9 s, its first and last (no resume, the
            # whole tail) 5 s; the plain way's 1 s
            clock += (5.0 if t.frames in (0, CARRY_BLOCK - 1) else 0.9) if way == "carry" else 1.0
            t.frames += 1
            if t.clock_due():
                t.clock(clock)
                reads += 1
            if last:
                break
        assert reads == 2 and t.frames == CARRY_BLOCK == CARRY_TIMED + 2
        assert parks == ([True] * (CARRY_BLOCK - 1) + [False] if way == "carry" else [False] * CARRY_BLOCK)
        done = t.end()
        assert done == (block == 2 * CARRY_ROUNDS - 1)
    assert t.frame_ms() == pytest.approx({"carry": 900.0, "plain": 1000.0})
    assert t.faster() == "carry"
    assert not t.parks(False)


def test_a_render_too_short_to_time_the_carry_code_does_not_build_it(monkeypatch):
    from lift_gl.passes.carry import CARRY_TUNING_FRAMES

    r = _tuning_renderer(monkeypatch)
    try:
        r.render(spp=CARRY_TUNING_FRAMES - 1)
        assert r.trace.carry_tuning.program is None and r.trace.carry is None
        assert (r.accumulate.read_totals()[..., 3] == CARRY_TUNING_FRAMES - 1).all()
        r.render(spp=CARRY_TUNING_FRAMES + 2)   # long enough: built and timed
        assert r.trace.carry_tuning is None and r.trace.carry_tuned_ms is not None
    finally:
        r.release()


def test_a_driver_that_rejects_the_carry_code_keeps_the_plain_megakernel(monkeypatch):
    """The carry code compiles only when a render starts timing it; a driver that rejects it
    (a ShaderError) must not end the render: the plain megakernel goes on, and why is kept."""
    from lift_gl import shaders
    from lift_gl.errors import ShaderError
    from lift_gl.passes.carry import CARRY_TUNING_FRAMES

    r = _tuning_renderer(monkeypatch)
    try:
        real = shaders.compile_compute

        def reject_carry(ctx, source):
            if "#define LIFT_CARRY_PATHS" in source.text:
                raise ShaderError("unsupported", "carry.glsl", 1)
            return real(ctx, source)

        monkeypatch.setattr(shaders, "compile_compute", reject_carry)
        r.render(spp=CARRY_TUNING_FRAMES + 2)
        assert r.trace.carry_tuning is None and r.trace.carry is None
        assert "did not compile" in r.trace.carry_fallback and "did not compile" in r.explain()
        assert (r.accumulate.read_totals()[..., 3] == CARRY_TUNING_FRAMES + 2).all()
    finally:
        r.release()


def test_carry_tuning_lets_no_single_slow_block_decide():
    """The first case of a fresh process on an H100 timed the carry way's blocks at up to 1.18x
    their steady time and kept the slower plain megakernel: each way's blocks are summed up by
    their faster half, so one slow block (here the first carry block at 3x) does not decide,
    while a way slower in every block still loses."""
    from lift_gl.passes.carry import CARRY_BLOCK, CARRY_ROUNDS, CARRY_TIMED, CarryTuning

    def tuned(frame_s):   # frame_s(way, block of that way): seconds a frame
        t = CarryTuning({})
        clock, seen = 0.0, {"carry": 0, "plain": 0}
        for _ in range(2 * CARRY_ROUNDS):
            way = t.start()
            for _ in range(CARRY_BLOCK):
                clock += frame_s(way, seen[way])
                t.frames += 1
                if t.clock_due():
                    t.clock(clock)
            seen[way] += 1
            t.end()
        return t

    t = tuned(lambda way, k: (2.7 if k == 0 else 0.9) if way == "carry" else 1.0)
    assert t.block_ms()["carry"] == pytest.approx([2700.0, 900.0, 900.0])
    assert len(t.block_ms()["plain"]) == CARRY_ROUNDS and CARRY_TIMED == CARRY_BLOCK - 2
    assert t.frame_ms() == pytest.approx({"carry": 900.0, "plain": 1000.0}) and t.faster() == "carry"
    t = tuned(lambda way, k: 1.1 if way == "carry" else (3.0 if k == 1 else 1.0))
    assert t.faster() == "plain"
