// Denoiser input: the accumulated mean radiance demodulated by the first-hit albedo (as
// lift_gl/denoise/demodulate.py: a channel whose albedo is below eps keeps its radiance),
// with the variance of its luminance in alpha (negative: unknown).
layout(local_size_x = 8, local_size_y = 8) in;
#include "passes/denoise_variance.glsl"
layout(rgba32f, binding = 0) uniform readonly image2D u_sum;
layout(rgba32f, binding = 1) uniform readonly image2D u_compensation;
layout(rgba32f, binding = 2) uniform readonly image2D u_half_difference;
layout(rgba32f, binding = 3) uniform writeonly image2D u_irradiance;
uniform sampler2D u_albedo;  // G-buffer albedo (RGBA16F)
uniform float u_albedo_eps;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_irradiance)))) return;
    vec4 totals = imageLoad(u_sum, p) + imageLoad(u_compensation, p);
    vec3 albedo = texelFetch(u_albedo, p, 0).rgb;
    vec3 divisor = mix(vec3(1.0), albedo, greaterThanEqual(albedo, vec3(u_albedo_eps)));
    vec3 mean = totals.a > 0.0 ? totals.rgb / totals.a : vec3(0.0);
    float variance = luminance_variance(totals, imageLoad(u_half_difference, p), divisor);
    imageStore(u_irradiance, p, vec4(mean / divisor, variance));
}
