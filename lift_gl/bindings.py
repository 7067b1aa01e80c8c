"""Every buffer binding point the renderer uses, in one table.

A storage buffer stays bound to its binding point from one dispatch to the next, so two buffers
that one frame binds must not share a number: a pass that bound its buffer over another's would
hand the next pass the wrong data, silently. Every buffer the passes bind is therefore named
here, with a number no other one has (tests/test_bindings.py checks it against the shaders).

The shaders read the same numbers: shaders.assemble writes `#define LIFT_BINDING_<NAME> <n>` for
each of them into every program, and a block is declared as

    layout(std430, binding = LIFT_BINDING_STATS) buffer Stats { uint stats[]; };

The scene's small arrays may be uniform blocks instead (a CPU rasterizer reads those faster:
passes/common.py SceneBuffers); uniform blocks have binding points of their own, and each such
array keeps its storage buffer's number there.

Image units and texture units are not in this table: a pass binds its images and samplers right
before its own dispatch, so they hold nothing from one pass to the next.
"""
from __future__ import annotations

# A big scene's arrays go into a heap of up to this many buffers (scene/split.py), bound from
# HEAP_FIRST_BINDING on. llvmpipe lets a compute shader use 16 storage blocks: the heap's 8
# leave the scene's other blocks (materials, lights, spheres, images, stats, motion, splats) one spare.
MAX_HEAP_CHUNKS = 8
HEAP_FIRST_BINDING = 24

# name -> binding point; who binds it and the block that reads it, in the comment.
STORAGE_BUFFERS = {
    # the scene (passes/common.py SceneBuffers; shaders/lift/scene_data.glsl)
    "bvh_nodes": 0,
    "tri_pos": 1,
    "tri_normal": 2,
    "tri_uv": 3,
    "tri_info": 4,
    "materials": 5,
    "lights": 6,
    "spheres": 7,
    "stats": 8,            # the statistics counters (dropped samples, rays, ...)
    "images": 9,           # textures and the environment map's tables
    "instances": 10,       # the TLAS and instance records, with HAS_INSTANCES
    "motion": 16,          # shutter-close positions and boxes, with HAS_MOTION
    # the passes' own buffers
    "net_exposure": 12,    # passes/net_denoise.py: the GLSL denoiser's input exposure
    "net_weights": 19,     # lift_gl/denoise/glsl_net.py: a convolution's weights (shaders/denoise/conv.comp)
    "net_bias": 20,        # ... and its bias
    "pixel_queue": 13,     # passes/trace.py: the megakernel's next pixel (LIFT_PIXEL_QUEUE)
    "carry": 15,           # passes/carry.py: paths parked for the next frame (LIFT_CARRY_PATHS)
    "splats": 17,          # passes/splat.py: light-tracing splats (shaders/lift/splat.glsl)
    # passes/prepass.py: a plugin's prepass storage (shaders/lift/prepass.glsl), split over up
    # to four buffers where one would pass GL_MAX_SHADER_STORAGE_BLOCK_SIZE
    "prepass0": 11,
    "prepass1": 14,
    "prepass2": 21,
    "prepass3": 22,
    "prev_positions": 18,  # temporal reprojection: last frame's positions (shaders/passes/motion_vectors.glsl)
    **{f"heap{k}": HEAP_FIRST_BINDING + k for k in range(MAX_HEAP_CHUNKS)},   # scene/split.py
}

# The scene arrays that may be uniform blocks (passes/common.py UNIFORM_ARRAYS): the same
# numbers, in the uniform-block binding points.
UNIFORM_BLOCKS = {name: STORAGE_BUFFERS[name] for name in
                  ("bvh_nodes", "tri_pos", "tri_normal", "tri_uv", "tri_info", "materials", "lights", "spheres",
                   "instances")}

# The scene's own buffers, as SceneBuffers binds them (the heap and motion apart).
SCENE_BINDINGS = {name: STORAGE_BUFFERS[name] for name in
                  ("bvh_nodes", "tri_pos", "tri_normal", "tri_uv", "tri_info", "materials", "lights", "spheres",
                   "images", "instances")}


def define_name(name: str) -> str:
    """The shaders' name for buffer `name`'s binding: LIFT_BINDING_<NAME>."""
    return "LIFT_BINDING_" + name.upper()


def binding_defines() -> dict[str, int]:
    """The defines shaders.assemble writes into every program."""
    return {define_name(name): number for name, number in STORAGE_BUFFERS.items()}
