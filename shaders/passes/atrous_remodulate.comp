// After the last à-trous iteration: multiply the albedo back (the divisor of denoise_input),
// writing (radiance, 1) so that the tonemap pass reads it as a mean of one sample.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform readonly image2D u_in;
layout(rgba32f, binding = 1) uniform writeonly image2D u_out;
uniform sampler2D u_albedo;
uniform float u_albedo_eps;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_out)))) return;
    vec3 albedo = texelFetch(u_albedo, p, 0).rgb;
    vec3 divisor = mix(vec3(1.0), albedo, greaterThanEqual(albedo, vec3(u_albedo_eps)));
    imageStore(u_out, p, vec4(imageLoad(u_in, p).rgb * divisor, 1.0));
}
