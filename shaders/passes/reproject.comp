// Reproject, moving camera or objects: the accumulation as the new camera sees it.
//
// For each pixel, the G-buffer's motion vector says where its first hit was in the previous
// frame (shaders/passes/motion_vectors.glsl). The history is read there with the 2x2
// bilinear taps; a tap counts only where the previous frame saw the same surface (depth and
// normal tests: history_taps.glsl). The kept taps are blended with their bilinear weights renormalised. When none is kept
// (a disocclusion, or the point was off screen) the history restarts: everything 0, so the
// accumulate pass that follows leaves exactly this frame (history length = its samples).
//
// The history is kept as sums (see accumulate.comp): the mean times a count. The count is
// capped at u_history_cap samples, so the frame that follows weighs at least the minimum
// blend factor: a moving camera gets an exponential moving average, and a ghost fades.
// Sums, moments and the half difference are scaled alike, so every ratio is kept.
#include "history_taps.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D u_prev_sum;
uniform sampler2D u_prev_compensation;
uniform sampler2D u_prev_half_difference;
uniform sampler2D u_prev_moments;
uniform sampler2D u_prev_normal_depth;
uniform sampler2D u_normal_depth;
uniform sampler2D u_motion;
uniform sampler2D u_frame;
layout(rgba32f, binding = 0) uniform writeonly image2D u_sum;
layout(rgba32f, binding = 1) uniform writeonly image2D u_compensation;
layout(rgba32f, binding = 2) uniform writeonly image2D u_half_difference;
layout(rgba32f, binding = 3) uniform writeonly image2D u_moments;
layout(rgba32f, binding = 4) uniform writeonly image2D u_rejection;
uniform float u_history_cap;      // samples
uniform float u_depth_slack;      // relative depth difference always allowed
uniform float u_normal_cos;       // normals closer than this angle match
uniform float u_clamp_sigma;      // > 0: clamp the history to the frame's neighbourhood (BIASED)

// The current frame's 3x3 neighbourhood: mean +- k standard deviations (variance clipping).
vec3 clamp_to_neighbourhood(vec3 history, ivec2 p, ivec2 size) {
    vec3 m1 = vec3(0.0), m2 = vec3(0.0);
    float n = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), size - 1);
            vec4 f = texelFetch(u_frame, q, 0);
            if (f.a <= 0.0) continue;
            vec3 c = f.rgb / f.a;
            m1 += c;
            m2 += c * c;
            n += 1.0;
        }
    }
    if (n == 0.0) return history;
    m1 /= n;
    vec3 sigma = sqrt(max(m2 / n - m1 * m1, 0.0));
    return clamp(history, m1 - u_clamp_sigma * sigma, m1 + u_clamp_sigma * sigma);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_sum);
    if (any(greaterThanEqual(p, size))) return;
    vec4 nd = texelFetch(u_normal_depth, p, 0);
    vec4 motion = texelFetch(u_motion, p, 0);
    HistoryTaps taps = history_taps(p, size, nd, motion, u_prev_normal_depth, u_depth_slack, u_normal_cos);
    vec3 rejected = taps.rejected;
    float kept = 0.0, count = 0.0, frames = 0.0;
    vec3 mean = vec3(0.0);
    vec2 moments = vec2(0.0);  // per-frame mean luminance and its square
    vec4 half_difference = vec4(0.0);
    for (int i = 0; i < 4; ++i) {
        float w = taps.weight[i];
        if (w <= 0.0) continue;
        ivec2 q = taps.base + ivec2(i & 1, i >> 1);
        vec4 total = texelFetch(u_prev_sum, q, 0) + texelFetch(u_prev_compensation, q, 0);
        if (!(total.a > 0.0)) continue;  // the same surface, but no sample yet
        vec4 m = texelFetch(u_prev_moments, q, 0);
        kept += w;
        mean += w * total.rgb / total.a;
        count += w * total.a;
        half_difference += w * texelFetch(u_prev_half_difference, q, 0) / total.a;
        if (m.z > 0.0) {
            moments += w * m.xy / m.z;
            frames += w * m.z;
        }
    }
    vec4 sum = vec4(0.0), out_half = vec4(0.0), out_moments = vec4(0.0);
    if (kept > 1e-3) {
        mean /= kept;
        count /= kept;
        if (u_clamp_sigma > 0.0) mean = clamp_to_neighbourhood(mean, p, size);
        float scale = min(count, u_history_cap) / count;
        count *= scale;
        sum = vec4(mean * count, count);
        out_half = half_difference / kept * count;  // half sums per sample, times the new count
        frames = frames / kept * scale;
        out_moments = frames > 0.0 ? vec4(moments / kept * frames, frames, 0.0) : vec4(0.0);
    }
    imageStore(u_sum, p, sum);
    imageStore(u_compensation, p, vec4(0.0));
    imageStore(u_half_difference, p, out_half);
    imageStore(u_moments, p, out_moments);
    imageStore(u_rejection, p, vec4(rejected, 1.0));
}
