#ifndef NET_INPUT_GLSL
#define NET_INPUT_GLSL
// What lift_gl/denoise/model_io.py does to one pixel, on the renderer's textures: the mean
// from the accumulation (NaN/Inf -> 0, negatives -> 0), albedo clipped to [0, 1], the
// radiance demodulated by it (a channel below eps keeps its radiance, demodulate.py).
layout(rgba32f, binding = 0) uniform readonly image2D u_sum;
layout(rgba32f, binding = 1) uniform readonly image2D u_compensation;
uniform sampler2D u_albedo;  // G-buffer albedo (RGBA16F)
uniform float u_albedo_eps;

vec3 clean3(vec3 v) {
    bvec3 bad = bvec3(isnan(v.x) || isinf(v.x), isnan(v.y) || isinf(v.y), isnan(v.z) || isinf(v.z));
    return max(mix(v, vec3(0.0), bad), vec3(0.0));
}

vec3 net_albedo(ivec2 p) {
    return clamp(clean3(texelFetch(u_albedo, p, 0).rgb), 0.0, 1.0);
}

vec3 net_safe_albedo(vec3 albedo) {
    return mix(vec3(1.0), albedo, greaterThanEqual(albedo, vec3(u_albedo_eps)));
}

vec3 net_demodulated(ivec2 p, vec3 albedo) {
    vec4 totals = imageLoad(u_sum, p) + imageLoad(u_compensation, p);
    vec3 mean = totals.a > 0.0 ? totals.rgb / totals.a : vec3(0.0);
    return clean3(clean3(mean) / net_safe_albedo(albedo));
}
#endif
