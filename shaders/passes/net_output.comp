// The network's output back to radiance (model_io.network_output): cropped to the picture,
// NaN/Inf/negatives -> 0, divided by the exposure, times the safe albedo; y flips back to the
// renderer's row order; alpha 1 (the tonemap pass reads it as sum with count 1). TEMPORAL: the
// demodulated radiance (before the albedo) also into u_history, the next frame's input.
layout(local_size_x = 8, local_size_y = 8) in;
#include "passes/net_input.glsl"
layout(std430, binding = LIFT_BINDING_NET_EXPOSURE) readonly buffer Exposure { float u_exposure; };
#ifndef TENSOR_FORMAT
#define TENSOR_FORMAT rgba32f  // the network's tensors' (shaders/denoise/tensor.glsl)
#endif
layout(TENSOR_FORMAT, binding = 6) uniform readonly image2DArray u_output;
layout(rgba32f, binding = 7) uniform writeonly image2D u_radiance;
uniform ivec2 u_size;
#ifdef TEMPORAL
layout(rgba32f, binding = 5) uniform writeonly image2D u_history;
#endif

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, u_size))) return;
    vec3 y = clean3(imageLoad(u_output, ivec3(p.x, u_size.y - 1 - p.y, 0)).rgb);
    vec3 demodulated = y / u_exposure;
    imageStore(u_radiance, p, vec4(demodulated * net_safe_albedo(net_albedo(p)), 1.0));
#ifdef TEMPORAL
    imageStore(u_history, p, vec4(demodulated, 1.0));
#endif
}
