// lift/host_kernel.cl: the OpenCL trace pass's kernel, the code that calls an OpenCL plugin's
//     float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params);
// the twin of the GLSL host's shaders/lift/host_main.comp: for every pixel, the random numbers
// (the same as the GLSL host's), the camera ray and its first hit, the loop over this frame's
// samples, the NaN/Inf guard (lift/sample_guard.h) on each, the pixel's output.
//
// The program lift_gl/passes/trace_cl.py builds is a short generated head, then this file:
//   1. the library an OpenCL plugin calls: lift/host.h, included;
//   2. the plugin's parameters (plugin.toml) as the fields of struct Params, and lift_params(),
//      which reads them from the parameter buffer;
//   3. the plugin's entry file (plugins/ao_cl/ao_cl.cl), included: it defines radiance();
//   4. this file, included.
//
// Output, per pixel: the sum of this frame's samples that passed the guard in rgb, their
// count in w, in GL texture order (row 0 at the bottom); the host copies it to the GL frame.
#include "lift/sample_guard.h"
#ifdef HAS_PIXEL_FILTER
#include "lift/pixel_filter.h"
#endif

// ---- the frame: per-frame values, one float4 each (uint fields as bit patterns; trace_cl.py pack_frame) ----
typedef struct { Camera camera; float2 jitter; uint frame, seed, samples; } FrameInfo;

FrameInfo lift_frame(__global const float4* f, Scene* scene) {
    FrameInfo info;
    info.camera.position = f[0].xyz;
    info.camera.right = f[1].xyz;
    info.camera.up = f[2].xyz;
    info.camera.forward = f[3].xyz;
    info.camera.tan_half_fov = f[4].x;
    info.camera.lens_radius = f[4].y;
    info.camera.focus_distance = f[4].z;
    info.camera.resolution = f[5].xy;
    info.jitter = f[5].zw;
    scene->env_radiance = f[6].xyz;
    info.frame = as_uint(f[6].w);
    scene->num_triangles = as_uint(f[7].x);
    scene->num_spheres = as_uint(f[7].y);
    scene->num_lights = as_uint(f[7].z);
    info.seed = as_uint(f[7].w);
    info.samples = as_uint(f[4].w);
    return info;
}

#ifdef PRIMARY_GBUFFER
// The primary hit the raster found, rebuilt exactly along the camera ray; where ray and
// raster disagree (a sample exactly on an edge) the ray is traced instead.
Hit gbuffer_hit(const Scene* scene, uint4 v, Ray ray) {
    Hit hit;
    hit.prim = NO_HIT;
    hit.t = ray.tmax;
    hit.bary = (float2)(0.0f);
    if (v.x == 0u) return hit;
    uint prim = v.x - 1u;
    float t = ray.tmax;
    float2 bary;
    if (prim < scene->num_triangles && intersect_triangle(scene, ray, prim, &t, &bary)) {
        hit.prim = prim; hit.t = t; hit.bary = bary;
        return hit;
    }
#ifdef HAS_SPHERES
    if (prim >= scene->num_triangles && intersect_sphere(scene, ray, prim - scene->num_triangles, &t)) {
        hit.prim = prim; hit.t = t;
        return hit;
    }
#endif
    trace_closest(scene, ray, &hit);
    return hit;
}
#endif

// ---- the kernel: the sample loop ----
__kernel void lift_trace(
        __global const float4* bvh_nodes, __global const float4* tri_pos, __global const float4* tri_normal,
        __global const float4* tri_uv, __global const uint2* tri_info, __global const Material* materials,
        __global const float4* lights, __global const float4* spheres,
        __global const float4* frame_values, __global const float* param_values,
        __global const uint4* visibility, __global float4* frame_out, volatile __global uint* dropped) {
    Scene scene;
    scene.bvh_nodes = bvh_nodes; scene.tri_pos = tri_pos; scene.tri_normal = tri_normal;
    scene.tri_uv = tri_uv; scene.tri_info = tri_info; scene.materials = materials;
    scene.lights = lights; scene.spheres = spheres;
    FrameInfo info = lift_frame(frame_values, &scene);
    Params params = lift_params(param_values);
    uint2 pixel = (uint2)(get_global_id(0), get_global_id(1));
    uint width = (uint)info.camera.resolution.x;
    if (pixel.x >= width || pixel.y >= (uint)info.camera.resolution.y) return;
    uint index = pixel.y * width + pixel.x;  // GL texture order: row 0 at the bottom
    float2 position = convert_float2(pixel);

    float3 sum = (float3)(0.0f);   // this frame's samples that passed the guard ...
    float valid = 0.0f;            // ... and how many they are
    for (uint s = 0u; s < info.samples; ++s) {
        Rng rng = rng_init(pixel, info.frame, s, info.seed);
        Ray ray;
        Hit hit;
#ifdef PRIMARY_GBUFFER
        ray = camera_ray(&info.camera, position + info.jitter);
        hit = gbuffer_hit(&scene, visibility[index], ray);
#else
        float2 subpixel = rng_next2(&rng);
#ifdef HAS_PIXEL_FILTER
        subpixel = pixel_filter_offset(frame_values + FRAME_ROWS, subpixel);  // the scene's pixel filter
#endif
        float2 lens = rng_next2(&rng);
        ray = camera_ray_lens(&info.camera, position + subpixel, lens);
        trace_closest(&scene, ray, &hit);
#endif
        float3 L = radiance(ray, hit, &rng, &scene, &params);
        if (!lift_keep_sample(L, dropped)) continue;   // the guard: lift/sample_guard.h
        sum += L;
        valid += 1.0f;
    }
    frame_out[index] = (float4)(sum, valid);
}
