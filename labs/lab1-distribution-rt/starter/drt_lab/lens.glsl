// lens.glsl: where on the thin lens a camera ray starts (step 4), with its density.
// Check the pair: lift-gl warptest drt_lab/lens.glsl --sampler sample_lens --pdf pdf_lens --domain disk
#ifndef DRT_LAB_LENS_GLSL
#define DRT_LAB_LENS_GLSL
#include "lift/sampling.glsl"

// YOUR TURN (step 4): a point of the unit disk, uniform by area, from u uniform in [0, 1)^2.
// (Uniform in radius and angle is not uniform by area: warptest shows the difference.)
vec2 sample_lens(vec2 u) {
    return vec2(0.0);
}

// Its density per unit area: 1 / pi on the disk, 0 outside.
float pdf_lens(vec2 p) {
    return dot(p, p) <= 1.0 ? LIFT_INV_PI : 0.0;
}
#endif
