// lift/host_prepass.comp: the prepass's program, the code that calls a plugin's [prepass]
// function (plugin.toml; lift_gl/passes/prepass.py runs it before the trace pass). After the
// trace programs' generated head (lift/host_main.comp's header lists it) and
//   #define LIFT_PREPASS_FUNCTION light_pass
// this file, for every pixel and each of this frame's samples: the sample's random numbers, as
// the trace pass draws them, and a call of the plugin's
//   void light_pass(ivec2 pixel, inout Rng rng);
// which writes what the trace pass's radiance() of the same sample reads (lift/prepass.glsl).
// It runs the trace pass's work groups over the same tiles, so that an invocation is the same
// pixel in both passes.
#include "lift/host_tiles.glsl"
#include "lift/host_report.glsl"

void main() {
    ivec2 pixel = lift_tile_pixel(gl_WorkGroupID.xy, gl_LocalInvocationID.xy, gl_WorkGroupSize.xy);
    if (!pixel_in_image(pixel)) return;
    for (uint s = 0u; s < u_samples; ++s) {
        Rng rng = lift_sample_rng(pixel, s);
        lift_prepass_begin(s);
        LIFT_PREPASS_FUNCTION(pixel, rng);
    }
    lift_report_invocation();
}
