// lift/host_reduced.comp: the reduced trace pass's program (lift_gl/passes/reduced_trace.py): a
// plugin's second estimate, its `[reduced]` function (a hybrid plugin's indirect light), for one
// pixel in every scale x scale block, divided by that pixel's albedo (demodulated).
//
// As lift/host_main.comp, it follows a short generated head: lift/host.glsl, the work group,
// the plugin's parameters, the plugin's entry file, and LIFT_REDUCED_RADIANCE defined as the
// name of the manifest's [reduced] function (which has radiance()'s signature).
//
// Output, per block: the demodulated samples' sum in rgb, their count in a; 0 samples where the
// first hit is black or missing (no information to spread to the neighbours).

// ---- the host's inputs ----
layout(rgba32f, binding = 0) uniform writeonly image2D u_reduced_out;
uniform usampler2D u_visibility;
uniform sampler2D u_albedo;  // G-buffer: the first hit's albedo, textures applied
uniform int u_scale;          // full-resolution pixels per reduced pixel, along each axis
uniform ivec2 u_block_offset; // this frame's representative pixel inside every block
#include "lift/primary_hit.glsl"  // gbuffer_hit: the first hit at a full-resolution pixel
#include "lift/sample_guard.glsl"

void main() {
    ivec2 block = ivec2(gl_GlobalInvocationID.xy);
    ivec2 blocks = imageSize(u_reduced_out);
    if (any(greaterThanEqual(block, blocks))) return;
    ivec2 pixel = min(block * u_scale + u_block_offset, ivec2(u_resolution) - 1);
    vec3 sum = vec3(0.0);
    float valid = 0.0;
    Ray ray = camera_ray(vec2(pixel) + u_jitter);
    Hit first = gbuffer_hit(pixel, ray);
    vec3 albedo = first.prim != NO_HIT ? texelFetch(u_albedo, pixel, 0).rgb : vec3(0.0);
    if (max(albedo.r, max(albedo.g, albedo.b)) <= 1e-6) {
        // Black (an emitter's face, the background): it tells its neighbours nothing about
        // their indirect light, so it must not count as zero in their filter.
        imageStore(u_reduced_out, block, vec4(0.0));
        return;
    }
    for (uint s = 0u; s < u_samples; ++s) {
        // Another seed than the full-resolution pass's: the two estimates stay independent.
        Rng rng = rng_init_pixel_sample(uvec2(pixel), u_frame, s, u_sample_base + s, u_seed ^ 0x5bd1e995u, u_stream);
        Hit hit = first;
        vec3 L = LIFT_REDUCED_RADIANCE(ray, hit, rng);
        if (!lift_keep_sample(L)) continue;   // the guard: lift/sample_guard.glsl
        // Demodulated; a channel the surface does not reflect carries no indirect light.
        sum += mix(vec3(0.0), L / max(albedo, vec3(1e-6)), greaterThan(albedo, vec3(1e-6)));
        valid += 1.0;
    }
    imageStore(u_reduced_out, block, vec4(sum, valid));
}
