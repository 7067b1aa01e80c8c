// One iteration of the edge-avoiding à-trous wavelet filter (Dammertz et al. 2010) with
// SVGF's edge-stopping functions (Schied et al. 2017), on demodulated irradiance (rgb) and
// the variance of its luminance (a). Taps: the 5x5 B3-spline kernel spread `u_step` pixels
// apart (1, 2, 4, ... over the iterations). Weight of tap q for pixel p:
//   h(q) * exp(-|z_p - z_q| / (sigma_z |grad z . (p - q)| + eps_z))      depth
//        * max(0, n_p . n_q)^sigma_n                                      normal
//        * exp(-|l_p - l_q| / (sigma_l sqrt(g3x3(var_p)) + eps_l))        luminance
// The output variance is sum(w^2 var_q) / (sum w)^2: the variance of the weighted mean.
// Background pixels (no surface) pass through and take no part (their variance is 0).
layout(local_size_x = 8, local_size_y = 8) in;
#include "passes/atrous_common.glsl"
layout(rgba32f, binding = 0) uniform readonly image2D u_in;
layout(rgba32f, binding = 1) uniform writeonly image2D u_out;
uniform int u_step;
uniform float u_sigma_luminance;  // <= 0: no luminance edge-stopping (a linear filter on flat guides)
uniform float u_sigma_normal;     // exponent; 0: no normal edge-stopping
uniform float u_sigma_depth;      // <= 0: no depth edge-stopping

const float KERNEL[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
const float EPS_LUMINANCE = 1e-10;
const float LOG2_E = 1.4426950408889634;

// 3x3 Gaussian of the variance around p (SVGF's prefilter: one pixel's estimate is noisy).
// Background pixels hold variance 0 (atrous_prepare.comp): no surface test needed here.
float blurred_variance(ivec2 p, ivec2 size) {
    float sum = 0.0, weight = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            float w = (dx == 0 ? 0.5 : 0.25) * (dy == 0 ? 0.5 : 0.25);  // [1/4, 1/2, 1/4] squared
            sum += w * imageLoad(u_in, q).a;
            weight += w;
        }
    }
    return sum / weight;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_out);
    if (any(greaterThanEqual(p, size))) return;
    vec4 c = imageLoad(u_in, p);
    vec4 nd = texelFetch(u_normal_depth, p, 0);
    if (!is_surface(nd)) {
        imageStore(u_out, p, c);
        return;
    }
    float l_p = atrous_luminance(c.rgb);
    float luminance_scale = u_sigma_luminance > 0.0
        ? u_sigma_luminance * sqrt(max(blurred_variance(p, size), 0.0)) + EPS_LUMINANCE : 0.0;
    vec2 grad = depth_gradient(p, size, nd.w);
    float eps_depth = 1e-2 * max(abs(nd.w), 1e-6);  // planes seen head-on have no gradient

    vec3 sum = vec3(0.0);
    float weight = 0.0, variance = 0.0;
    for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
            ivec2 offset = ivec2(dx, dy) * u_step;
            ivec2 q = p + offset;
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            vec4 nd_q = texelFetch(u_normal_depth, q, 0);
            if (!is_surface(nd_q)) continue;
            vec4 c_q = imageLoad(u_in, q);
            // The three edge-stopping weights as one power of two: log2 of their product
            // (one exp2 and at most one log2 a tap instead of two exp and a pow).
            float exponent = 0.0;
            if (u_sigma_normal > 0.0) {
                float cosine = dot(nd.xyz, nd_q.xyz);
                if (cosine <= 0.0) continue;  // weight 0
                exponent += u_sigma_normal * log2(min(cosine, 1.0));
            }
            if (offset != ivec2(0)) {
                float stop = 0.0;
                if (u_sigma_depth > 0.0) {
                    stop += abs(nd.w - nd_q.w) / (u_sigma_depth * abs(dot(grad, vec2(offset))) + eps_depth);
                }
                if (u_sigma_luminance > 0.0) stop += abs(l_p - atrous_luminance(c_q.rgb)) / luminance_scale;
                exponent -= LOG2_E * stop;
            }
            float w = KERNEL[abs(dx)] * KERNEL[abs(dy)] * exp2(exponent);
            sum += w * c_q.rgb;
            variance += w * w * c_q.a;
            weight += w;
        }
    }
    // The centre tap has weight h(0) > 0 for unit normals (n_p . n_p = 1); a guide that is not
    // (every tap's weight underflowed) leaves the pixel as it was rather than 0 / 0.
    imageStore(u_out, p, weight > 0.0 ? vec4(sum / weight, variance / (weight * weight)) : c);
}
