// lift/sample_guard.glsl: the NaN/Inf guard on a plugin's samples, run by every GLSL trace pass
// (lift/host_main.comp, lift/host_reduced.comp; the OpenCL host's is
// shaders/opencl/lift/sample_guard.h). A sample with a NaN or an infinity in any channel is
// dropped and counted in stats[0] (a render's dropped samples), never averaged in: one bad
// sample would make its pixel NaN for the rest of the accumulation. Every finite value is
// kept, negative ones and -0.0 too (the guard does not judge the estimate, only its numbers).
#ifndef LIFT_SAMPLE_GUARD_GLSL
#define LIFT_SAMPLE_GUARD_GLSL
#include "lift/scene_data.glsl"
#include "lift/finite.glsl"

// Whether sample L may be averaged in; a NaN or infinite one is counted instead.
bool lift_keep_sample(vec3 L) {
    if (lift_is_finite(L)) return true;
    atomicAdd(stats[0], 1u);
    return false;
}

// A sample's radiance into its pixel's sum and count, if the guard keeps it.
void lift_add_sample(vec3 L, inout vec3 sum, inout float valid) {
    if (lift_keep_sample(L)) {
        sum += L;
        valid += 1.0;
    }
}
#endif
