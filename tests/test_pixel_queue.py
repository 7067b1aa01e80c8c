"""The megakernel's pixel queue (the option pixel_queue, LIFT_PIXEL_QUEUE in lift_gl/passes/trace.py; GPUs' default): lanes
take their next pixel from a queue as their paths end. Each pixel's samples are the megakernel's,
in its order, so the image is the plain megakernel's bit for bit, frame after frame (the queue
empties itself at the end of each dispatch), with several samples a frame too."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene


def _render(queue, scene_name, integrator="pt", spf=1, frames=3, size=(37, 29)):
    r = Renderer(load_scene(REPO / "scenes" / scene_name), size=size, integrator=integrator, seed=3,
                 samples_per_frame=spf, options=Options(pixel_queue=queue))
    try:
        return r.render(spp=frames * spf), r.trace.pixel_queue is not None, r.stats.dropped_samples
    finally:
        r.release()


@pytest.mark.parametrize("scene_name, spf", [("cornell.toml", 1), ("showcase.toml", 1), ("cornell.toml", 3)])
def test_pixel_queue_renders_the_megakernels_image(scene_name, spf):
    # 37x29: tiles overhang the image on both sides (pixels the queue must skip)
    plain, had_queue, dropped = _render("off", scene_name, spf=spf)
    queued, has_queue, dropped_q = _render("on", scene_name, spf=spf)
    assert not had_queue and has_queue
    assert np.isfinite(queued).all() and queued.max() > 0 and dropped == dropped_q
    np.testing.assert_array_equal(queued, plain)


def test_pixel_queue_only_where_paths_go_a_vertex_at_a_time():
    # drt traces whole paths in radiance(): no queue, the plain megakernel, and explain says why
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(8, 8), integrator="drt",
                 options=Options(pixel_queue="on"))
    try:
        assert r.trace.pixel_queue is None and r.choices["pixel_queue"] == "off"
        assert "pixel_queue         on -> off because the plugin's paths are not written as steps" in r.explain()
        assert r.render(spp=1).max() > 0
    finally:
        r.release()


def test_pixel_queue_counts_the_same_rays():
    """LIFT_COUNT_RAYS (lift-gl bench's rays a second): a lane counts the rays of all its pixels
    and adds them once; the total is the plain megakernel's."""
    rays = {}
    for queue in ("off", "on"):
        r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(37, 29), integrator="pt", seed=3,
                     count_rays=True, options=Options(pixel_queue=queue))
        try:
            r.render(spp=2)
            rays[queue] = r.stats.rays
        finally:
            r.release()
    assert rays["off"] > 2 * 37 * 29 and rays["on"] == rays["off"]


def test_a_pixel_the_loop_limit_cuts_keeps_its_finished_samples():
    """llvmpipe ends an invocation's loops after 65535 iterations in all; with the queue a lane
    runs the paths of many pixels in one loop, so the limit can end it in the middle of a pixel.
    That pixel keeps the samples its lane finished (here none: valid 0), not the frame before's
    values, and the cut is counted (Renderer.stats.loop_limited) as for the plain megakernel."""
    from test_hostile_input import _fine_glowing_box

    r = Renderer(_fine_glowing_box(12), size=(32, 32), integrator="pt", seed=1, params={"max_depth": 400},
                 options=Options(pixel_queue="on"))
    try:
        assert r.trace.pixel_queue is not None
        sentinel = np.full((32, 32, 4), -7.0, np.float32)
        r.trace.frame.write(sentinel.tobytes())   # what a frame before would have left
        r.render(spp=1)
        frame = np.frombuffer(r.trace.frame.read(), np.float32).reshape(32, 32, 4)
        assert r.stats.loop_limited > 0              # the limit did cut lanes here
        assert not (frame == -7.0).any()             # no pixel kept the old values
        assert set(np.unique(frame[..., 3])) <= {0.0, 1.0}
        cut = frame[..., 3] == 0.0
        assert cut.any() and (frame[cut] == 0.0).all()
        assert (frame[~cut][:, :3] >= 1.0).all()   # the glowing box: every sample sees >= 1
    finally:
        r.release()


def test_on_gpus_the_queued_megakernel_keeps_its_stack_local(as_if_gpu):
    """The options resolved for a GPU: 8x4 groups with the stack in shared memory, but the queued
    megakernel (pt) keeps its stack in a local array (docs/gpu.md); drt's plain megakernel keeps
    shared memory; bvh_stack still decides where set. The image is the same either way."""
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    images, layouts = {}, {}
    for integrator, stack in (("pt", "auto"), ("pt", "shared"), ("drt", "auto")):
        r = Renderer(scene, size=(24, 16), integrator=integrator, seed=3, options=Options(bvh_stack=stack))
        try:
            layouts[integrator, stack] = (r.trace.local_size, "#define LIFT_BVH_SHARED_STACK " in r.trace.source.text,
                                          r.trace.pixel_queue is not None)
            if integrator == "pt" and stack == "auto":
                assert "in a local array" in r.explain()
                assert "bvh_stack           auto -> local because the queued megakernel" in r.explain()
            images[integrator, stack] = r.render(spp=2)
        finally:
            r.release()
    assert layouts["pt", "auto"] == ((8, 4), False, True)
    assert layouts["pt", "shared"] == ((8, 4), True, True)
    assert layouts["drt", "auto"] == ((8, 4), True, False)
    assert images["pt", "auto"].max() > 0
    np.testing.assert_array_equal(images["pt", "auto"], images["pt", "shared"])
