"""Upsample pass: joint bilateral upsampling (Kopf et al. 2007) of the reduced pass's estimate,
added into the frame.

inputs:  frame (RGBA32F: this frame's full-resolution radiance sum, sample count), reduced
         (passes/reduced_trace.py), G-buffer normal_depth and visibility (guides), albedo
outputs: frame (in place: + count * albedo * upsampled estimate)

For a full-resolution pixel p, each of the 3 x 3 reduced samples q around it is weighted by
    exp(-|p - x_q|^2 / (2 (0.75 scale)^2))    distance to q's representative pixel x_q
  * max(0, n_p . n_q)^normal_power           the G-buffer normals at p and x_q
  * exp(-|z_p - z_q| / (depth_sigma z_p))    the G-buffer view depths
and the weighted mean, multiplied by p's own albedo (the G-buffer's, textures applied; the
reduced pass divided by x_q's), is p's estimate. A pixel whose neighbours all fail the guides
(a thin object) falls back to the distance weights alone rather than staying black.
Background pixels get nothing.
This is where the bias is: q's estimate belongs to another point of the scene.
"""
from __future__ import annotations

import moderngl

from .. import shaders
from .common import groups, set_uniforms

SOURCE = """
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform image2D u_frame;
uniform sampler2D u_reduced;       // demodulated estimate sum (rgb), sample count (a)
uniform sampler2D u_normal_depth;  // G-buffer: normal (xyz), view depth (w; 0 = background)
uniform usampler2D u_visibility;   // G-buffer: primitive id + 1 (x)
uniform sampler2D u_albedo;        // G-buffer: albedo, textures applied
uniform int u_scale;
uniform ivec2 u_block_offset;
uniform float u_normal_power;
uniform float u_depth_sigma;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_frame);
    if (any(greaterThanEqual(p, size))) return;
    uvec4 vis = texelFetch(u_visibility, p, 0);
    if (vis.x == 0u) return;  // background: no surface, no indirect light
    vec4 nd = texelFetch(u_normal_depth, p, 0);
    ivec2 blocks = textureSize(u_reduced, 0);
    ivec2 home = p / u_scale;
    float sigma = 0.75 * float(u_scale);
    vec3 guided = vec3(0.0), spatial = vec3(0.0);
    float guided_w = 0.0, spatial_w = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = home + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, blocks))) continue;
            vec4 sample_q = texelFetch(u_reduced, q, 0);
            if (sample_q.a <= 0.0) continue;
            vec3 value = sample_q.rgb / sample_q.a;
            ivec2 x_q = min(q * u_scale + u_block_offset, size - 1);
            vec2 d = vec2(x_q - p);
            float w_dist = exp(-dot(d, d) / (2.0 * sigma * sigma));
            spatial += w_dist * value;
            spatial_w += w_dist;
            vec4 nd_q = texelFetch(u_normal_depth, x_q, 0);
            if (texelFetch(u_visibility, x_q, 0).x == 0u) continue;  // q saw the background
            float w_normal = pow(max(dot(nd.xyz, nd_q.xyz), 0.0), u_normal_power);
            float w_depth = exp(-abs(nd.w - nd_q.w) / (u_depth_sigma * max(abs(nd.w), 1e-6)));
            float w = w_dist * w_normal * w_depth;
            guided += w * value;
            guided_w += w;
        }
    }
    vec3 estimate = guided_w > 1e-4 ? guided / guided_w : (spatial_w > 0.0 ? spatial / spatial_w : vec3(0.0));
    vec4 frame = imageLoad(u_frame, p);
    vec3 albedo = texelFetch(u_albedo, p, 0).rgb;
    imageStore(u_frame, p, vec4(frame.rgb + frame.a * albedo * estimate, frame.a));
}
"""


class UpsamplePass:
    name = "upsample"
    inputs = ("frame", "reduced", "normal_depth", "visibility", "albedo")
    outputs = ("frame",)

    def __init__(self, ctx: moderngl.Context, size, defines: dict):
        self.ctx = ctx
        self.size = size
        self.program = shaders.compile_compute(ctx, shaders.assemble(SOURCE, dict(defines),
                                                                     main_name="<upsample pass>"))

    def run(self, frame, reduced, gbuffer, scale: int, offset, normal_power: float, depth_sigma: float) -> None:
        set_uniforms(self.program, {"u_scale": int(scale), "u_block_offset": tuple(offset),
                                    "u_normal_power": float(normal_power), "u_depth_sigma": float(depth_sigma)})
        for unit, (name, texture) in enumerate((("u_reduced", reduced), ("u_normal_depth", gbuffer.normal_depth),
                                                ("u_visibility", gbuffer.visibility), ("u_albedo", gbuffer.albedo))):
            texture.use(location=unit)
            self.program[name].value = unit
        frame.bind_to_image(0, read=True, write=True)
        self.program.run(*groups(*self.size))
        self.ctx.memory_barrier()  # the accumulation reads it

    def release(self) -> None:
        self.program.release()
