// lift/host.glsl: everything a plugin can use. The host's generated main() includes this,
// declares the plugin's parameters as uniforms of their names, then includes the plugin's
// entry file, which defines
//     vec3 radiance(Ray ray, Hit hit, inout Rng rng);
// called once a sample: `ray` is the camera ray of this sample, `hit` its first hit
// (hit.prim == NO_HIT: none), `rng` its random numbers; it returns the radiance arriving at
// the camera along `ray` (linear RGB). A NaN or infinite return is dropped and counted.
#ifndef LIFT_HOST_GLSL
#define LIFT_HOST_GLSL
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
#endif
