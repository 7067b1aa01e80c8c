// The network's input tensor from the renderer's textures (model_io.network_input): channels
// demodulated mean x exposure (3), albedo (3), normal (3), in layers of 4 (TENSOR_FORMAT); row 0 of
// the tensor is the top of the picture (the G-buffer's row 0 is the bottom: y flips). The
// tensor is the picture padded at the bottom and right to the network's multiple by
// repeating the edge pixel (tiling.pad_to_multiple).
layout(local_size_x = 8, local_size_y = 8) in;
#include "passes/net_input.glsl"
layout(std430, binding = LIFT_BINDING_NET_EXPOSURE) readonly buffer Exposure { float u_exposure; };
#ifndef TENSOR_FORMAT
#define TENSOR_FORMAT rgba32f  // the network's tensors' (shaders/denoise/tensor.glsl)
#endif
layout(TENSOR_FORMAT, binding = 7) uniform writeonly image2DArray u_input;
uniform sampler2D u_normal_depth;  // G-buffer normal (xyz), depth (w)
uniform ivec2 u_size;              // the picture; the tensor is imageSize(u_input)

void main() {
    ivec2 at = ivec2(gl_GlobalInvocationID.xy);  // tensor pixel: (column, row from the top)
    if (any(greaterThanEqual(at, imageSize(u_input).xy))) return;
    ivec2 src = min(at, u_size - 1);
    ivec2 p = ivec2(src.x, u_size.y - 1 - src.y);
    vec3 albedo = net_albedo(p);
    vec3 color = net_demodulated(p, albedo) * u_exposure;
    vec3 n = texelFetch(u_normal_depth, p, 0).xyz;
    n = clamp(mix(n, vec3(0.0), isnan(n)), -1.0, 1.0);  // nan_to_num then clip, as model_io
    imageStore(u_input, ivec3(at, 0), vec4(color, albedo.r));
    imageStore(u_input, ivec3(at, 1), vec4(albedo.gb, n.xy));
    imageStore(u_input, ivec3(at, 2), vec4(n.z, 0.0, 0.0, 0.0));
}
