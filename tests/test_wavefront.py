"""The wavefront trace pass (lift_gl/passes/wavefront.py) against the megakernel it replaces:
the same paths from the same random numbers, so the same images bit for bit on llvmpipe, the
same dropped-sample and ray counts; and the megakernel wherever the wavefront cannot run."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import LiftError
from lift_gl.passes.trace import TracePass
from lift_gl.passes.wavefront import WAVEFRONT_ENV_VAR
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

SIZE = (64, 48)


def _render(monkeypatch, mode, scene, spp=4, integrator="pt", **kw):
    """Image, dropped samples, rays (with count_rays) and whether a wavefront ran."""
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, mode)
    r = Renderer(scene, size=SIZE, integrator=integrator, seed=7, **kw)
    try:
        image = r.render(spp=spp)
        return image, r.stats.dropped_samples, r.stats.rays, r.trace.wavefront is not None
    finally:
        r.release()


def _plugin_copy(tmp_path, name, edit=None, edit_manifest=None):
    """A copy of pt named `name` whose pt.glsl is edit(text), its manifest edit_manifest(text)."""
    source = REPO / "plugins" / "pt"
    folder = tmp_path / name
    folder.mkdir()
    for file, change in (("plugin.toml", edit_manifest), ("pt.glsl", edit)):
        text = (source / file).read_text()
        edited = change(text) if change else text
        assert edited != text or change is None
        if file == "plugin.toml":
            edited = edited.replace('name = "pt"', f'name = "{name}"')
        (folder / file).write_text(edited)
    return str(folder)


@pytest.mark.parametrize("scene_name, kw", [
    ("cornell.toml", {}),                                  # area lights, shadow rays
    ("showcase.toml", {"samples_per_frame": 2}),           # textures, environment map, spheres; 2 waves a frame
    ("instances.toml", {"count_rays": True}),              # instances, environment; rays counted
])
def test_wavefront_renders_the_megakernels_image(monkeypatch, scene_name, kw):
    scene = load_scene(REPO / "scenes" / scene_name)
    mega, mega_dropped, mega_rays, mega_wave = _render(monkeypatch, "off", scene, **kw)
    wave, wave_dropped, wave_rays, wave_wave = _render(monkeypatch, "on", scene, **kw)
    assert (mega_wave, wave_wave) == (False, True)
    assert np.isfinite(mega).all() and mega.max() > 0
    np.testing.assert_array_equal(wave, mega)
    assert wave_dropped == mega_dropped
    assert wave_rays == mega_rays and (mega_rays > SIZE[0] * SIZE[1] * 4 if kw.get("count_rays") else True)


def test_dropped_samples_are_counted_alike(monkeypatch, tmp_path):
    """A pt whose paths of 3 or more vertices return NaN: the wavefront drops and counts the
    same samples as the megakernel, and both images keep only the others."""
    plugin = _plugin_copy(tmp_path, "pt_nan", lambda t: t.replace(
        "vec3 path_radiance(PathState path) { return path.L; }",
        "vec3 path_radiance(PathState path) { return path.depth >= 2 ? vec3(uintBitsToFloat(0x7fc00000u)) : path.L; }"))
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    mega, mega_dropped, _, _ = _render(monkeypatch, "off", scene, integrator=plugin)
    wave, wave_dropped, _, ran = _render(monkeypatch, "on", scene, integrator=plugin)
    assert ran
    assert 0 < mega_dropped < SIZE[0] * SIZE[1] * 4
    assert wave_dropped == mega_dropped
    np.testing.assert_array_equal(wave, mega)


def test_few_steps_and_no_ballot_leave_the_rest_to_the_tail(monkeypatch):
    """One step dispatch (or none), then the tail runs every longer path to its end; the queue
    appended one atomic an invocation; a program for each mode: still the megakernel's image."""
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "off")
    scene = load_scene(REPO / "scenes" / "showcase.toml")
    r = Renderer(scene, size=SIZE, integrator="pt", seed=3)
    try:
        mega = r.render(spp=2)
        defines = r._plugin_defines(r.plugin, r.params)
        for options in ({"steps": 1, "ballot": False, "prefix": 1}, {"steps": 0},
                        {"steps": 2, "split": True, "prefix": 2}):
            wave = TracePass(r.ctx, SIZE, r.plugin, defines, wavefront=True, wavefront_options=options)
            assert wave.wavefront is not None and wave.wavefront.steps == options["steps"]
            megakernel, r.trace = r.trace, wave
            r.reset(seed=3)
            image = r.render(spp=2)
            r.trace = megakernel
            wave.release()
            np.testing.assert_array_equal(image, mega)
    finally:
        r.release()


def test_start_kernel_prefix_runs_the_first_vertices_before_compacting(monkeypatch):
    """prefix K: the start kernel runs each path's first K vertices as the megakernel's loop
    does, so its queue holds the paths that the plain start (K = 1) and K - 1 step dispatches
    leave alive (pt's paths take up to max_depth + 1 vertices: some live on after max_depth,
    none after that), and the image is still the megakernel's, bit for bit."""
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "off")
    scene = load_scene(REPO / "scenes" / "showcase.toml")
    depth = 4
    r = Renderer(scene, size=SIZE, integrator="pt", seed=5, params={"max_depth": depth})
    try:
        mega = r.render(spp=2)
        defines = r._plugin_defines(r.plugin, r.params)
        queue_lengths = {}
        for steps, prefix in ((3, 1), (2, 3), (1, 2), (0, depth), (3, depth + 1)):
            wave = TracePass(r.ctx, SIZE, r.plugin, defines, wavefront=True,
                             wavefront_options={"steps": steps, "prefix": prefix})
            assert wave.wavefront is not None and wave.wavefront.prefix == prefix
            queues = []

            def hook(what, sample, step, go, w=wave.wavefront, queues=queues):
                go()
                if what == "args" and sample == 0:  # the paths the last dispatch left alive
                    queues.append(int(np.frombuffer(w.control.read(), np.uint32)[0]))

            megakernel, r.trace = r.trace, wave
            w = wave.wavefront
            w.run = lambda frame, samples, w=w, hook=hook: type(w).run(w, frame, samples, hook=hook)
            r.reset(seed=5)
            image = r.render(spp=2)
            r.trace = megakernel
            wave.release()
            np.testing.assert_array_equal(image, mega, err_msg=f"steps {steps}, prefix {prefix}")
            queue_lengths[prefix] = queues[:steps + 1]  # the first frame's
        plain = queue_lengths[1]  # after the start kernel, step 1, 2, 3
        assert SIZE[0] * SIZE[1] > plain[0] > plain[1] > plain[2] > plain[3] > 0
        assert [queue_lengths[k][0] for k in (2, 3, depth)] == plain[1:]
        assert queue_lengths[depth + 1] == [0] * 4
    finally:
        r.release()


def test_start_kernel_runs_at_least_one_vertex(monkeypatch):
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "off")
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(8, 8), integrator="pt")
    try:
        with pytest.raises(LiftError, match="at least one path vertex"):
            TracePass(r.ctx, (8, 8), r.plugin, r._plugin_defines(r.plugin, r.params), wavefront=True,
                      wavefront_options={"prefix": 0})
    finally:
        r.release()


def test_plugins_the_wavefront_cannot_run_keep_the_megakernel(monkeypatch, tmp_path):
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    plain = _plugin_copy(tmp_path, "pt_plain", lambda t: t.replace("#define LIFT_PATH_STEPS\n", ""))
    camera = _plugin_copy(tmp_path, "pt_camera", edit_manifest=lambda t: t.replace(
        'primary = "gbuffer"', 'primary = "camera"'))
    for integrator, reason in ((plain, "LIFT_PATH_STEPS"), (camera, "camera"), ("bdpt", "LIFT_PATH_STEPS")):
        monkeypatch.setenv(WAVEFRONT_ENV_VAR, "on")
        r = Renderer(scene, size=SIZE, integrator=integrator, seed=7)
        try:
            assert r.trace.wavefront is None and reason in r.trace.wavefront_fallback
            assert "megakernel although" in r.explain()
            asked = r.render(spp=2)
        finally:
            r.release()
        image, _, _, ran = _render(monkeypatch, "off", scene, spp=2, integrator=integrator)
        assert not ran
        # (bdpt's splats are added by float atomics, in whatever order the lanes get there)
        np.testing.assert_allclose(asked, image, rtol=1e-5, atol=1e-6)


def test_slots_over_the_storage_buffer_limit_keep_the_megakernel(monkeypatch):
    """llvmpipe lets a storage buffer hold 128 MiB: a frame's pt slots at 1024x1024 would not fit."""
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "on")
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(1024, 1024), integrator="pt")
    try:
        limit = r.ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]
        if limit >= 1024 * 1024 * 256:
            pytest.skip(f"this driver's storage buffers hold {limit} bytes")
        assert r.trace.wavefront is None and "MiB of path slots" in r.trace.wavefront_fallback
    finally:
        r.release()


def test_bad_wavefront_setting_is_refused(monkeypatch):
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "sometimes")
    with pytest.raises(LiftError, match=WAVEFRONT_ENV_VAR):
        Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(8, 8), integrator="pt")


@pytest.mark.parametrize("software", [True, False])
def test_auto_is_the_megakernel_and_faster_times_both(monkeypatch, software):
    import lift_gl.gl.context as context
    from lift_gl.passes.wavefront import wavefront_mode

    monkeypatch.setattr(context, "is_software", lambda ctx: software)
    for setting, expected in (("auto", "off"), ("faster", "faster"), ("on", "on"), ("off", "off")):
        monkeypatch.setenv(WAVEFRONT_ENV_VAR, setting)
        assert wavefront_mode(object()) == expected


def test_faster_times_both_ways_and_keeps_the_faster(monkeypatch):
    """faster: the first frames alternate between the megakernel and the wavefront (the
    same samples either way), then the faster is kept; a megakernel kept frees the wavefront."""
    import lift_gl.gl.context as context
    from lift_gl.passes.trace import TUNING_FRAMES

    monkeypatch.setattr(context, "is_software", lambda ctx: False)   # wavefront_mode's view only
    monkeypatch.setattr("lift_gl.passes.trace.TUNING_DELAY_S", 0.0)  # timed from the first frame
    monkeypatch.setattr("lift_gl.passes.trace.TUNING_CLOSE", 0.0)    # one block of frames decides
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    reference, _, _, _ = _render(monkeypatch, "off", scene, spp=2 * TUNING_FRAMES + 2)
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "faster")
    r = Renderer(scene, size=SIZE, integrator="pt", seed=7)
    try:
        assert r.trace.tuning is not None and r.trace.wavefront is not None
        image = r.render(spp=2 * TUNING_FRAMES + 2)
        assert r.trace.tuning is None and set(r.trace.tuned_ms) == {"megakernel", "wavefront"}
        kept_wavefront = r.trace.tuned_ms["wavefront"] < r.trace.tuned_ms["megakernel"]
        assert (r.trace.wavefront is not None) == kept_wavefront
        np.testing.assert_array_equal(image, reference)
        # the decision itself, from given timings
        for wave_s, kept in ((0.002, False), (0.0005, True)):
            r.trace.wavefront = r.trace.wavefront or _StubWavefront()
            r.trace.tuning = {"megakernel": [0.001] * TUNING_FRAMES, "wavefront": [wave_s] * TUNING_FRAMES}
            r.trace._keep_the_faster()
            assert (r.trace.wavefront is not None) == kept
            assert ("megakernel was faster" in (r.trace.wavefront_fallback or "")) == (not kept)
            r.trace.wavefront_fallback = None
    finally:
        r.release()


def test_tuning_frames_take_the_ways_in_the_order_abba(monkeypatch):
    """The ways are timed A B B A A B B A: a clock rising linearly over the tuning frames (an
    idle GPU warming up) moves both ways' medians alike, where A B A B would favour the
    wavefront, always timed after the megakernel. Checked on the frames TracePass.run
    really takes, with a fake drift."""
    import lift_gl.gl.context as context
    from lift_gl.passes.trace import TUNING_FRAMES, tuning_way

    assert [tuning_way(i) for i in range(8)] == ["megakernel", "wavefront", "wavefront", "megakernel"] * 2
    monkeypatch.setattr(context, "is_software", lambda ctx: False)
    monkeypatch.setattr("lift_gl.passes.trace.TUNING_DELAY_S", 0.0)
    monkeypatch.setattr("lift_gl.passes.trace.TUNING_CLOSE", 0.0)
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "faster")
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=SIZE, integrator="pt", seed=7)
    try:
        ways, clock = [], iter(range(100))
        r.trace._run = lambda uniforms, visibility, as_wavefront: ways.append(as_wavefront)
        # each frame takes 10 ms less than the last (a warming GPU), whichever way ran
        monkeypatch.setattr("lift_gl.passes.trace.time", SimpleNamespace(perf_counter=lambda: -0.005 * next(clock) ** 2))
        r.render(spp=2 * TUNING_FRAMES + 1)
        # the wavefront's first frame, untimed, then the timed ones
        assert ways == [True] + [tuning_way(i) == "wavefront" for i in range(2 * TUNING_FRAMES)]
        ms = r.trace.tuned_ms
        assert ms is not None and abs(ms["megakernel"] - ms["wavefront"]) < 1e-9
    finally:
        r.release()


def test_tuning_waits_for_the_clock_and_times_close_ways_longer(monkeypatch):
    """The frames of the first TUNING_DELAY_S run the megakernel untimed (a GPU's clock is
    still rising); then blocks of 2 x TUNING_FRAMES timed frames, another block while the two
    medians are within TUNING_CLOSE, at most TUNING_ROUNDS blocks. Fake clock and frame times."""
    import lift_gl.gl.context as context
    import lift_gl.passes.trace as trace_mod

    monkeypatch.setattr(context, "is_software", lambda ctx: False)
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "faster")
    monkeypatch.setattr(trace_mod, "TUNING_DELAY_S", 0.05)
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=SIZE, integrator="pt", seed=7)
    try:
        clock = {"now": 0.0}
        frame_s = {"megakernel": 0.010, "wavefront": 0.0102}   # 2% apart: close

        def fake_run(uniforms, visibility, as_wavefront):
            ways.append(as_wavefront)
            clock["now"] += frame_s["wavefront" if as_wavefront else "megakernel"]

        monkeypatch.setattr(trace_mod, "time", SimpleNamespace(perf_counter=lambda: clock["now"]))
        ways = []
        r.trace._run = fake_run
        r.render(spp=5)   # 50 ms of frames, the wavefront's first among them: the delay, untimed
        assert ways == [True] + [False] * 4 and all(len(t) == 0 for t in r.trace.tuning.values())
        n = 2 * trace_mod.TUNING_FRAMES
        r.render(spp=n)
        assert r.trace.tuning is not None                  # close: a second block
        r.render(spp=n * (trace_mod.TUNING_ROUNDS - 1))
        assert r.trace.tuning is None and r.trace.wavefront is None   # the last block decided
        # far apart: one block decides
        r2 = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=SIZE, integrator="pt", seed=7)
        try:
            frame_s["wavefront"] = 0.007
            r2.trace._run = fake_run
            monkeypatch.setattr(trace_mod, "TUNING_DELAY_S", 0.0)
            r2.render(spp=n + 1)   # the wavefront's untimed first frame, then one block
            assert r2.trace.tuning is None and r2.trace.wavefront is not None
        finally:
            r2.release()
    finally:
        r.release()


class _StubWavefront:
    def release(self):
        pass


def test_tuning_times_no_frame_while_the_gpu_clock_is_low(monkeypatch):
    """Where NVML reads the SM clock, frames at under TUNING_CLOCK of its maximum run the
    megakernel untimed, until TUNING_CLOCK_WAIT_S have passed. Fake clock, NVML and frame times."""
    import lift_gl.gl.context as context
    import lift_gl.passes.trace as trace_mod

    monkeypatch.setattr(context, "is_software", lambda ctx: False)
    monkeypatch.setenv(WAVEFRONT_ENV_VAR, "faster")
    monkeypatch.setattr(trace_mod, "TUNING_DELAY_S", 0.0)
    monkeypatch.setattr(trace_mod, "TUNING_CLOSE", 0.0)
    clock = {"now": 0.0, "mhz": 345}

    class FakeNvml:
        def sm_mhz(self):
            return clock["mhz"]

        def max_sm_mhz(self):
            return 1980

    def fake_run(uniforms, visibility, as_wavefront):
        ways.append(as_wavefront)
        clock["now"] += 0.010 if as_wavefront else 0.020

    monkeypatch.setattr(trace_mod, "time", SimpleNamespace(perf_counter=lambda: clock["now"]))
    n = 2 * trace_mod.TUNING_FRAMES
    for clock_rises in (True, False):
        r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=SIZE, integrator="pt", seed=7)
        try:
            clock.update(now=0.0, mhz=345)
            ways = []
            r.trace._run = fake_run
            r.trace._tuning_clock = FakeNvml()
            r.render(spp=5)   # idle clock: untimed frames (the wavefront's first, then the megakernel)
            assert ways == [True] + [False] * 4 and all(len(t) == 0 for t in r.trace.tuning.values())
            if clock_rises:
                clock["mhz"] = 1900
            else:   # never rises: timed once TUNING_CLOCK_WAIT_S have passed
                clock["now"] += trace_mod.TUNING_CLOCK_WAIT_S
            r.render(spp=n)
            assert r.trace.tuning is None and r.trace.wavefront is not None   # the faster way kept
            assert ways[5:] == [trace_mod.tuning_way(i) == "wavefront" for i in range(n)]
        finally:
            r.release()
