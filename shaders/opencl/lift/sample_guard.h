// lift/sample_guard.h: the NaN/Inf guard on an OpenCL plugin's samples (lift/host_kernel.cl),
// the twin of the GLSL hosts' shaders/lift/sample_guard.glsl: a sample with a NaN or an
// infinity in any channel is dropped and counted (the host adds the count to the render's
// dropped samples), never averaged in. Every finite value is kept, negative ones and -0.0 too.
#ifndef LIFT_CL_SAMPLE_GUARD_H
#define LIFT_CL_SAMPLE_GUARD_H

// False when any component is NaN or infinite: the exponent bits, which survive a compiler
// that assumes fast math and folds isnan away.
bool lift_is_finite(float3 v) {
    uint3 bits = as_uint3(v) & (uint3)(0x7f800000u);
    return bits.x != 0x7f800000u && bits.y != 0x7f800000u && bits.z != 0x7f800000u;
}

// Whether sample L may be averaged in; a NaN or infinite one is counted in *dropped instead.
bool lift_keep_sample(float3 L, volatile __global uint* dropped) {
    if (lift_is_finite(L)) return true;
    atomic_inc(dropped);
    return false;
}
#endif
