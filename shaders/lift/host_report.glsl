// lift/host_report.glsl: what the host's programs (lift/host_main.comp, lift/host_prepass.comp)
// share around a plugin's call: a sample's random numbers, the report an invocation makes at
// its end, and which pixel sample a plugin's prepass storage is read for (lift/prepass.glsl).
#ifndef LIFT_HOST_REPORT_GLSL
#define LIFT_HOST_REPORT_GLSL
// The random numbers of this frame's sample s of a pixel.
Rng lift_sample_rng(ivec2 pixel, uint s) {
#ifdef LIFT_COHERENT_SAMPLING
    lift_own_rng = rng_init_pixel_sample(uvec2(pixel), u_frame, s, u_sample_base + s, u_seed ^ 0x68bc21ebu, u_stream);
#endif
    return rng_init_pixel_sample(lift_rng_key(uvec2(pixel)), u_frame, s, u_sample_base + s, u_seed, u_stream);
}

// What an invocation reports once, at its end: its rays (LIFT_COUNT_RAYS: a 64-bit count in two
// words, a carry into stats[3] when stats[2] wraps around) and whether the driver's loop budget
// cut its loops short (a loop's first iteration always runs, so the probe needs two to tell:
// kept, but counted and reported as stats[4]).
void lift_report_invocation() {
#ifdef LIFT_COUNT_RAYS
    if (lift_rays_traced > 0u) {
        uint before = atomicAdd(stats[2], lift_rays_traced);
        if (before > 0xffffffffu - lift_rays_traced) atomicAdd(stats[3], 1u);
    }
#endif
    uint probe = 0u;
    for (uint i = 0u; i < u_samples + 1u; ++i) probe += 1u;
    if (probe < u_samples + 1u) atomicAdd(stats[4], 1u);
}

#ifdef LIFT_PREPASS
// Sample s of this frame at this invocation: both passes dispatch the same work groups, so an
// invocation and a sample name the same pixel sample in each.
void lift_prepass_begin(uint s) {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint invocation = group * (gl_WorkGroupSize.x * gl_WorkGroupSize.y) + gl_LocalInvocationIndex;
    lift_prepass_sample = s * u_prepass_invocations + invocation;
}
#endif
#endif
