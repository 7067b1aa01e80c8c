"""What a renderer's shaders are compiled with: the options resolved for this device, scene and
plugin (lift_gl/options.py), the BVH layout they ask of pack_scene, and the defines.

Three sets of defines, each built on the one before:
- the scene's (scene_defines): its features (SceneFeatures: code for absent features is not
  compiled), the arrays in uniform blocks, a big scene's split, the tree's layout and stack;
- a plugin's (plugin_defines): the stack for this plugin's resolved options, coherent
  sampling, and the parameters its manifest compiles in (`define`);
- a pass's own, which each pass adds (passes/*.py).
"""
from __future__ import annotations

from .accel.wide import STACK_DEFINES, stack_defines as wide_stack_defines
from .options import ResolvedOptions, TreeShape, Workload, resolve
from .passes.common import coherent_defines
from .passes.trace import plugin_path_steps
from .plugins import Plugin, param_defines
from .scene.light_choice import one_flat_emitter


def resolve_choices(options, device, plugin: Plugin, features, scene, packed=None) -> ResolvedOptions:
    """The options' choices for this device, plugin and scene; before the scene is packed
    (packed None) those that depend on its tree are provisional."""
    work = Workload(language=plugin.language, path_steps=plugin_path_steps(plugin, features.defines()),
                    splats=plugin.splats, motion=features.motion, instances=features.instances,
                    triangles=scene.triangle_count,
                    tree=TreeShape.of(packed) if packed is not None else None,
                    one_flat_emitter=one_flat_emitter(scene))
    return resolve(options, device, work)


def bvh_layout(choices: ResolvedOptions) -> dict:
    """pack_scene's BVH and light-tree settings, as the options chose them."""
    return {"bvh_width": choices["bvh_width"], "bvh_slot_order": choices["bvh_slot_order"],
            "bvh_builder": choices["bvh_builder"], "light_selection": choices["light_selection"]}


def stack_defines(packed, choices: ResolvedOptions) -> dict:
    """The 4-wide traversal's stack for this tree and these choices (the option
    bvh_stack_entries; accel/wide.stack_defines)."""
    return wide_stack_defines(packed.bvh_stack, packed.bvh_levels, choices["bvh_stack_entries"])


def scene_defines(features, buffers, packed, choices: ResolvedOptions, count_rays: bool) -> dict:
    """Every program's defines for this scene: features, arrays in uniform blocks (CPU
    rasterizers), a big scene's split (scene/split.py), the tree's layout (accel/wide.py)."""
    defines = dict(features.defines(), **buffers.defines(), **buffers.plan.defines())
    if packed.bvh_width != 2:
        defines["LIFT_BVH_WIDTH"] = packed.bvh_width
        if packed.bvh_quantized:
            defines["LIFT_BVH_QUANTIZED"] = True
        defines.update(stack_defines(packed, choices))
        if choices["trace_paired"] == "on":
            defines["LIFT_TRACE_PAIRED"] = True
    if packed.light_tree:
        defines["LIFT_LIGHT_TREE"] = True
    if count_rays:  # compiled in only when asked: one more atomic per pixel and frame
        defines["LIFT_COUNT_RAYS"] = True
    return defines


def plugin_defines(defines: dict, packed, plugin: Plugin, params: dict, choices: ResolvedOptions) -> dict:
    """A plugin's programs' defines: the scene's `defines`, with the stack for this plugin's
    choices (a reloaded plugin's may differ), coherent sampling and its compile-time parameters."""
    defines = dict(defines)
    if packed.bvh_width != 2:
        for key in STACK_DEFINES:
            defines.pop(key, None)
        defines.update(stack_defines(packed, choices))
    if plugin.language == "glsl":
        defines.update(coherent_defines(choices["coherent_sampling"], choices["coherent_interleave"] or 1))
    return dict(defines, **param_defines(plugin, params))
