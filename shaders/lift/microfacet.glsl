// lift/microfacet.glsl: the isotropic GGX (Trowbridge-Reitz) microfacet distribution, in the
// shading frame (z = macro normal). alpha is the roughness (width of the slope distribution).
// Forms are chosen so that nothing divides by zero at grazing angles or small alpha.
#ifndef LIFT_MICROFACET_GLSL
#define LIFT_MICROFACET_GLSL

#include "lift/sampling.glsl"

// Normal distribution D(m) (projected area of microfacets with normal m per unit solid angle).
// With |m| = 1: cos^2(a^2 - 1) + 1 = m.x^2 + m.y^2 + a^2 m.z^2, which keeps precision as a -> 0.
float ggx_D(vec3 m, float alpha) {
    if (m.z <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float d = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    return 1.0 / max(LIFT_PI * a2 * d * d, 1e-30);
}

// sqrt(w.z^2 + alpha^2 (w.x^2 + w.y^2)) = |w.z| sqrt(1 + alpha^2 tan^2): shared by Lambda, G1, G2.
float ggx_slope_norm(vec3 w, float alpha) {
    return sqrt(w.z * w.z + alpha * alpha * (w.x * w.x + w.y * w.y));
}

// Smith Lambda: (sqrt(1 + alpha^2 tan^2) - 1) / 2; at the horizon (infinite) a large finite value.
float ggx_lambda(vec3 w, float alpha) {
    float z = abs(w.z);
    float s = ggx_slope_norm(w, alpha);
    if (z <= 0.0) return 1e30;
    return 0.5 * (s - z) / z;
}

// Smith masking of one direction, 1 / (1 + Lambda(w)); zero at the horizon.
float ggx_G1(vec3 w, float alpha) {
    float z = abs(w.z);
    float denom = z + ggx_slope_norm(w, alpha);
    return denom > 0.0 ? 2.0 * z / denom : 0.0;
}

// Height-correlated Smith masking-shadowing, 1 / (1 + Lambda(wo) + Lambda(wi)), written as
// 2 |zo| |zi| / (s_o |zi| + s_i |zo|) so that it is finite at the horizon. The caller checks
// that wo and wi see the microfacet's front (the chi+ terms).
float ggx_G2(vec3 wo, vec3 wi, float alpha) {
    float zo = abs(wo.z);
    float zi = abs(wi.z);
    float denom = ggx_slope_norm(wo, alpha) * zi + ggx_slope_norm(wi, alpha) * zo;
    return denom > 0.0 ? 2.0 * zo * zi / denom : 0.0;
}

// Sample a microfacet normal from the distribution of normals visible from wo (Heitz 2018,
// "Sampling the GGX Distribution of Visible Normals"). wo must be in the upper hemisphere;
// the result is in the upper hemisphere.
vec3 ggx_sample_visible(vec3 wo, float alpha, vec2 u) {
    // Stretch to the configuration where the roughness is 1 (a hemisphere).
    vec3 vh = normalize(vec3(alpha * wo.x, alpha * wo.y, max(wo.z, 0.0)));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    // A point on the disk projected from the visible half of the hemisphere.
    float r = sqrt(u.x);
    float phi = 2.0 * LIFT_PI * u.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    // Unstretch.
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(nh.z, 1e-7)));
}

// Density of ggx_sample_visible over microfacet normals (solid angle of m):
// G1(wo) max(0, wo.m) D(m) / wo.z.
float ggx_pdf_visible(vec3 wo, vec3 m, float alpha) {
    if (wo.z <= 0.0) return 0.0;
    return ggx_G1(wo, alpha) * max(0.0, dot(wo, m)) * ggx_D(m, alpha) / wo.z;
}

#ifdef HAS_BECKMANN
// ---- Beckmann distribution (Mitsuba's default for rough conductors) ----
// D(m) = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4). Sampled in proportion to D(m) cos(m),
// not by visible normals (Beckmann has no closed-form VNDF sampling).
float beckmann_D(vec3 m, float alpha) {
    if (m.z <= 0.0) return 0.0;
    float cos2 = m.z * m.z;
    float tan2 = max(0.0, 1.0 - cos2) / cos2;
    float a2 = alpha * alpha;
    return exp(-tan2 / a2) / max(LIFT_PI * a2 * cos2 * cos2, 1e-30);
}

// Smith Lambda with Walter et al.'s (2007) rational fit, a = 1 / (alpha tan(theta)).
float beckmann_lambda(vec3 w, float alpha) {
    float z = abs(w.z);
    float s = sqrt(max(0.0, 1.0 - z * z));
    if (!(s > 0.0)) return 0.0;
    float a = z / (alpha * s);
    if (a >= 1.6) return 0.0;
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a);
}

// Smith masking of one direction.
float beckmann_G1(vec3 w, float alpha) { return 1.0 / (1.0 + beckmann_lambda(w, alpha)); }

// Height-correlated masking-shadowing.
float beckmann_G2(vec3 wo, vec3 wi, float alpha) {
    return 1.0 / (1.0 + beckmann_lambda(wo, alpha) + beckmann_lambda(wi, alpha));
}

// A microfacet normal with density D(m) cos(m) (over solid angle of m).
vec3 beckmann_sample(float alpha, vec2 u) {
    float tan2 = -alpha * alpha * log(max(1.0 - u.x, 1e-30));
    float cos_t = inversesqrt(1.0 + tan2);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    float phi = 2.0 * LIFT_PI * u.y;
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}
#endif

#endif
