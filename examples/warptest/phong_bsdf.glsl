// A student's BSDF: a Phong lobe about the mirror direction r of wo, f = ks (n + 2) / (2 pi)
// cos(alpha)^n with alpha the angle between wi and r, sampled in proportion to cos(alpha)^n
// (as power_cosine.glsl does about +z, here about r). Directions below the surface are
// rejected: the sampler returns false, and the pdf is 0 there, so the pdf integrates to less
// than 1 by exactly the chance of a rejection.
// The functions have the signatures of bsdf_sample / bsdf_pdf (shaders/lift/bsdf.glsl):
//   lift-gl warptest examples/warptest/phong_bsdf.glsl --sampler phong_sample --pdf phong_pdf \
//       --bsdf diffuse --cos-theta-o 0.5
#include "lift/frame.glsl"

const float PHONG_EXPONENT = 20.0;

bool phong_sample(Material m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    if (wo.z <= 0.0) return false;
    vec3 r = vec3(-wo.x, -wo.y, wo.z);
    float cos_alpha = pow(u.x, 1.0 / (PHONG_EXPONENT + 1.0));
    float sin_alpha = sqrt(max(0.0, 1.0 - cos_alpha * cos_alpha));
    float phi = 2.0 * LIFT_PI * u.y;
    vec3 wi = to_world(frame_from_normal(r), vec3(sin_alpha * cos(phi), sin_alpha * sin(phi), cos_alpha));
    if (wi.z <= 0.0) return false;  // below the surface
    s.wi = wi;
    s.pdf = (PHONG_EXPONENT + 1.0) / (2.0 * LIFT_PI) * pow(cos_alpha, PHONG_EXPONENT);
    // f cos(theta_i) / pdf: the lobe's cos(alpha)^n cancels.
    s.weight = m.color_type.rgb * ((PHONG_EXPONENT + 2.0) / (PHONG_EXPONENT + 1.0) * wi.z);
    return true;
}

float phong_pdf(Material m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    float cos_alpha = max(dot(wi, vec3(-wo.x, -wo.y, wo.z)), 0.0);
    return (PHONG_EXPONENT + 1.0) / (2.0 * LIFT_PI) * pow(cos_alpha, PHONG_EXPONENT);
}
