"""Showing an edited scene in a renderer that has one (Renderer.update_scene: the viewer's live
edits, lift_gl/scene/edit.py): only what changed is rebuilt, uploaded or recompiled.

- colours, roughness (geometry=False): the materials buffer is rewritten;
- emission: the emitter table is rebuilt with the scene;
- objects that only moved (instances): a new TLAS over the same BVHs below it;
- other geometry: the scene is packed again, its BVH rebuilt in one SAH build;
- new scene features (a first rough material, a first emitter...), or arrays that moved into or
  out of uniform blocks: the programs are recompiled, the passes made anew.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .accel.cache import bins_for_one_build
from .compile_settings import bvh_layout
from .passes.camera import camera_uniforms
from .passes.gbuffer import GBufferPass
from .scene.features import SceneFeatures
from .scene.instances import flatten_instances, only_instances_moved
from .scene.model import Scene
from .scene.pack import pack_materials, pack_scene, repack_instances


def environment_radiance(scene: Scene):
    return scene.environment.radiance if scene.environment is not None else (0.0, 0.0, 0.0)


def update_scene(r, scene: Scene, geometry: bool = True) -> bool:
    """Take `scene` into renderer `r`, keeping r's camera. Returns whether the accumulation may
    keep its history (temporal reprojection): only when objects moved and nothing else changed."""
    materials = pack_materials(scene)
    old = r.packed.materials
    same_look = (materials.shape == old.shape and np.array_equal(materials, old)
                 and _environment(scene) == _environment(r.scene)
                 and len(scene.distant_lights) == len(r.scene.distant_lights) == 0
                 and len(scene.textures) == len(r.scene.textures) == 0)
    emission_changed = materials.shape != old.shape or not np.array_equal(materials[:, 1, :3], old[:, 1, :3])
    if r.plugin.language == "opencl" and scene.instances:
        scene = flatten_instances(scene)  # as the renderer's constructor does
    if geometry and not emission_changed and only_instances_moved(r.scene, scene):
        packed = repack_instances(r.packed, scene)  # a new TLAS; every BVH below it stays
    elif geometry or emission_changed:
        # a live edit waits for this build: one SAH build, without the second one with
        # finer bins at the top (which can double it for 1.5% of trace time)
        features = r.fixed_features or SceneFeatures.of(scene)
        packed = pack_scene(scene, bvh_bins=bins_for_one_build(), **bvh_layout(r.resolve_choices(r.plugin, features, scene=scene)))
    else:
        packed = dataclasses.replace(r.packed, materials=materials)
    r.scene = dataclasses.replace(scene, camera=r.scene.camera)
    r.packed = packed
    r.camera_uniforms = camera_uniforms(r.camera, r.size)  # the origin may have moved
    fixed = r.fixed_features
    r.buffers.instances = fixed.instances if fixed else packed.instances is not None  # HAS_INSTANCES
    r.uploaded = r.buffers.upload(packed)  # names of the buffers rewritten
    if isinstance(r.gbuffer, GBufferPass):  # a rebuilt BVH may store other triangle copies
        r.gbuffer.set_triangles(packed.num_world_triangles, packed.raster_rows)
        r.gbuffer.instance_draws = list(packed.instance_draws)
    r.scene_uniforms = r.buffers.uniforms(environment_radiance(scene))
    features = r.fixed_features or SceneFeatures.of(scene)
    if features != r.features:
        same_look = False
    r.features = features
    r.choices = r.resolve_choices(r.plugin, features, packed)   # the new tree may want another stack
    defines = r._shader_defines()  # features, and arrays that moved into or out of uniform blocks
    if defines != r.defines:
        same_look = False  # new passes: their history starts empty
        r.defines = defines
        r.remake_passes()
    r.motion_history.scene_changed()
    return same_look


def _environment(scene: Scene):
    return None if scene.environment is None else tuple(np.ravel(scene.environment.radiance))
