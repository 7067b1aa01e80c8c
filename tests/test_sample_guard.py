"""The NaN/Inf guard on a plugin's samples (shaders/lift/sample_guard.glsl, and its OpenCL twin
shaders/opencl/lift/sample_guard.h), in every trace host that calls a plugin: the plain sample
loop, the path-steps loop, the pixel queue, carried paths, the reduced pass and the OpenCL kernel.
A sample with a NaN or an infinity in any channel is dropped and counted, exactly once; every
finite one (negative, -0.0, a denormal, a large one) is kept and averaged in."""
from __future__ import annotations

import textwrap

import numpy as np
import pytest

from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.testing import cornell_scene, require_opencl

SIZE = (8, 8)
SPP = 2
# (sample, kept): what the probe plugins return for each value of their parameter `kind`,
# built from the uniforms one = 1.0 and zero = 0.0 so that no compiler folds them
KINDS = [("NaN", False), ("+Inf", False), ("-Inf", False), ("Inf in one channel", False),
         ("-0.0", True), ("-2.0", True), ("1e-40 (denormal)", True), ("1e37", True)]
KEPT_VALUE = {"-0.0": 0.0, "-2.0": -2.0, "1e-40 (denormal)": 1e-40, "1e37": 1e37}
PARAMS = """
[params.kind]
type = "int"
default = 0
min = 0
max = 7
[params.one]
type = "float"
default = 1.0
[params.zero]
type = "float"
default = 0.0
"""
GLSL_SAMPLE = """
vec3 probe_sample() {
    if (kind == 0) return vec3(zero / zero);
    if (kind == 1) return vec3(one / zero);
    if (kind == 2) return vec3(-one / zero);
    if (kind == 3) return vec3(one, one / zero, one);
    if (kind == 4) return vec3(-zero);
    if (kind == 5) return vec3(-2.0 * one);
    if (kind == 6) return vec3(1e-40 * one);
    return vec3(1e37 * one);
}
"""
PLAIN = GLSL_SAMPLE + """
vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return probe_sample(); }
"""
# Paths of one vertex: path_step says "under way" once, so carried paths park every one of them.
PATH_STEPS = GLSL_SAMPLE + """
#define LIFT_PATH_STEPS
struct PathState { uint vertices; };
PathState path_start(Ray ray, Hit hit) { return PathState(0u); }
bool path_step(inout PathState path, inout Rng rng) { return ++path.vertices < 2u; }
vec3 path_radiance(PathState path) { return probe_sample(); }
vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return probe_sample(); }
"""
# The full-resolution estimate always 1; the reduced one (every pixel: scale 1) the probe's.
REDUCED = GLSL_SAMPLE + """
vec3 radiance(Ray ray, Hit hit, inout Rng rng) { return vec3(one); }
vec3 reduced_probe(Ray ray, Hit hit, inout Rng rng) { return probe_sample(); }
"""
OPENCL = """
float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* p) {
    float one = p->one, zero = p->zero;
    switch (p->kind) {
        case 0: return (float3)(zero / zero);
        case 1: return (float3)(one / zero);
        case 2: return (float3)(-one / zero);
        case 3: return (float3)(one, one / zero, one);
        case 4: return (float3)(-zero);
        case 5: return (float3)(-2.0f * one);
        case 6: return (float3)(1e-40f * one);
        default: return (float3)(1e37f * one);
    }
}
"""


def make_plugin(root, name, source, language="glsl", extra=""):
    folder = root / name
    folder.mkdir(parents=True)
    entry = f"{name}.{'cl' if language == 'opencl' else 'glsl'}"
    (folder / "plugin.toml").write_text(f'name = "{name}"\nlanguage = "{language}"\nentry = "{entry}"\n'
                                        f'primary = "gbuffer"\n{extra}{PARAMS}')
    (folder / entry).write_text(textwrap.dedent(source))
    return folder


def check_every_kind(r: Renderer, samples_per_kind: int, counted=None) -> None:
    """Each kind: bad samples all dropped and counted, good ones all kept; `counted` reads the
    count of samples the guard saw and kept (default: the frame's per-pixel count)."""
    for kind, (label, kept) in enumerate(KINDS):
        r.set_params(kind=kind)
        image = r.render(spp=SPP)
        assert r.stats.dropped_samples == (0 if kept else samples_per_kind), label
        if counted is not None:
            assert counted(r) == (samples_per_kind if kept else 0), label
        else:
            assert (r.accumulate.read_totals()[..., 3] == (SPP if kept else 0)).all(), label
        assert np.isfinite(image).all(), label
        if kept:
            np.testing.assert_allclose(image, KEPT_VALUE[label], rtol=1e-6, atol=1e-38, err_msg=label)


@pytest.mark.parametrize("source, options", [
    (PLAIN, {}),                                                   # main()'s loop
    (PATH_STEPS, {"pixel_queue": "off"}),                          # the path-steps loop
    (PATH_STEPS, {"pixel_queue": "on"}),                           # the pixel queue
    (PATH_STEPS, {"pixel_queue": "on", "carry_paths": "always"}),  # every path parked, then resumed
], ids=["plain", "path-steps", "pixel-queue", "carried-paths"])
def test_the_megakernel_drops_and_counts_exactly_the_bad_samples(tmp_path, source, options):
    folder = make_plugin(tmp_path, "guard_probe", source)
    r = Renderer(cornell_scene(), size=SIZE, integrator=str(folder), seed=2, options=Options(**options))
    try:
        if "carry_paths" in options:
            assert r.trace.carry is not None
        else:
            assert (r.trace.pixel_queue is not None) == (options.get("pixel_queue") == "on")
        check_every_kind(r, SIZE[0] * SIZE[1] * SPP)
    finally:
        r.release()


def test_the_reduced_pass_drops_and_counts_exactly_the_bad_samples(tmp_path):
    folder = make_plugin(tmp_path, "guard_reduced", REDUCED,
                         extra='[reduced]\nfunction = "reduced_probe"\nscale = 1\n')
    r = Renderer(cornell_scene(), size=SIZE, integrator=str(folder), seed=2)
    try:
        assert r.reduced is not None
        r.render(spp=1)
        # the reduced pass skips a block whose first hit is black (nothing to demodulate): the
        # G-buffer's albedo, which it reads, says which
        albedo = np.frombuffer(r.gbuffer.albedo.read(), np.float16).reshape(-1, 4)[:, :3]
        lit = int((albedo.max(axis=-1) > 1e-6).sum())
        assert lit > SIZE[0] * SIZE[1] // 2

        for kind, (label, kept) in enumerate(KINDS):
            r.set_params(kind=kind)
            image = r.render(spp=SPP)   # SPP frames of one sample
            assert r.stats.dropped_samples == (0 if kept else lit * SPP), label
            last_frame = np.frombuffer(r.reduced.reduced.read(), np.float32).reshape(-1, 4)
            assert last_frame[:, 3].sum() == (lit if kept else 0), label   # the samples it kept
            if not kept:   # (a kept 1e37 may overflow in the upsampling's filter: not the guard's business)
                assert np.isfinite(image).all() and not last_frame.any(), label
    finally:
        r.release()


def test_the_opencl_kernel_drops_and_counts_exactly_the_bad_samples(tmp_path):
    require_opencl()
    folder = make_plugin(tmp_path, "guard_cl", OPENCL, language="opencl")
    r = Renderer(cornell_scene(), size=SIZE, integrator=str(folder), seed=2)
    try:
        check_every_kind(r, SIZE[0] * SIZE[1] * SPP)
    finally:
        r.release()


def test_every_trace_host_includes_the_one_guard():
    """The guard is written once a language: the hosts include it, none repeats the test."""
    from conftest import REPO

    lift = REPO / "shaders" / "lift"
    for host in ("host_main.comp", "host_reduced.comp"):
        text = (lift / host).read_text()
        assert '#include "lift/sample_guard.glsl"' in text and "lift_is_finite" not in text, host
    for host in ("host_pixel_queue.glsl", "host_carry.glsl"):
        assert "lift_is_finite" not in (lift / host).read_text(), host
    kernel = (REPO / "shaders" / "opencl" / "lift" / "host_kernel.cl").read_text()
    assert '#include "lift/sample_guard.h"' in kernel and "lift_is_finite" not in kernel
