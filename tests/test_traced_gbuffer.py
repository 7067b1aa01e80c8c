"""The ray-cast G-buffer (TracedGBufferPass, what GPUs with few raster units run) against the
raster one: the same primitive, material, normal, depth and albedo in (almost) every pixel,
and the same pt image where the primary hits agree."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import LiftError
from lift_gl.frame import guides
from lift_gl.options import Device, Options, Workload, parse_options, resolve
from lift_gl.passes.gbuffer import GBufferPass, TracedGBufferPass
from lift_gl.renderer import Renderer
from lift_gl.passes.camera import frame_jitter
from lift_gl.passes.pixel_filter import filtered_jitter
from lift_gl.scene.loader import load_scene

SIZE = (64, 48)


def _visibility(gbuffer) -> np.ndarray:
    w, h = gbuffer.visibility.size
    return np.frombuffer(gbuffer.visibility.read(), np.uint32).reshape(h, w, 4).copy()


def _render(mode, scene, **kw):
    r = Renderer(scene, size=SIZE, integrator="pt", seed=2, options=Options(gbuffer=mode), **kw)
    try:
        image = r.render(spp=2)
        w, h = SIZE
        frame_vis = _visibility(r.gbuffer)  # the last frame's (jittered)
        g = guides(r)  # every output, through the pixel centres (a frame writes only the visibility)
        out = {"image": image, "kind": type(g), "frame_vis": frame_vis, "vis": _visibility(g),
               "nd": np.frombuffer(g.normal_depth.read(), np.float32).reshape(h, w, 4).copy(),
               "albedo": np.frombuffer(g.albedo.read(), np.float16).reshape(h, w, 4).astype(np.float32),
               "explain": r.explain()}
        return out
    finally:
        r.release()


@pytest.mark.parametrize("scene_name", ["cornell.toml", "showcase.toml", "instances.toml"])  # triangles; spheres and textures; instances
def test_traced_gbuffer_matches_the_raster(scene_name):
    scene = load_scene(REPO / "scenes" / scene_name)
    raster = _render("raster", scene)
    traced = _render("traced", scene)
    assert raster["kind"] is GBufferPass and traced["kind"] is TracedGBufferPass
    assert "ray cast" in traced["explain"] and "ray cast" not in raster["explain"]
    prim_r, prim_t = raster["vis"][..., 0], traced["vis"][..., 0]
    same = prim_r == prim_t
    # Raster and ray may disagree only on primitive edges (a sample exactly on one).
    assert same.mean() > 0.99, same.mean()
    assert (prim_r > 0).mean() > 0.5  # the scene fills the picture
    hit = same & (prim_r > 0)
    np.testing.assert_array_equal(traced["vis"][..., 3][same], raster["vis"][..., 3][same])  # material
    np.testing.assert_allclose(traced["nd"][..., :3][hit], raster["nd"][..., :3][hit], atol=2e-3)
    np.testing.assert_allclose(traced["nd"][..., 3][hit], raster["nd"][..., 3][hit], rtol=1e-4)
    np.testing.assert_allclose(traced["albedo"][hit], raster["albedo"][hit], atol=2e-3)
    np.testing.assert_array_equal(traced["nd"][~(prim_t > 0)], 0.0)  # background as the raster clears it
    # pt rebuilds the primary hit along the same ray either way: the same paths.
    same_frame = raster["frame_vis"][..., 0] == traced["frame_vis"][..., 0]
    assert same_frame.mean() > 0.99, same_frame.mean()
    np.testing.assert_array_equal(traced["image"][same_frame], raster["image"][same_frame])


def test_frames_write_only_the_visibility():
    """A frame runs the program that writes only the visibility (all the trace pass reads), and
    it is the full program's, bit for bit; the guides (AOVs, denoiser) run the full one; a
    [reduced] plugin, whose passes read the albedo and normals, gets the full one every frame."""
    traced = Options(gbuffer="traced")
    scene = load_scene(REPO / "scenes" / "showcase.toml")  # triangles, spheres, textures
    r = Renderer(scene, size=SIZE, integrator="pt", seed=2, options=traced)
    try:
        r.render(spp=1)
        g = r.gbuffer
        assert set(g._programs) == {True}  # nothing asked for more
        frame_vis = _visibility(g)
        assert (frame_vis[..., 0] > 0).mean() > 0.5
        jitter = filtered_jitter(frame_jitter(0, r.seed), r.scene.pixel_filter, r.scene.film_size, r.size)
        r.buffers.bind()
        g.run(r.camera, r.packed.bounds, jitter, r.scene_uniforms, r.camera_uniforms)  # the full program
        np.testing.assert_array_equal(_visibility(g), frame_vis)
        albedo = r.aov("albedo")
        assert set(g._programs) == {True, False} and albedo.max() > 0.1
    finally:
        r.release()
    r = Renderer(scene, size=SIZE, integrator="hybrid", seed=2, options=traced)
    try:
        r.render(spp=1)
        assert set(r.gbuffer._programs) == {False}
    finally:
        r.release()


def test_motion_vectors_keep_the_raster():
    scene = load_scene(REPO / "scenes" / "cornell.toml")
    r = Renderer(scene, size=(16, 16), integrator="pt", temporal="reproject", options=Options(gbuffer="traced"))
    try:
        assert type(r.gbuffer) is GBufferPass
        assert "gbuffer             traced -> raster because temporal reprojection" in r.explain()
    finally:
        r.release()


def test_which_devices_ray_cast_it_and_a_bad_setting():
    """auto: ray cast on GPUs with few raster units (by the renderer's name), rasterized elsewhere."""
    for renderer, software, expect in (("NVIDIA H100 80GB HBM3/PCIe/SSE2", False, "traced"),
                                       ("NVIDIA GeForce RTX 4090/PCIe/SSE2", False, "raster"),
                                       ("llvmpipe (LLVM 15.0.6, 256 bits)", True, "raster")):
        assert resolve(Options(), Device(software, renderer))["gbuffer"] == expect, renderer
    assert resolve(Options(gbuffer="raster"), Device(False, "NVIDIA H200"))["gbuffer"] == "raster"
    assert resolve(Options(gbuffer="traced"), Device(False, "NVIDIA H200"), Workload(motion_vectors=True))["gbuffer"] \
        == "raster"
    with pytest.raises(LiftError, match="option gbuffer: 'both' is not allowed; use raster, traced, auto"):
        parse_options(["gbuffer=both"])
