"""The ray-cast G-buffer (TracedGBufferPass, what GPUs with few raster units run) against the
raster one: the same primitive, material, normal, depth and albedo in (almost) every pixel,
and the same pt image where the primary hits agree."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import REPO
from lift_gl.errors import LiftError
from lift_gl.frame import guides
from lift_gl.options import Device, Options, parse_options, resolve
from lift_gl.passes.gbuffer import GBufferPass, TracedGBufferPass
from lift_gl.renderer import Renderer
from lift_gl.passes.camera import frame_jitter
from lift_gl.passes.pixel_filter import filtered_jitter
from lift_gl.scene import Camera, Environment, Material, Scene
from lift_gl.scene.loader import load_scene
from lift_gl.scene.primitives import quad, sphere

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


def _moved(scene):
    """The camera and the scene one step on: the camera shifted right and turned a little,
    the spheres that are not lights moved, and every instance, or else the first mesh's
    corners (a light moved, or meshes and instances at once, restart the accumulation:
    Renderer.update_scene)."""
    step = np.array([0.15, 0.05, 0.0])
    camera = dataclasses.replace(scene.camera, position=scene.camera.position + step,
                                 target=scene.camera.target + 0.5 * step)
    spheres = [s if scene.materials[s.material].is_emissive else
               dataclasses.replace(s, center=s.center + [0.1, 0.0, 0.05]) for s in scene.spheres]
    instances = []
    for k in scene.instances:
        transform = k.transform.copy()
        transform[:3, 3] += [0.0, 0.08, 0.05]
        instances.append(dataclasses.replace(k, transform=transform))
    meshes = list(scene.meshes)
    if meshes and not instances and not scene.materials[meshes[0].material].is_emissive:
        meshes[0] = dataclasses.replace(meshes[0], positions=meshes[0].positions + [0.05, 0.0, 0.0])
    return camera, dataclasses.replace(scene, spheres=spheres, instances=instances, meshes=meshes)


def _motion(mode, scene):
    r = Renderer(scene, size=SIZE, integrator="pt", seed=2, temporal="reproject", options=Options(gbuffer=mode))
    try:
        r.render(spp=1)
        camera, moved = _moved(scene)
        r.update_scene(moved)
        r.set_camera(camera)
        image = r.render(spp=1)
        w, h = SIZE
        return {"kind": type(r.gbuffer), "image": image, "vis": _visibility(r.gbuffer), "reprojected": r.stats.reprojected,
                "motion": np.frombuffer(r.gbuffer.motion.read(), np.float32).reshape(h, w, 4).copy(),
                "history": r.aov("history")[..., 0]}
    finally:
        r.release()


def _spheres_scene():
    """Two diffuse spheres on a diffuse floor before an emissive wall, without textures (a
    textured scene's edit restarts the accumulation: showcase.toml has them)."""
    materials = [Material(name="wall", base_color=np.zeros(3), emission=np.array([1.0, 0.9, 0.8])),
                 Material(name="grey", base_color=np.array([0.6, 0.6, 0.6]))]
    wall = quad([-4, -1, -2], [8, 0, 0], [0, 6, 0], material=0, name="wall")
    floor = quad([-4, -1, 4], [8, 0, 0], [0, 0, -6], material=1, name="floor")
    balls = [sphere([-0.7, 0.0, 0.5], 0.6, material=1), sphere([0.9, -0.4, 1.2], 0.4, material=1)]
    camera = Camera(position=np.array([0.0, 0.5, 6.0]), target=np.array([0.0, 0.0, 0.0]), fov_deg=45.0)
    return Scene(camera=camera, materials=materials, meshes=[floor, wall], spheres=balls, film_size=SIZE)


@pytest.mark.parametrize("scene_name", ["cornell.toml", "spheres", "instances.toml"])
def test_traced_motion_vectors_match_the_raster(scene_name):
    """Temporal reprojection on the ray-cast G-buffer: where both G-buffers saw the same
    primitive, the same motion (camera, mesh corners, spheres and instances moved), the same
    depth in the previous camera, a depth gradient of the raster's size (its fwidth takes
    differences over 2x2 pixel quads; the ray-cast one the neighbours' rays on the tangent
    plane), and the reprojected image alike."""
    scene = _spheres_scene() if scene_name == "spheres" else load_scene(REPO / "scenes" / scene_name)
    if scene.distant_lights:  # instances.toml's sun: a scene with one restarts on an edit
        scene = dataclasses.replace(scene, distant_lights=[], environment=Environment(np.ones(3)))
    raster, traced = _motion("raster", scene), _motion("traced", scene)
    assert raster["kind"] is GBufferPass and traced["kind"] is TracedGBufferPass
    assert raster["reprojected"] == traced["reprojected"] == 1
    same = (raster["vis"][..., 0] == traced["vis"][..., 0])
    hit = same & (raster["vis"][..., 0] > 0)
    assert same.mean() > 0.99 and hit.mean() > 0.5
    mr, mt = raster["motion"], traced["motion"]
    assert np.abs(mr[..., :2][hit]).max() > 0.5  # it moved by pixels
    np.testing.assert_allclose(mt[..., :2][hit], mr[..., :2][hit], atol=2e-3)
    np.testing.assert_allclose(mt[..., 2][hit], mr[..., 2][hit], rtol=1e-4)
    ratio = np.median(mt[..., 3][hit] / np.maximum(mr[..., 3][hit], 1e-12))
    assert 0.7 < ratio < 1.4, ratio
    np.testing.assert_array_equal(mt[~(traced["vis"][..., 0] > 0)], 0.0)  # background: no history
    # The history each pixel kept through the move, and the image, nearly the same.
    kept = hit[::-1]
    assert np.mean(traced["history"][kept] == raster["history"][kept]) > 0.97
    assert np.abs(traced["image"] - raster["image"]).mean() < 0.02 * raster["image"].mean()


def test_which_devices_ray_cast_it_and_a_bad_setting():
    """auto: ray cast on GPUs with few raster units (by the renderer's name), rasterized elsewhere."""
    for renderer, software, expect in (("NVIDIA H100 80GB HBM3/PCIe/SSE2", False, "traced"),
                                       ("NVIDIA GeForce RTX 4090/PCIe/SSE2", False, "raster"),
                                       ("llvmpipe (LLVM 15.0.6, 256 bits)", True, "raster")):
        assert resolve(Options(), Device(software, renderer))["gbuffer"] == expect, renderer
    assert resolve(Options(gbuffer="raster"), Device(False, "NVIDIA H200"))["gbuffer"] == "raster"
    with pytest.raises(LiftError, match="option gbuffer: 'both' is not allowed; use raster, traced, auto"):
        parse_options(["gbuffer=both"])
