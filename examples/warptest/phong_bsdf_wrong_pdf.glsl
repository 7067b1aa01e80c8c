// WRONG on purpose: the Phong lobe of phong_bsdf.glsl with the BRDF's normalisation (n + 2)
// in the pdf, where the sampled density of cos(alpha)^n has (n + 1): 22/21, a pdf 4.8% too
// large, the same in every direction. A classic slip (the two constants sit side by side).
//   lift-gl warptest examples/warptest/phong_bsdf_wrong_pdf.glsl --sampler phong_sample --pdf phong_pdf \
//       --bsdf diffuse --cos-theta-o 0.5
#include "lift/frame.glsl"

const float PHONG_EXPONENT = 20.0;

float phong_pdf(Material m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    float cos_alpha = max(dot(wi, vec3(-wo.x, -wo.y, wo.z)), 0.0);
    return (PHONG_EXPONENT + 2.0) / (2.0 * LIFT_PI) * pow(cos_alpha, PHONG_EXPONENT);  // the bug: + 1.0
}

bool phong_sample(Material m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    if (wo.z <= 0.0) return false;
    vec3 r = vec3(-wo.x, -wo.y, wo.z);
    float cos_alpha = pow(u.x, 1.0 / (PHONG_EXPONENT + 1.0));
    float sin_alpha = sqrt(max(0.0, 1.0 - cos_alpha * cos_alpha));
    float phi = 2.0 * LIFT_PI * u.y;
    vec3 wi = to_world(frame_from_normal(r), vec3(sin_alpha * cos(phi), sin_alpha * sin(phi), cos_alpha));
    if (wi.z <= 0.0) return false;
    s.wi = wi;
    s.pdf = phong_pdf(m, wo, wi);
    s.weight = m.color_type.rgb * wi.z;  // f cos / pdf, with the wrong pdf
    return true;
}
