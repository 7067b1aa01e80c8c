// lens.glsl: where on the thin lens a camera ray starts (step 4), with its density.
// Check the pair: lift-gl warptest drt_lab/lens.glsl --sampler sample_lens --pdf pdf_lens --domain disk
#ifndef DRT_LAB_LENS_GLSL
#define DRT_LAB_LENS_GLSL
#include "lift/sampling.glsl"

// A point of the unit disk, uniform by area, from u uniform in [0, 1)^2. The radius is the
// square root of u.x: the area within radius r grows as r^2, so r^2 must be uniform.
vec2 sample_lens(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * LIFT_PI * u.y;
    return r * vec2(cos(phi), sin(phi));
}

// Its density per unit area: 1 / pi on the disk, 0 outside.
float pdf_lens(vec2 p) {
    return dot(p, p) <= 1.0 ? LIFT_INV_PI : 0.0;
}
#endif
