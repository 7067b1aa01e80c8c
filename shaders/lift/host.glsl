// lift/host.glsl: everything a plugin can use. The trace pass's program includes this first,
// declares the plugin's parameters as uniforms of their names, then includes the plugin's
// entry file, which defines
//     vec3 radiance(Ray ray, Hit hit, inout Rng rng);
// called once a sample: `ray` is the camera ray of this sample, `hit` its first hit
// (hit.prim == NO_HIT: none), `rng` its random numbers; it returns the radiance arriving at
// the camera along `ray` (linear RGB). A NaN or infinite return is dropped and counted.
// What calls it: the host's sample loop, shaders/lift/host_main.comp (the pixel, its random
// numbers, the first hit, the loop over samples, the NaN/Inf guard, the output).
#ifndef LIFT_HOST_GLSL
#define LIFT_HOST_GLSL
#if defined(LIFT_SPLATS) && !defined(LIFT_SPLATS_CAS)
// here, at the program's top: GLSL takes an #extension only before any declaration
#extension GL_NV_shader_atomic_float : require
#endif
#include "lift/scene_data.glsl"
#include "lift/rng.glsl"
#include "lift/frame.glsl"
#include "lift/sampling.glsl"
#include "lift/bvh.glsl"
#include "lift/camera.glsl"
#include "lift/surface.glsl"
#include "lift/bsdf.glsl"
#include "lift/textures.glsl"
#include "lift/lights.glsl"
#include "lift/finite.glsl"
#include "lift/splat.glsl"
#include "lift/prepass.glsl"
#include "lift/host_frame.glsl"
#if !defined(PRIMARY_GBUFFER) && defined(HAS_PIXEL_FILTER)
#include "lift/pixel_filter.glsl"
#endif
#endif
