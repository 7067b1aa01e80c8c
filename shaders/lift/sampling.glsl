// lift/sampling.glsl: warps from the unit square to common domains. Every sampler sits next
// to its pdf, named in pairs (sample_X / pdf_X); tests/test_bsdf_chi2.py checks the pairs.
#ifndef LIFT_SAMPLING_GLSL
#define LIFT_SAMPLING_GLSL

#ifndef LIFT_PI
#define LIFT_PI 3.14159265358979323846
#define LIFT_INV_PI 0.31830988618379067154
#define LIFT_INV_4PI 0.07957747154594766788
#endif

// ---- Unit disk (Shirley & Chiu concentric map: low distortion, keeps strata) ----
// A point uniform on the unit disk.
vec2 sample_concentric_disk(vec2 u) {
    vec2 p = 2.0 * u - 1.0;
    if (p.x == 0.0 && p.y == 0.0) return vec2(0.0);
    float r, phi;
    if (abs(p.x) > abs(p.y)) {
        r = p.x;
        phi = (LIFT_PI / 4.0) * (p.y / p.x);
    } else {
        r = p.y;
        phi = (LIFT_PI / 2.0) - (LIFT_PI / 4.0) * (p.x / p.y);
    }
    return r * vec2(cos(phi), sin(phi));
}
// Area density on the unit disk.
float pdf_concentric_disk() { return LIFT_INV_PI; }

// ---- Cosine-weighted hemisphere around +z (Malley: project the disk up) ----
// A unit direction about +z with density cos(theta) / pi.
vec3 sample_cosine_hemisphere(vec2 u) {
    vec2 d = sample_concentric_disk(u);
    float z = sqrt(max(0.0, 1.0 - dot(d, d)));
    return vec3(d, z);
}
// Solid-angle density; zero below the horizon.
float pdf_cosine_hemisphere(vec3 w) { return max(w.z, 0.0) * LIFT_INV_PI; }

// ---- Uniform sphere ----
// A unit direction uniform over the sphere.
vec3 sample_uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * LIFT_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}
// Solid-angle density: 1 / (4 pi).
float pdf_uniform_sphere(vec3 w) { return LIFT_INV_4PI; }

// ---- Uniform triangle ----
// Returns barycentrics (b1, b2) of corners 1 and 2; corner 0 gets b0 = 1 - b1 - b2, so the
// point is p0 * b0 + p1 * b1 + p2 * b2 (the same (u, v) a Moller-Trumbore hit reports).
vec2 sample_uniform_triangle(vec2 u) {
    float su = sqrt(u.x);
    return vec2(su * (1.0 - u.y), su * u.y);
}
// Area density: 1 / area (zero for a degenerate triangle rather than Inf).
float pdf_uniform_triangle(float area) { return area > 0.0 ? 1.0 / area : 0.0; }

// ---- Multiple importance sampling ----
// Power heuristic, beta = 2, one sample from each strategy: weight of strategy a.
// 0/0 (neither strategy can produce the sample) gives 0; an infinite pdf_a (a delta
// strategy) gives 1, an infinite pdf_b gives 0. Scaled by the larger pdf so that the squares
// cannot overflow.
float power_heuristic(float pdf_a, float pdf_b) {
    if (isinf(pdf_a)) return 1.0;
    if (isinf(pdf_b)) return 0.0;
    float m = max(pdf_a, pdf_b);
    if (!(m > 0.0)) return 0.0;
    float a = pdf_a / m;
    float b = pdf_b / m;
    return (a * a) / (a * a + b * b);
}

#endif
