"""G-buffer pass: rasterizes the scene with the frame's jittered projection.

inputs:  scene buffers, camera, jitter; instances are drawn with one instanced draw per
         run of records of one prototype (gbuffer.vert with LIFT_INSTANCE_DRAW)
outputs: visibility (RGBA32UI: primitive id + 1 (0 = background), barycentrics as float
         bits, material id), normal_depth (RGBA32F: camera-facing shading normal, view
         depth), albedo (RGBA16F), depth buffer
         with motion_vectors (temporal reprojection only): motion (RGBA32F: previous minus
         current pixel position, view depth in the previous camera, depth change per pixel;
         shaders/passes/motion_vectors.glsl), and the previous frame's normal_depth kept
         (two textures used in turn: swap_history()).

The depth test compares a depth the fragment shader writes (gl_FragDepth: linear in view depth
near the camera, logarithmic beyond, camera.DEPTH_STEPS), not the projection's hyperbolic
depth, which with the tiny near plane that a camera inside the scene needs cannot tell a wall
from the back of the same wall (tests/test_stress.py); nor view depth / far, whose steps of
far / 2^24 cannot tell a ball from the floor under it when the floor reaches 1e9 away.
"""
from __future__ import annotations

import moderngl
import numpy as np

from .. import shaders
from .camera import depth_uniforms, view_projection
from .common import groups, set_uniforms

SHADER_DIR = shaders.SHADER_DIR / "passes"


def _make_outputs(g, ctx, size, defines: dict, motion_vectors: bool) -> dict:
    """The G-buffer's textures on `g` (either pass): visibility, normal_depth, albedo, and with
    motion vectors motion and the previous normal_depth; returns the defines they need."""
    g.motion_vectors = motion_vectors
    g.visibility = ctx.texture(size, 4, dtype="u4")
    g.normal_depth = ctx.texture(size, 4, dtype="f4")
    g.albedo = ctx.texture(size, 4, dtype="f2")
    g.motion = g.prev_normal_depth = None
    textures = [g.visibility, g.normal_depth, g.albedo]
    if motion_vectors:
        defines = dict(defines, LIFT_MOTION_VECTORS=True)
        g.motion = ctx.texture(size, 4, dtype="f4")
        g.prev_normal_depth = ctx.texture(size, 4, dtype="f4")
        textures += [g.motion, g.prev_normal_depth]
    for t in textures:
        t.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return defines


class GBufferPass:
    name = "gbuffer"
    inputs = ("scene", "camera", "jitter")
    outputs = ("visibility", "normal_depth", "albedo", "motion?")   # motion: with motion_vectors

    def __init__(self, ctx: moderngl.Context, size, defines: dict, num_triangles: int, num_spheres: int,
                 motion_vectors: bool = False, instance_draws=(), raster_rows=None):
        """num_triangles: the world-space triangle rows (drawn as they are, or only
        `raster_rows`: set_triangles); instance_draws: (first triangle, triangles, first
        record, records) of each instanced draw, with HAS_INSTANCES (PackedScene.instance_draws)."""
        self.ctx = ctx
        self.size = size
        self.num_spheres = num_spheres
        self.instance_draws = list(instance_draws)
        defines = _make_outputs(self, ctx, size, defines, motion_vectors)
        self.depth = ctx.depth_renderbuffer(size)
        self.fbo = self._framebuffer()
        self._spare_fbo = None  # the framebuffer for the other normal_depth texture (motion vectors)
        self.program = self._program("gbuffer", defines)
        self.vao = self.index_buffer = None
        self.set_triangles(num_triangles, raster_rows)
        self.instance_vao = None
        if defines.get("HAS_INSTANCES"):
            self.instance_vao = ctx.vertex_array(self._program("gbuffer", dict(defines, LIFT_INSTANCE_DRAW=True)), [])
        self.sphere_vao = None
        if num_spheres:
            self.sphere_vao = ctx.vertex_array(self._program("gbuffer_sphere", defines), [])

    def set_triangles(self, num_triangles: int, raster_rows=None) -> None:
        """The triangle rows to draw: all `num_triangles`, or only `raster_rows` (PackedScene:
        a triangle the BVH stores several times is drawn once, from its first copy; gl_VertexID
        is then the index buffer's entry, the copy's own vertex row)."""
        for obj in (self.vao, self.index_buffer):
            if obj is not None:
                obj.release()
        self.index_buffer = None
        self.num_triangles = num_triangles
        self.num_vertices = 3 * num_triangles
        if raster_rows is not None and num_triangles:
            rows = np.asarray(raster_rows, np.uint32)
            vertices = (3 * rows[:, None] + np.arange(3, dtype=np.uint32)).ravel()
            self.index_buffer = self.ctx.buffer(vertices.tobytes())
            self.num_vertices = vertices.size
        self.vao = self.ctx.vertex_array(self.program, [], index_buffer=self.index_buffer, index_element_size=4)

    def _framebuffer(self) -> moderngl.Framebuffer:
        colour = [self.visibility, self.normal_depth, self.albedo] + ([self.motion] if self.motion_vectors else [])
        return self.ctx.framebuffer(colour, self.depth)

    def swap_history(self) -> None:
        """Before a frame (motion vectors only): this frame's normal_depth becomes the
        previous one, and the next run writes into the older texture."""
        self.normal_depth, self.prev_normal_depth = self.prev_normal_depth, self.normal_depth
        if self._spare_fbo is None:
            self._spare_fbo = self._framebuffer()
        self.fbo, self._spare_fbo = self._spare_fbo, self.fbo

    def _program(self, stem: str, defines: dict) -> moderngl.Program:
        vert = shaders.assemble(SHADER_DIR / f"{stem}.vert", defines)
        frag = shaders.assemble(SHADER_DIR / f"{stem}.frag", defines)
        return shaders.compile_program(self.ctx, vert, frag)

    def run(self, camera, bounds, jitter, scene_uniforms: dict, camera_uniforms: dict,
            motion_uniforms: dict | None = None, visibility_only: bool = False) -> None:
        """motion_uniforms (motion vectors only): lift_gl/temporal.py motion_uniforms().
        visibility_only: the caller reads only the visibility; the raster writes every output
        all the same (its cost is rasterizing, not the stores: docs/gpu.md)."""
        uniforms = dict(scene_uniforms, **camera_uniforms, **(motion_uniforms or {}))
        uniforms["u_view_proj"] = view_projection(camera, self.size, bounds, jitter).ravel()
        uniforms.update(depth_uniforms(camera, bounds))
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)  # motion too: background has no history
        self.ctx.enable(moderngl.DEPTH_TEST)
        # Blending left on by the viewer's GUI would mix normal_depth with the clear colour
        # (its alpha is the view depth): normals scaled by the depth, the depth squared.
        self.ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        if self.num_triangles:
            set_uniforms(self.vao.program, uniforms)
            self.vao.render(moderngl.TRIANGLES, vertices=self.num_vertices)
        if self.instance_vao is not None and self.instance_draws:
            program = self.instance_vao.program
            set_uniforms(program, uniforms)
            for first_tri, tris, first_record, records in self.instance_draws:
                program["u_instance_first"].value = first_record
                self.instance_vao.render(moderngl.TRIANGLES, vertices=3 * tris, first=3 * first_tri,
                                         instances=records)
        if self.sphere_vao is not None:
            set_uniforms(self.sphere_vao.program, uniforms)
            self.sphere_vao.render(moderngl.TRIANGLES, vertices=36, instances=self.num_spheres)
        self.ctx.disable(moderngl.DEPTH_TEST)

    def release(self) -> None:
        for obj in (self.visibility, self.normal_depth, self.albedo, self.depth, self.fbo, self.vao,
                    self.index_buffer, self.program, self.motion, self.prev_normal_depth, self._spare_fbo):
            if obj is not None:
                obj.release()
        for vao in (self.sphere_vao, self.instance_vao):
            if vao is not None:
                vao.release()


class TracedGBufferPass:
    """The G-buffer's visibility, normal_depth and albedo by one camera ray per pixel (a
    compute pass over lift/bvh.glsl) instead of the raster: the same outputs, for GPUs whose
    raster units are the bottleneck (the option gbuffer, lift_gl/options.py), motion vectors
    included (temporal reprojection): the hit point's previous position projected by the
    previous camera, and the depth gradient from the neighbouring pixels' rays on the hit's
    tangent plane. The primary hit is then the traced camera ray's, which the trace pass
    rebuilds exactly (lift/primary_hit.glsl).

    A frame whose other passes read only the visibility (run(visibility_only=True): the
    renderer's frames but a [reduced] plugin's) runs a second program that leaves normal_depth
    and albedo unwritten, and with them the surface's normal and the material's textures: 8-11%
    of the pass on an H100 (docs/gpu.md, Fourteenth session). The guides (the denoiser's, the
    AOVs: lift_gl/frame.py guides) and picking run the full one."""

    name = "gbuffer"
    inputs = ("scene", "camera", "jitter")
    outputs = ("visibility", "normal_depth", "albedo", "motion?")   # motion: with motion_vectors

    def __init__(self, ctx: moderngl.Context, size, defines: dict, stack: str | None = None,
                 motion_vectors: bool = False):
        """`stack`: where the traversal keeps its stack, shared or local (the resolved options'
        gbuffer_stack; None: this device's default)."""
        from ..options import Device, Options, resolve, work_group

        device = Device.of(ctx)
        stack = stack or resolve(Options(), device).gbuffer_stack
        self.ctx = ctx
        self.size = size
        defines = _make_outputs(self, ctx, size, defines, motion_vectors)
        self.local_size = work_group(stack, device)
        defines = dict(defines, LIFT_GBUFFER_LOCAL_X=self.local_size[0], LIFT_GBUFFER_LOCAL_Y=self.local_size[1])
        if stack == "shared":
            defines["LIFT_BVH_SHARED_STACK"] = self.local_size[0] * self.local_size[1]
        self._defines = defines
        self._programs = {}  # visibility_only -> program, each compiled on its first run
        self._fbo = None  # made on the first read through `fbo` (the viewer's picking)

    def program(self, visibility_only: bool = False) -> moderngl.ComputeShader:
        if visibility_only not in self._programs:
            defines = dict(self._defines, LIFT_GBUFFER_VISIBILITY_ONLY=True) if visibility_only else self._defines
            self._programs[visibility_only] = shaders.compile_compute(
                self.ctx, shaders.assemble(SHADER_DIR / "gbuffer_traced.comp", defines))
        return self._programs[visibility_only]

    @property
    def fbo(self) -> moderngl.Framebuffer:
        """Its images as a framebuffer, as the raster pass has one: for reading a few texels."""
        if self._fbo is None:
            self._fbo = self.ctx.framebuffer([self.visibility, self.normal_depth, self.albedo])
        return self._fbo

    def swap_history(self) -> None:
        """Before a frame (motion vectors only): this frame's normal_depth becomes the
        previous one, and the next run writes into the older texture."""
        self.normal_depth, self.prev_normal_depth = self.prev_normal_depth, self.normal_depth
        if self._fbo is not None:  # it holds the other normal_depth now
            self._fbo.release()
            self._fbo = None

    def run(self, camera, bounds, jitter, scene_uniforms: dict, camera_uniforms: dict,
            motion_uniforms: dict | None = None, visibility_only: bool = False) -> None:
        """visibility_only: the caller reads only the visibility (not with motion vectors: the
        reprojection reads normal_depth)."""
        program = self.program(visibility_only and not self.motion_vectors)
        set_uniforms(program, dict(scene_uniforms, **camera_uniforms, **(motion_uniforms or {}),
                                   u_jitter=tuple(float(v) for v in jitter)))
        self.visibility.bind_to_image(0, read=False, write=True)
        self.normal_depth.bind_to_image(1, read=False, write=True)
        self.albedo.bind_to_image(2, read=False, write=True)
        if self.motion_vectors:
            self.motion.bind_to_image(3, read=False, write=True)
        program.run(*groups(*self.size, self.local_size))
        self.ctx.memory_barrier()  # the trace pass fetches these images: no overlap on a GPU

    def release(self) -> None:
        for obj in (self.visibility, self.normal_depth, self.albedo, self.motion, self.prev_normal_depth, self._fbo,
                    *self._programs.values()):
            if obj is not None:
                obj.release()
