// lift/host.h: everything an OpenCL plugin can use. The OpenCL trace program includes this
// first, defines the plugin's Params struct, includes the plugin's entry file, which defines
//   float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params);
// then the host's kernel, lift/host_kernel.cl, which calls it once a sample: `ray` is the
// camera ray of this sample, `hit` its first hit (hit.prim == NO_HIT: none).
#ifndef LIFT_CL_HOST_H
#define LIFT_CL_HOST_H
#include "lift/scene.h"
#include "lift/rng.h"
#include "lift/sampling.h"
#include "lift/bvh.h"
#include "lift/camera.h"
#include "lift/surface.h"
#endif
