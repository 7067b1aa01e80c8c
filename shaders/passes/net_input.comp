// The network's input tensor from the renderer's textures (model_io.network_input): channels
// demodulated mean x exposure (3), albedo (3), normal (3), in layers of 4 (TENSOR_FORMAT); row 0 of
// the tensor is the top of the picture (the G-buffer's row 0 is the bottom: y flips). The
// tensor is the picture padded at the bottom and right to the network's multiple by
// repeating the edge pixel (tiling.pad_to_multiple).
//
// TEMPORAL (a model with 13 inputs): then the previous frame's denoised demodulated radiance
// x this frame's exposure (3) and its validity (1). With HISTORY_MOTION the history is read
// where the motion vectors say, from the taps the accumulation's reprojection would keep
// (history_taps.glsl), their bilinear weights renormalised; without motion vectors (the
// camera cannot have moved without resetting the accumulation) at the same pixel. Validity 0,
// and the history 0, where no tap holds, on the background, and everywhere when
// u_history_valid is 0 (the first frame, after a reset or a camera cut).
layout(local_size_x = 8, local_size_y = 8) in;
#include "passes/net_input.glsl"
layout(std430, binding = LIFT_BINDING_NET_EXPOSURE) readonly buffer Exposure { float u_exposure; };
#ifndef TENSOR_FORMAT
#define TENSOR_FORMAT rgba32f  // the network's tensors' (shaders/denoise/tensor.glsl)
#endif
layout(TENSOR_FORMAT, binding = 7) uniform writeonly image2DArray u_input;
uniform sampler2D u_normal_depth;  // G-buffer normal (xyz), depth (w)
uniform ivec2 u_size;              // the picture; the tensor is imageSize(u_input)

#ifdef TEMPORAL
uniform sampler2D u_history;       // the last frame's denoised demodulated radiance (the renderer's rows)
uniform int u_history_valid;
#ifdef HISTORY_MOTION
#include "passes/history_taps.glsl"
uniform sampler2D u_prev_normal_depth;
uniform sampler2D u_motion;
uniform float u_depth_slack;
uniform float u_normal_cos;
#endif

vec4 previous_frame(ivec2 p) {  // (demodulated radiance, validity) at pixel p of this frame
    vec4 nd = texelFetch(u_normal_depth, p, 0);
    if (u_history_valid == 0 || !(nd.w > 0.0)) return vec4(0.0);
#ifdef HISTORY_MOTION
    HistoryTaps taps = history_taps(p, u_size, nd, texelFetch(u_motion, p, 0), u_prev_normal_depth,
                                    u_depth_slack, u_normal_cos);
    float kept = dot(taps.weight, vec4(1.0));
    if (!(kept > 1e-3)) return vec4(0.0);  // the reprojection's own threshold
    vec3 history = vec3(0.0);
    for (int i = 0; i < 4; ++i)
        if (taps.weight[i] > 0.0) history += taps.weight[i] * texelFetch(u_history, taps.base + ivec2(i & 1, i >> 1), 0).rgb;
    return vec4(history / kept, 1.0);
#else
    return vec4(texelFetch(u_history, p, 0).rgb, 1.0);
#endif
}
#endif

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
#ifdef TEMPORAL
    vec4 previous = previous_frame(p);
    imageStore(u_input, ivec3(at, 2), vec4(n.z, previous.rgb * u_exposure));
    imageStore(u_input, ivec3(at, 3), vec4(previous.a, 0.0, 0.0, 0.0));
#else
    imageStore(u_input, ivec3(at, 2), vec4(n.z, 0.0, 0.0, 0.0));
#endif
}
