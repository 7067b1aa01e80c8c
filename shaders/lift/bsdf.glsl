// lift/bsdf.glsl: the BSDFs of lift-gl materials, in the local shading frame.
//
// Conventions
//   - z is the shading normal; wo (towards the viewer) and wi (towards the light) both point
//     AWAY from the surface. For a dielectric, wo.z < 0 means the viewer is inside the medium.
//   - Diffuse and conductor are one-sided: zero when wo.z <= 0 or wi.z <= 0. The caller flips
//     the frame to face wo for opaque surfaces.
//   - Radiance transport (camera paths): a transmitted sample's weight and the transmission
//     part of bsdf_eval carry the factor (n_wo / n_wi)^2 = 1 / etap^2, with
//     etap = n(side of wi) / n(side of wo). Radiance is compressed by eta^2 when it enters a
//     denser medium; the camera path follows it backwards.
//   - Delta lobes (smooth conductor, smooth dielectric) are never returned by bsdf_eval or
//     bsdf_pdf (both give 0). For a delta sample, BsdfSample.pdf is the discrete probability
//     of the chosen lobe (1 for a mirror, F or 1 - F for glass), not a density; callers must
//     not use it for MIS (is_delta tells them so).
//
// Feature defines (code for absent materials is not compiled; diffuse always is):
//   HAS_CONDUCTOR          smooth conductors (mirror with exact or Schlick Fresnel)
//   HAS_ROUGH_CONDUCTOR    GGX rough conductors; implies HAS_CONDUCTOR
//   HAS_DIELECTRIC         smooth glass
//   HAS_ROUGH_DIELECTRIC   GGX rough glass (Walter et al. 2007); implies HAS_DIELECTRIC
//   HAS_PLASTIC            a diffuse base under a smooth dielectric coat
//   HAS_ROUGH_PLASTIC      ... under a GGX-rough coat; implies HAS_PLASTIC
//   HAS_BECKMANN           rough conductors with a Beckmann distribution (emission_alpha.w < 0)
// A material whose code is not compiled reflects nothing (bsdf_sample returns false).
//
// Material fields used (lift/scene_data.glsl): color_type.rgb = diffuse albedo / Schlick F0 /
// transmission tint / tint of a conductor given by eta and k, color_type.w = MAT_*;
// emission_alpha.w = GGX alpha (0 = smooth; a rough lobe uses max(alpha, BSDF_MIN_ALPHA));
// eta_ior.rgb, k_pad.rgb = conductor complex index (eta.r < 0: Schlick with F0 = colour);
// eta_ior.w = dielectric index of refraction (inside over outside; the normal points
// outside). Plastic: see its section. A material's textures are applied before these
// functions see it (material_at in lift/textures.glsl).
#ifndef LIFT_BSDF_GLSL
#define LIFT_BSDF_GLSL

#if defined(HAS_ROUGH_CONDUCTOR) && !defined(HAS_CONDUCTOR)
#define HAS_CONDUCTOR
#endif
#if defined(HAS_ROUGH_DIELECTRIC) && !defined(HAS_DIELECTRIC)
#define HAS_DIELECTRIC
#endif
#if defined(HAS_ROUGH_PLASTIC) && !defined(HAS_PLASTIC)
#define HAS_PLASTIC
#endif

// Included whatever the defines: the assembler inlines an #include once, even inside an
// inactive #if, so a conditional include here would hide these files from a later include.
// Functions nobody calls cost nothing; the material code below is what the defines remove.
#include "lift/scene_data.glsl"
#include "lift/sampling.glsl"
#include "lift/fresnel.glsl"
#include "lift/microfacet.glsl"

// The least alpha a rough lobe is evaluated with (max(alpha, BSDF_MIN_ALPHA)): it keeps the
// peak of D, 1 / (pi alpha^2), finite.
#define BSDF_MIN_ALPHA 1e-4

// A direction bsdf_sample chose, with what a path needs to follow it.
struct BsdfSample {
    vec3 wi;        // sampled direction (shading frame, away from the surface)
    vec3 weight;    // f(wo, wi) |wi.z| / pdf, delta lobes included
    float pdf;      // solid-angle density; for a delta lobe, the discrete lobe probability
    bool is_delta;  // true for specular samples: no MIS, no light sampling
};

// The material's type: MAT_DIFFUSE, MAT_CONDUCTOR, MAT_DIELECTRIC or MAT_PLASTIC.
int bsdf_type(Material m) { return int(m.color_type.w + 0.5); }
// The roughness alpha of the material's microfacet lobe (0: smooth). A negative stored alpha
// marks a Beckmann conductor (HAS_BECKMANN, bsdf_beckmann); every other lobe is GGX.
float bsdf_alpha(Material m) { return abs(m.emission_alpha.w); }
// Whether a conductor's rough lobe is Beckmann's (a negative stored alpha) rather than GGX.
bool bsdf_beckmann(Material m) { return m.emission_alpha.w < 0.0; }

// An interface between equal indices (IOR within 1e-3 of 1) bends nothing and reflects
// (almost) nothing, rough or not: it is a delta transmission, and the rough BTDF, whose
// half vector and refraction Jacobian degenerate there, is never used for it.
bool dielectric_index_matched(Material m) { return abs(m.eta_ior.w - 1.0) < 1e-3; }

// The rough GGX lobe of a conductor or dielectric (alpha > 0, and not index-matched glass).
bool bsdf_is_rough(Material m) {
    return bsdf_alpha(m) > 0.0 && !(bsdf_type(m) == MAT_DIELECTRIC && dielectric_index_matched(m));
}

// Whether every direction the material scatters into is a delta (a mirror, smooth glass):
// then bsdf_eval and bsdf_pdf are 0 everywhere, light sampling cannot help and a path
// continues only by bsdf_sample.
bool bsdf_is_delta(Material m) {
    int type = bsdf_type(m);
    return (type == MAT_CONDUCTOR || type == MAT_DIELECTRIC) && !bsdf_is_rough(m);
}

// Mirror direction about the normal of the shading frame.
vec3 bsdf_reflect_z(vec3 wo) { return vec3(-wo.x, -wo.y, wo.z); }

// ================================ Diffuse (Lambert) ==================================
// Lambert: f cos_i = albedo / pi * wi.z, zero unless wo and wi are both above the surface.
vec3 diffuse_eval(Material m, vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    return m.color_type.rgb * (LIFT_INV_PI * wi.z);
}

// The density of diffuse_sample's direction: cosine-weighted, wi.z / pi.
float diffuse_pdf(vec3 wo, vec3 wi) {
    if (wo.z <= 0.0 || wi.z <= 0.0) return 0.0;
    return pdf_cosine_hemisphere(wi);
}

// A cosine-weighted direction; its weight f cos / pdf is the albedo.
bool diffuse_sample(Material m, vec3 wo, vec2 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    if (wo.z <= 0.0) return false;
    vec3 wi = sample_cosine_hemisphere(u);
    if (wi.z <= 0.0) return false;
    s.wi = wi;
    s.pdf = pdf_cosine_hemisphere(wi);
    s.weight = m.color_type.rgb;  // (albedo / pi) cos / (cos / pi)
    return true;
}

// ================================ Conductor ==========================================
#ifdef HAS_CONDUCTOR
// The conductor's reflectance at cos_theta: exact from eta and k (tinted by color_type.rgb),
// or Schlick's with F0 = color_type.rgb where eta.r < 0.
vec3 conductor_fresnel(Material m, float cos_theta) {
    if (m.eta_ior.r < 0.0) return fresnel_schlick(cos_theta, m.color_type.rgb);
    return m.color_type.rgb * fresnel_conductor(cos_theta, m.eta_ior.rgb, m.k_pad.rgb);
}

// ---- Smooth conductor: a mirror ----
// The mirror direction, weighted by the Fresnel reflectance (a delta: pdf 1).
bool conductor_smooth_sample(Material m, vec3 wo, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, true);
    if (wo.z <= 0.0) return false;
    s.wi = bsdf_reflect_z(wo);
    s.weight = conductor_fresnel(m, wo.z);
    s.pdf = 1.0;
    return true;
}

#ifdef HAS_ROUGH_CONDUCTOR
#ifdef HAS_BECKMANN
// ---- Rough conductor, Beckmann: the same BRDF with Beckmann's D and G; normals sampled
// by D(m) cos(m), so pdf(wi) = D(h) h.z / (4 wo.h) ----
// f cos_i of the Beckmann conductor.
vec3 conductor_beckmann_eval(Material m, vec3 wo, vec3 wi) {
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    vec3 h = normalize(wo + wi);
    return conductor_fresnel(m, dot(wo, h)) * (beckmann_D(h, alpha) * beckmann_G2(wo, wi, alpha) / (4.0 * wo.z));
}

// The density of conductor_beckmann_sample's direction.
float conductor_beckmann_pdf(Material m, vec3 wo, vec3 wi) {
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    vec3 h = normalize(wo + wi);
    float wo_h = dot(wo, h);
    return wo_h > 0.0 ? beckmann_D(h, alpha) * h.z / (4.0 * wo_h) : 0.0;
}

// A direction reflected about a Beckmann-distributed microfacet normal.
bool conductor_beckmann_sample(Material m, vec3 wo, vec2 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    vec3 h = beckmann_sample(alpha, u);
    float wo_h = dot(wo, h);
    if (wo_h <= 0.0) return false;  // a back-facing microfacet: no sample
    vec3 wi = 2.0 * wo_h * h - wo;
    if (wi.z <= 0.0) return false;
    s.wi = wi;
    s.pdf = conductor_beckmann_pdf(m, wo, wi);
    if (!(s.pdf > 0.0) || isinf(s.pdf)) return false;
    // f cos / pdf = F G2 wo.h / (cos_o h.z): D and the Jacobians cancel.
    s.weight = conductor_fresnel(m, wo_h) * (beckmann_G2(wo, wi, alpha) * wo_h / (wo.z * h.z));
    return true;
}
#endif

// ---- Rough conductor: GGX microfacet BRDF, f = D G2 F / (4 cos_o cos_i) ----
// f cos_i, and in `pdf` the density of conductor_rough_sample's direction.
vec3 conductor_rough_eval_pdf(Material m, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
#ifdef HAS_BECKMANN
    if (bsdf_beckmann(m)) {
        pdf = conductor_beckmann_pdf(m, wo, wi);
        return conductor_beckmann_eval(m, wo, wi);
    }
#endif
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    vec3 h = normalize(wo + wi);
    float D = ggx_D(h, alpha);
    // Visible-normal density times the reflection Jacobian 1 / (4 wo.h); wo.h cancels.
    pdf = ggx_G1(wo, alpha) * D / (4.0 * wo.z);
    // f cos_i: the cos_i of the BRDF's denominator cancels.
    return conductor_fresnel(m, dot(wo, h)) * (D * ggx_G2(wo, wi, alpha) / (4.0 * wo.z));
}

// f cos_i of the rough conductor (GGX, or Beckmann where bsdf_beckmann).
vec3 conductor_rough_eval(Material m, vec3 wo, vec3 wi) {
    float pdf;
    return conductor_rough_eval_pdf(m, wo, wi, pdf);
}

// The density of conductor_rough_sample's direction.
float conductor_rough_pdf(Material m, vec3 wo, vec3 wi) {
    float pdf;
    conductor_rough_eval_pdf(m, wo, wi, pdf);
    return pdf;
}

// A direction reflected about a visible GGX normal (Heitz 2018); weight F G2 / G1(wo).
bool conductor_rough_sample(Material m, vec3 wo, vec2 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    if (wo.z <= 0.0) return false;
#ifdef HAS_BECKMANN
    if (bsdf_beckmann(m)) return conductor_beckmann_sample(m, wo, u, s);
#endif
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    vec3 h = ggx_sample_visible(wo, alpha, u);
    float wo_h = dot(wo, h);
    if (wo_h <= 0.0) return false;
    vec3 wi = 2.0 * wo_h * h - wo;
    if (wi.z <= 0.0) return false;  // reflected below the horizon: masked, no sample
    float pdf = ggx_G1(wo, alpha) * ggx_D(h, alpha) / (4.0 * wo.z);
    if (!(pdf > 0.0) || isinf(pdf)) return false;
    float g1 = ggx_G1(wo, alpha);
    if (!(g1 > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf;
    // f cos / pdf = F G2 / G1(wo): D and the Jacobians cancel.
    s.weight = conductor_fresnel(m, wo_h) * (ggx_G2(wo, wi, alpha) / g1);
    return true;
}
#endif  // HAS_ROUGH_CONDUCTOR
#endif  // HAS_CONDUCTOR

// ================================ Dielectric =========================================
#ifdef HAS_DIELECTRIC
// etap = n(side of wi) / n(side of wo) for a transmitted direction: ior from outside.
float dielectric_etap(Material m, vec3 wo) { return wo.z > 0.0 ? m.eta_ior.w : 1.0 / m.eta_ior.w; }

// ---- Smooth dielectric: Fresnel-weighted choice between mirror and refraction ----
// Reflection with probability F (the Fresnel reflectance), else refraction; both deltas,
// with s.pdf the probability of the choice. A refracted weight carries the tint and the
// radiance scaling 1 / etap^2.
bool dielectric_smooth_sample(Material m, vec3 wo, float u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, true);
    if (wo.z == 0.0) return false;
    float ior = m.eta_ior.w;
    float F = fresnel_dielectric(wo.z, ior);
    if (u < F) {
        s.wi = bsdf_reflect_z(wo);
        s.weight = vec3(1.0);  // F / F
        s.pdf = F;
        return true;
    }
    float etap = dielectric_etap(m, wo);
    float cos_o = abs(wo.z);
    float sin2_t = max(0.0, 1.0 - cos_o * cos_o) / (etap * etap);
    if (sin2_t >= 1.0) return false;  // unreachable: F = 1 under total internal reflection
    float cos_t = sqrt(1.0 - sin2_t);
    s.wi = normalize(vec3(-wo.xy / etap, wo.z > 0.0 ? -cos_t : cos_t));
    s.weight = m.color_type.rgb / (etap * etap);  // (1 - F) / (1 - F), radiance scaling
    s.pdf = 1.0 - F;
    return true;
}

#ifdef HAS_ROUGH_DIELECTRIC
// ---- Rough dielectric: GGX BRDF + BTDF (Walter et al. 2007), VNDF sampling from wo's side ----
// Shared by eval and pdf: the microfacet normal (upper hemisphere) that maps wo to wi, or
// false if none does (a back-facing microfacet, a grazing direction).
bool dielectric_rough_half(Material m, vec3 wo, vec3 wi, out vec3 h, out bool is_reflection, out float etap) {
    h = vec3(0.0, 0.0, 1.0);
    is_reflection = wo.z * wi.z > 0.0;
    etap = 1.0;
    if (wo.z == 0.0 || wi.z == 0.0) return false;
    if (!is_reflection) etap = dielectric_etap(m, wo);
    // Generalised half vector: n_wi wi + n_wo wo (wo + wi for reflection).
    vec3 hv = wi * etap + wo;
    float len2 = dot(hv, hv);
    if (!(len2 > 0.0)) return false;
    h = hv * inversesqrt(len2);
    if (h.z < 0.0) h = -h;
    // Both directions must see the microfacet from the side their macro hemisphere sees.
    if (dot(h, wi) * wi.z <= 0.0 || dot(h, wo) * wo.z <= 0.0) return false;
    return true;
}

// f cos_i of the rough dielectric: reflection where wo and wi are on one side, transmission
// (tinted, radiance scaled by 1 / etap^2) where they are on opposite sides.
vec3 dielectric_rough_eval(Material m, vec3 wo, vec3 wi) {
    vec3 h;
    bool is_reflection;
    float etap;
    if (!dielectric_rough_half(m, wo, wi, h, is_reflection, etap)) return vec3(0.0);
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    float D = ggx_D(h, alpha);
    float G = ggx_G2(wo, wi, alpha);
    float wo_h = dot(wo, h);
    float F = fresnel_dielectric(wo_h, m.eta_ior.w);
    if (is_reflection) {
        // D G F / (4 |cos_o| |cos_i|) * |cos_i|
        return vec3(D * G * F / (4.0 * abs(wo.z)));
    }
    float wi_h = dot(wi, h);
    float denom = wi_h + wo_h / etap;
    denom = denom * denom * abs(wo.z);
    if (!(denom > 0.0)) return vec3(0.0);
    // D G (1 - F) |wi.h| |wo.h| / ((wi.h + wo.h / etap)^2 |cos_o| |cos_i|) * |cos_i| / etap^2
    float ft = D * G * (1.0 - F) * abs(wi_h * wo_h) / denom / (etap * etap);
    return m.color_type.rgb * ft;
}

// The density of dielectric_rough_sample's direction.
float dielectric_rough_pdf(Material m, vec3 wo, vec3 wi) {
    vec3 h;
    bool is_reflection;
    float etap;
    if (!dielectric_rough_half(m, wo, wi, h, is_reflection, etap)) return 0.0;
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    vec3 wo_up = wo.z > 0.0 ? wo : -wo;  // VNDF is sampled from wo's side
    float pdf_h = ggx_pdf_visible(wo_up, h, alpha);
    float wo_h = dot(wo, h);
    float F = fresnel_dielectric(wo_h, m.eta_ior.w);
    if (is_reflection) {
        return pdf_h * F / (4.0 * abs(wo_h));
    }
    float wi_h = dot(wi, h);
    float denom = wi_h + wo_h / etap;
    denom = denom * denom;
    if (!(denom > 0.0)) return 0.0;
    return pdf_h * (1.0 - F) * abs(wi_h) / denom;  // times the refraction Jacobian dh/dwi
}

// A visible GGX normal from wo's side (u.xy), then reflection or refraction about it chosen
// by its Fresnel reflectance (u.z).
bool dielectric_rough_sample(Material m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    if (wo.z == 0.0) return false;
    float alpha = max(bsdf_alpha(m), BSDF_MIN_ALPHA);
    float ior = m.eta_ior.w;
    vec3 wo_up = wo.z > 0.0 ? wo : -wo;
    vec3 h = ggx_sample_visible(wo_up, alpha, u.xy);
    float wo_h = dot(wo, h);  // same sign as wo.z for a visible normal
    if (wo_h * wo.z <= 0.0) return false;
    float F = fresnel_dielectric(wo_h, ior);
    float g1 = ggx_G1(wo, alpha);
    float pdf_h = ggx_pdf_visible(wo_up, h, alpha);
    if (!(g1 > 0.0) || !(pdf_h > 0.0) || isinf(pdf_h)) return false;
    if (u.z < F) {
        // ---- Reflection off the microfacet ----
        vec3 wi = 2.0 * wo_h * h - wo;
        if (wi.z * wo.z <= 0.0) return false;
        s.wi = wi;
        s.pdf = pdf_h * F / (4.0 * abs(wo_h));
        s.weight = vec3(ggx_G2(wo, wi, alpha) / g1);  // F G2 / (F G1)
        return true;
    }
    // ---- Refraction through the microfacet ----
    float etap = dielectric_etap(m, wo);
    float c = abs(wo_h);
    float sin2_t = max(0.0, 1.0 - c * c) / (etap * etap);
    if (sin2_t >= 1.0) return false;  // unreachable: F = 1 under total internal reflection
    float cos_t = sqrt(1.0 - sin2_t);
    vec3 hs = wo_h > 0.0 ? h : -h;  // microfacet normal on wo's side
    vec3 wi = normalize(-wo / etap + (c / etap - cos_t) * hs);
    if (wi.z * wo.z >= 0.0) return false;  // refracted into wo's hemisphere: masked
    float wi_h = dot(wi, h);
    float denom = wi_h + wo_h / etap;
    denom = denom * denom;
    if (!(denom > 0.0)) return false;
    s.wi = wi;
    s.pdf = pdf_h * (1.0 - F) * abs(wi_h) / denom;
    if (!(s.pdf > 0.0) || isinf(s.pdf)) return false;
    s.weight = m.color_type.rgb * (ggx_G2(wo, wi, alpha) / g1 / (etap * etap));
    return true;
}
#endif  // HAS_ROUGH_DIELECTRIC
#endif  // HAS_DIELECTRIC


// ================================ Plastic ============================================
#ifdef HAS_PLASTIC
// A diffuse base of albedo Rd under a dielectric coat of index ior (Mitsuba's plastic and
// roughplastic; pbrt's substrate is imported as this). Fields: color_type.rgb = Rd;
// eta_ior.w = ior; eta_ior.x = Fdr, the fraction of diffuse light inside the coat that the
// coat reflects back down (computed by the host: lift_gl/scene/optics.py); eta_ior.y = 1
// for "nonlinear"; k_pad.rgb = specular tint; emission_alpha.w = GGX alpha (0: smooth).
//
//   f = tint F(wo.h) D G2 / (4 cos_o cos_i)              specular (smooth coat: a mirror
//                                                          of weight tint F(cos_o), a delta)
//     + (1 - F(cos_o)) (1 - F(cos_i)) / ior^2 Rd' / pi   diffuse, light crossing the coat twice
//   Rd' = Rd / (1 - Fdr), or Rd / (1 - Rd Fdr) with nonlinear (inter-reflections under the
//   coat darken and saturate the base).
// With Rd = 1 the smooth coat conserves energy exactly: the integral of
// (1 - F(cos_i)) cos_i / pi over the hemisphere is ior^2 (1 - Fdr). For the rough coat the
// transmittance through the coat is approximated by the smooth one's (Mitsuba tabulates the
// rough one): at grazing angles the rough coat reflects less than F(cos_o), so energy is
// lost there (a white base, alpha 0.3, cos_o 0.1: albedo 0.58), and near normal incidence
// slightly more (a gain below 4e-4, tests/test_plastic_bsdf.py).
// Sampling: the specular lobe with probability P = clamp(F(cos_o) s / (F(cos_o) s +
// (1 - F(cos_o)) d), 0.1, 0.9) (s, d: mean tint and albedo), else a cosine-weighted
// direction. For the smooth coat bsdf_eval and bsdf_pdf cover the diffuse part only, and a
// mirror sample is a delta with BsdfSample.pdf = P.

// The base's albedo under the coat: Rd' (see above).
vec3 plastic_base_albedo(Material m) {
    vec3 rd = m.color_type.rgb;
    float fdr = m.eta_ior.x;
    return m.eta_ior.y > 0.5 ? rd / max(vec3(1.0) - rd * fdr, vec3(1e-6)) : rd / max(1.0 - fdr, 1e-6);
}

// The probability P of sampling the coat's specular lobe, given F(cos_o) = F_o.
float plastic_specular_probability(Material m, float F_o) {
    float s = F_o * dot(m.k_pad.rgb, vec3(1.0 / 3.0));
    float d = (1.0 - F_o) * dot(m.color_type.rgb, vec3(1.0 / 3.0));
    return clamp(s / max(s + d, 1e-12), 0.1, 0.9);
}

#ifdef HAS_ROUGH_PLASTIC
// The specular part of the rough coat, times cos_i, and in `pdf` the density of its VNDF sampling.
vec3 plastic_specular_eval_pdf(Material m, vec3 wo, vec3 wi, float alpha, out float pdf) {
    vec3 h = normalize(wo + wi);
    float D = ggx_D(h, alpha);
    pdf = ggx_G1(wo, alpha) * D / (4.0 * wo.z);
    float F = fresnel_dielectric(dot(wo, h), m.eta_ior.w);
    return m.k_pad.rgb * (F * D * ggx_G2(wo, wi, alpha) / (4.0 * wo.z));
}
#endif

// f cos_i, and in `pdf` the density of plastic_sample's direction (both lobes).
vec3 plastic_eval_pdf(Material m, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    float ior = m.eta_ior.w;
    float F_o = fresnel_dielectric(wo.z, ior);
    // The diffuse part
    float t = (1.0 - F_o) * (1.0 - fresnel_dielectric(wi.z, ior)) / (ior * ior);
    vec3 f = plastic_base_albedo(m) * (t * LIFT_INV_PI * wi.z);
    float P = plastic_specular_probability(m, F_o);
    pdf = (1.0 - P) * pdf_cosine_hemisphere(wi);
#ifdef HAS_ROUGH_PLASTIC
    if (bsdf_alpha(m) > 0.0) {
        float specular_pdf;
        f += plastic_specular_eval_pdf(m, wo, wi, max(bsdf_alpha(m), BSDF_MIN_ALPHA), specular_pdf);
        pdf += P * specular_pdf;
    }
#endif
    return f;
}

// f cos_i of the plastic (the smooth coat's mirror, a delta, left out).
vec3 plastic_eval(Material m, vec3 wo, vec3 wi) {
    float pdf;
    return plastic_eval_pdf(m, wo, wi, pdf);
}

// The density of plastic_sample's direction (the smooth coat's mirror left out).
float plastic_pdf(Material m, vec3 wo, vec3 wi) {
    float pdf;
    plastic_eval_pdf(m, wo, wi, pdf);
    return pdf;
}

// The specular lobe with probability P (u.z), else a cosine-weighted direction (u.xy).
bool plastic_sample(Material m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    if (wo.z <= 0.0) return false;
    float F_o = fresnel_dielectric(wo.z, m.eta_ior.w);
    float P = plastic_specular_probability(m, F_o);
    float alpha = bsdf_alpha(m);
    vec3 wi;
    if (u.z < P) {
        // ---- Specular: reflection off the coat ----
        if (alpha <= 0.0) {
            s.wi = bsdf_reflect_z(wo);
            s.weight = m.k_pad.rgb * (F_o / P);
            s.pdf = P;
            s.is_delta = true;
            return true;
        }
#ifdef HAS_ROUGH_PLASTIC
        vec3 h = ggx_sample_visible(wo, max(alpha, BSDF_MIN_ALPHA), u.xy);
        float wo_h = dot(wo, h);
        if (wo_h <= 0.0) return false;
        wi = 2.0 * wo_h * h - wo;
#else
        return false;  // a rough coat that this shader was not built for
#endif
    } else {
        // ---- Diffuse: the base, seen through the coat ----
        wi = sample_cosine_hemisphere(u.xy);
    }
    if (wi.z <= 0.0) return false;
    s.wi = wi;
    vec3 f = plastic_eval_pdf(m, wo, wi, s.pdf);
    if (!(s.pdf > 0.0)) return false;
    s.weight = f / s.pdf;  // one-sample MIS over the two lobes
    return true;
}
#endif  // HAS_PLASTIC

// ================================ Dispatch ===========================================
// bsdf_eval and bsdf_pdf of one pair of directions in one call, for next event estimation,
// which needs both: one dispatch on the material's type, and what the two share (the half
// vector, D, the Fresnel terms) computed once. The same values as the two calls
// (tests/test_bsdf_eval_pdf.py).
vec3 bsdf_eval_pdf(Material m, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    int type = bsdf_type(m);
    if (type == MAT_DIFFUSE) {
        pdf = diffuse_pdf(wo, wi);
        return diffuse_eval(m, wo, wi);
    }
#ifdef HAS_ROUGH_CONDUCTOR
    if (type == MAT_CONDUCTOR && bsdf_alpha(m) > 0.0) return conductor_rough_eval_pdf(m, wo, wi, pdf);
#endif
#ifdef HAS_ROUGH_DIELECTRIC
    if (type == MAT_DIELECTRIC && bsdf_is_rough(m)) {
        pdf = dielectric_rough_pdf(m, wo, wi);
        return dielectric_rough_eval(m, wo, wi);
    }
#endif
#ifdef HAS_PLASTIC
    if (type == MAT_PLASTIC) return plastic_eval_pdf(m, wo, wi, pdf);
#endif
    return vec3(0.0);  // delta lobes, or a material not compiled in
}

// The BSDF times the cosine at wi: f(wo, wi) |wi.z| (shading frame; wo, wi unit and away
// from the surface). Zero for delta lobes (mirrors, smooth glass), which only bsdf_sample
// can produce.
vec3 bsdf_eval(Material m, vec3 wo, vec3 wi) {
    int type = bsdf_type(m);
    if (type == MAT_DIFFUSE) return diffuse_eval(m, wo, wi);
#ifdef HAS_ROUGH_CONDUCTOR
    if (type == MAT_CONDUCTOR && bsdf_alpha(m) > 0.0) return conductor_rough_eval(m, wo, wi);
#endif
#ifdef HAS_ROUGH_DIELECTRIC
    if (type == MAT_DIELECTRIC && bsdf_is_rough(m)) return dielectric_rough_eval(m, wo, wi);
#endif
#ifdef HAS_PLASTIC
    if (type == MAT_PLASTIC) return plastic_eval(m, wo, wi);
#endif
    return vec3(0.0);  // delta lobes, or a material not compiled in
}

// The solid-angle density with which bsdf_sample(m, wo, ...) returns wi (delta lobes: 0).
// MIS weighs a light sample's direction with it.
float bsdf_pdf(Material m, vec3 wo, vec3 wi) {
    int type = bsdf_type(m);
    if (type == MAT_DIFFUSE) return diffuse_pdf(wo, wi);
#ifdef HAS_ROUGH_CONDUCTOR
    if (type == MAT_CONDUCTOR && bsdf_alpha(m) > 0.0) return conductor_rough_pdf(m, wo, wi);
#endif
#ifdef HAS_ROUGH_DIELECTRIC
    if (type == MAT_DIELECTRIC && bsdf_is_rough(m)) return dielectric_rough_pdf(m, wo, wi);
#endif
#ifdef HAS_PLASTIC
    if (type == MAT_PLASTIC) return plastic_pdf(m, wo, wi);
#endif
    return 0.0;
}

// Samples a direction s.wi for wo (shading frame) from three uniform numbers u (one picks a
// lobe where there are several). s.weight = f cos / pdf, the factor a path's throughput
// takes; s.pdf and s.is_delta are for MIS. False (and s zeroed) when there is no sample:
// wo below an opaque surface, a direction below the horizon, a material not compiled in.
bool bsdf_sample(Material m, vec3 wo, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    int type = bsdf_type(m);
    bool ok = false;
    if (type == MAT_DIFFUSE) {
        ok = diffuse_sample(m, wo, u.xy, s);
    }
#ifdef HAS_CONDUCTOR
    else if (type == MAT_CONDUCTOR) {
#ifdef HAS_ROUGH_CONDUCTOR
        if (bsdf_alpha(m) > 0.0) ok = conductor_rough_sample(m, wo, u.xy, s);
        else
#endif
        ok = conductor_smooth_sample(m, wo, s);
    }
#endif
#ifdef HAS_DIELECTRIC
    else if (type == MAT_DIELECTRIC) {
#ifdef HAS_ROUGH_DIELECTRIC
        if (bsdf_is_rough(m)) ok = dielectric_rough_sample(m, wo, u, s);
        else
#endif
        ok = dielectric_smooth_sample(m, wo, u.z, s);
    }
#endif
#ifdef HAS_PLASTIC
    else if (type == MAT_PLASTIC) {
        ok = plastic_sample(m, wo, u, s);
    }
#endif
    // The last guard: a sample with a non-finite or negative weight is dropped, not returned.
    if (ok && (any(isnan(s.weight)) || any(isinf(s.weight)) || any(lessThan(s.weight, vec3(0.0)))
               || isnan(s.pdf) || isinf(s.pdf) || !(s.pdf > 0.0))) ok = false;
    if (!ok) s = BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, false);
    return ok;
}

// etap^2 where wi refracts from wo through a dielectric (smooth or rough), else 1: the inverse
// of the radiance scale 1 / etap^2 that a transmission's weight and f carry. Russian roulette
// judges a path by its throughput times the product of these (the way out undoes the way in:
// pbrt's etaScale); importance, which refraction does not compress, is multiplied by it.
float refraction_eta2(Material m, vec3 wo, vec3 wi) {
#ifdef HAS_DIELECTRIC
    if (bsdf_type(m) == MAT_DIELECTRIC && wo.z * wi.z < 0.0) {
        float etap = dielectric_etap(m, wo);
        return etap * etap;
    }
#endif
    return 1.0;
}

// A colour for the G-buffer's albedo channel (the denoiser's guide): what the surface
// reflects at normal incidence.
vec3 bsdf_albedo(Material m) {
    int type = bsdf_type(m);
#ifdef HAS_CONDUCTOR
    if (type == MAT_CONDUCTOR) return conductor_fresnel(m, 1.0);
#endif
    return m.color_type.rgb;  // diffuse albedo (plastic: of its base); glass: its transmission tint
}

#endif
