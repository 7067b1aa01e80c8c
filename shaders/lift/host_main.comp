// lift/host_main.comp: the trace pass's program, the code that calls a plugin's radiance().
// For every pixel: its random numbers, the camera ray and its first hit, the loop over this
// frame's samples, the NaN/Inf guard on each, the pixel's output.
//
// The program lift_gl/passes/trace.py compiles is a short generated head, then this file:
//   1. the library a plugin calls: lift/host.glsl, included;
//   2. the work group the options chose: layout(local_size_x = 8, local_size_y = 8) in;
//   3. the plugin's parameters (plugin.toml) as uniforms of their names: uniform int max_depth;
//   4. the plugin's entry file (plugins/pt/pt.glsl), included: it defines radiance();
//   5. this file, included.
//
// main() below is the plain loop. Two alternatives run instead where they are faster; each
// gives the same samples, so the same image:
// - the path-steps loop (below main), for a plugin that writes its paths as steps from the
//   G-buffer (it defines LIFT_PATH_STEPS: pt): all of a frame's samples as one loop over path
//   vertices;
// - for such a plugin on GPUs, the pixel queue (lift/host_pixel_queue.glsl), with carried paths
//   (lift/host_carry.glsl) on deep trees: chosen once per device and scene by
//   lift_gl/options.py (`lift-gl render --explain` prints which and why).
//
// Output, per pixel: the sum of this frame's samples that passed the guard in rgb, their
// count in alpha (the accumulation pass divides). Mesa's llvmpipe ends every loop of an
// invocation once 65535 iterations have run in it, all loops together (BVH steps, bounces,
// samples), and says nothing: lift_report_invocation's probe loop notices and counts it.

// ---- the host's inputs ----
layout(rgba32f, binding = 0) uniform writeonly image2D u_frame_out;
#ifdef PRIMARY_GBUFFER
uniform usampler2D u_visibility;
#endif
// (and the frame's uniforms, u_frame, u_seed, u_samples, ...: lift/host_frame.glsl)
#ifdef PRIMARY_GBUFFER
#include "lift/primary_hit.glsl"
#endif
#include "lift/host_tiles.glsl"
#include "lift/sample_guard.glsl"
#include "lift/host_report.glsl"

#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS) && defined(LIFT_PIXEL_QUEUE)
#define LIFT_QUEUED   // the pixel queue runs instead of main()'s loop
#endif

#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS)
void lift_trace_path_steps(ivec2 pixel, inout vec3 sum, inout float valid);
#endif
#ifdef LIFT_QUEUED
void lift_trace_pixel_queue();
#endif

// ==== main(): the plain sample loop ====
void main() {
#ifdef LIFT_QUEUED
    lift_trace_pixel_queue();
    lift_report_invocation();
    return;
#endif
    ivec2 pixel = lift_tile_pixel(gl_WorkGroupID.xy, gl_LocalInvocationID.xy, gl_WorkGroupSize.xy);  // a group: a tile
    if (!pixel_in_image(pixel)) return;
    vec3 sum = vec3(0.0);   // this frame's samples that passed the guard ...
    float valid = 0.0;      // ... and how many they are
#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS)
    lift_trace_path_steps(pixel, sum, valid);
#else
    for (uint s = 0u; s < u_samples; ++s) {
        Rng rng = lift_sample_rng(pixel, s);
#ifdef LIFT_PREPASS
        lift_prepass_begin(s);  // the storage the plugin's prepass left for this sample (lift/prepass.glsl)
#endif
        Ray ray;
        Hit hit;
#ifdef PRIMARY_GBUFFER
        // the G-buffer's first hit, the same for all the frame's samples of the pixel
#ifdef HAS_MOTION
        g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
        ray = camera_ray(vec2(pixel) + u_jitter);
        hit = gbuffer_hit(pixel, ray);
#else
        // primary = "camera": a point in the pixel, on the lens and in the shutter interval
        vec2 subpixel = rng_next2(rng);
#ifdef HAS_PIXEL_FILTER
        subpixel = pixel_filter_offset(subpixel);  // drawn from the scene's pixel filter
#endif
        vec2 lens = rng_next2(rng);
#ifdef HAS_MOTION
        g_ray_time = rng_next(rng);  // uniform over the shutter: a box shutter
#endif
        ray = camera_ray_lens(vec2(pixel) + subpixel, lens);
        trace_closest(ray, hit);
#endif
        lift_add_sample(radiance(ray, hit, rng), sum, valid);   // the guard: lift/sample_guard.glsl
    }
#endif
    lift_report_invocation();
    imageStore(u_frame_out, pixel, vec4(sum, valid));
}

// ---- what main() calls ----

#if defined(PRIMARY_GBUFFER) && defined(LIFT_PATH_STEPS)
// ==== alternative: the path-steps loop ====
// A plugin whose paths advance a vertex at a time: one loop over all the vertices of all this
// frame's samples, a lane starting its next sample as soon as its path ends. (A loop per
// sample keeps the SIMD lanes of a CPU rasterizer waiting for the longest path of their
// batch: docs/cpu-speed.md.) The samples of a frame share its G-buffer hit, as in main()'s
// loop, and have the same random numbers: the same sums.
void lift_trace_path_steps(ivec2 pixel, inout vec3 sum, inout float valid) {
#ifdef HAS_MOTION
    g_ray_time = 0.0;  // the moment the G-buffer shows: shutter open
#endif
    Ray primary_ray = camera_ray(vec2(pixel) + u_jitter);
    Hit primary_hit = gbuffer_hit(pixel, primary_ray);
    uint s = 0u;
    Rng rng = lift_sample_rng(pixel, 0u);
    PathState path = path_start(primary_ray, primary_hit);
    while (s < u_samples) {
        if (path_step(path, rng)) continue;
        lift_add_sample(path_radiance(path), sum, valid);
        ++s;
        rng = lift_sample_rng(pixel, s);
        path = path_start(primary_ray, primary_hit);
    }
}
#endif

#ifdef LIFT_QUEUED
// ==== alternative: the pixel queue (GPUs) ====
#include "lift/host_pixel_queue.glsl"
#endif
