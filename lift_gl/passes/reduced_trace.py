"""Reduced trace pass: a plugin's second estimate (its `[reduced]` function) for one pixel in
every scale x scale block (a hybrid plugin's indirect light).

inputs:  scene buffers, camera, G-buffer visibility (the full-resolution first hits) and albedo
outputs: reduced (RGBA32F, ceil(W / scale) x ceil(H / scale): the estimate divided by the
         first hit's albedo, summed over this frame's samples, in rgb; their count in a;
         0 samples where the first hit is black or missing: no information to spread)

Block b is represented by full-resolution pixel b * scale + offset, where the offset is the
same for the whole frame and walks over the block from frame to frame (`block_offset`), so
that over scale^2 frames every pixel is traced. The estimate is demodulated (divided by the
albedo of the surface it starts from) so that the upsampling pass can multiply each pixel's
own albedo back in: material and texture edges stay sharp. Both passes take that albedo from
the G-buffer (textures applied, as the denoiser's guide), so that demodulating and remodulating
one pixel cancel exactly. The upsampling pass (passes/upsample.py) reads the guides (normal,
depth) of the same representative pixels from the G-buffer.
"""
from __future__ import annotations

import moderngl

from .. import shaders
from ..plugins import GLSL_TYPES, Plugin
from .camera import halton
from .common import LOCAL_SIZE, groups, set_uniforms

MAIN_TEMPLATE = """
layout(local_size_x = {local}, local_size_y = {local}) in;
#include "lift/host.glsl"
layout(rgba32f, binding = 0) uniform writeonly image2D u_reduced_out;
uniform usampler2D u_visibility;
uniform sampler2D u_albedo;  // G-buffer: the first hit's albedo, textures applied
uniform uint u_frame;
uniform uint u_seed;
uniform uint u_samples;
uniform uint u_sample_base;
uniform uint u_stream;  // the error estimate's half this frame belongs to (lift/rng.glsl)
uniform vec2 u_jitter;
uniform int u_scale;          // full-resolution pixels per reduced pixel, along each axis
uniform ivec2 u_block_offset; // this frame's representative pixel inside every block

// ---- plugin parameters ----
{params}
// ---- plugin ----
#include "{entry}"
// ---- host ----
#include "lift/primary_hit.glsl"  // gbuffer_hit: the first hit at a full-resolution pixel

void main() {{
    ivec2 block = ivec2(gl_GlobalInvocationID.xy);
    ivec2 blocks = imageSize(u_reduced_out);
    if (any(greaterThanEqual(block, blocks))) return;
    ivec2 pixel = min(block * u_scale + u_block_offset, ivec2(u_resolution) - 1);
    vec3 sum = vec3(0.0);
    float valid = 0.0;
    Ray ray = camera_ray(vec2(pixel) + u_jitter);
    Hit first = gbuffer_hit(pixel, ray);
    vec3 albedo = first.prim != NO_HIT ? texelFetch(u_albedo, pixel, 0).rgb : vec3(0.0);
    if (max(albedo.r, max(albedo.g, albedo.b)) <= 1e-6) {{
        // Black (an emitter's face, the background): it tells its neighbours nothing about
        // their indirect light, so it must not count as zero in their filter.
        imageStore(u_reduced_out, block, vec4(0.0));
        return;
    }}
    for (uint s = 0u; s < u_samples; ++s) {{
        // Another seed than the full-resolution pass's: the two estimates stay independent.
        Rng rng = rng_init_pixel_sample(uvec2(pixel), u_frame, s, u_sample_base + s, u_seed ^ 0x5bd1e995u, u_stream);
        Hit hit = first;
        vec3 L = {function}(ray, hit, rng);
        if (!lift_is_finite(L)) {{
            atomicAdd(stats[0], 1u);  // dropped and counted, as the full-resolution pass does
            continue;
        }}
        // Demodulated; a channel the surface does not reflect carries no indirect light.
        sum += mix(vec3(0.0), L / max(albedo, vec3(1e-6)), greaterThan(albedo, vec3(1e-6)));
        valid += 1.0;
    }}
    imageStore(u_reduced_out, block, vec4(sum, valid));
}}
"""

OFFSET_BASES = (5, 7)  # Halton bases for the block offsets: unlike the subpixel jitter's (2, 3)


def block_offset(frame: int, scale: int) -> tuple[int, int]:
    """The representative pixel of every block in this frame: a low-discrepancy walk over
    the scale x scale block."""
    return (int(halton(frame + 1, OFFSET_BASES[0]) * scale), int(halton(frame + 1, OFFSET_BASES[1]) * scale))


def reduced_size(size, scale: int) -> tuple[int, int]:
    return (-(-size[0] // scale), -(-size[1] // scale))


def generate_main(plugin: Plugin) -> str:
    params = "\n".join(f"uniform {GLSL_TYPES[p.type]} {p.name};  // {p.help}" for p in plugin.params.values())
    return MAIN_TEMPLATE.format(local=LOCAL_SIZE, params=params, entry=plugin.entry_path.as_posix(),
                                function=plugin.reduced.function)


class ReducedTracePass:
    name = "reduced"
    inputs = ("scene", "camera", "visibility", "albedo")
    outputs = ("reduced",)

    def __init__(self, ctx: moderngl.Context, size, plugin: Plugin, defines: dict):
        self.ctx = ctx
        self.size = size
        self.plugin = plugin
        self.source = shaders.assemble(generate_main(plugin), dict(defines), include_dirs=[plugin.folder],
                                       main_name=f"<{plugin.name} reduced-resolution host main>")
        self.program = shaders.compile_compute(ctx, self.source)
        self.scale = None
        self.reduced = None

    def _allocate(self, scale: int) -> None:
        if scale == self.scale:
            return
        if self.reduced is not None:
            self.reduced.release()
        self.scale = scale
        self.reduced = self.ctx.texture(reduced_size(self.size, scale), 4, dtype="f4")

    def run(self, uniforms: dict, gbuffer, scale: int, offset: tuple[int, int]) -> None:
        self._allocate(int(scale))
        set_uniforms(self.program, dict(uniforms, u_scale=self.scale, u_block_offset=offset))
        for unit, (name, texture) in enumerate((("u_visibility", gbuffer.visibility), ("u_albedo", gbuffer.albedo))):
            texture.use(location=unit)
            self.program[name].value = unit
        self.reduced.bind_to_image(0, read=False, write=True)
        self.program.run(*groups(*self.reduced.size))
        self.ctx.memory_barrier()  # the upsampling reads it

    def release(self) -> None:
        self.program.release()
        if self.reduced is not None:
            self.reduced.release()
