// lift/sampling.h: warps from the unit square, each next to its pdf (as shaders/lift/sampling.glsl),
// and the local shading frame (shaders/lift/frame.glsl). Float literals throughout: a double
// constant would make the arithmetic differ from the GLSL twin.
#ifndef LIFT_CL_SAMPLING_H
#define LIFT_CL_SAMPLING_H

#define LIFT_PI 3.14159265358979323846f
#define LIFT_INV_PI 0.31830988618379067154f
#define LIFT_INV_4PI 0.07957747154594766788f

// ---- Unit disk (Shirley & Chiu concentric map) ----
float2 sample_concentric_disk(float2 u) {
    float2 p = 2.0f * u - 1.0f;
    if (p.x == 0.0f && p.y == 0.0f) return (float2)(0.0f);
    float r, phi;
    if (fabs(p.x) > fabs(p.y)) {
        r = p.x;
        phi = (LIFT_PI / 4.0f) * (p.y / p.x);
    } else {
        r = p.y;
        phi = (LIFT_PI / 2.0f) - (LIFT_PI / 4.0f) * (p.x / p.y);
    }
    return r * (float2)(cos(phi), sin(phi));
}
float pdf_concentric_disk(void) { return LIFT_INV_PI; }

// ---- Cosine-weighted hemisphere around +z ----
float3 sample_cosine_hemisphere(float2 u) {
    float2 d = sample_concentric_disk(u);
    float z = sqrt(fmax(0.0f, 1.0f - dot(d, d)));
    return (float3)(d, z);
}
float pdf_cosine_hemisphere(float3 w) { return fmax(w.z, 0.0f) * LIFT_INV_PI; }

// ---- Uniform sphere ----
float3 sample_uniform_sphere(float2 u) {
    float z = 1.0f - 2.0f * u.x;
    float r = sqrt(fmax(0.0f, 1.0f - z * z));
    float phi = 2.0f * LIFT_PI * u.y;
    return (float3)(r * cos(phi), r * sin(phi), z);
}
float pdf_uniform_sphere(float3 w) { return LIFT_INV_4PI; }

// ---- Local shading frame: z is the normal (Duff et al. 2017) ----
typedef struct { float3 t; float3 b; float3 n; } Frame;

Frame frame_from_normal(float3 n) {
    float s = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (s + n.z);
    float b = n.x * n.y * a;
    Frame f;
    f.t = (float3)(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
    f.b = (float3)(b, s + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

float3 to_local(Frame f, float3 v) { return (float3)(dot(v, f.t), dot(v, f.b), dot(v, f.n)); }
float3 to_world(Frame f, float3 v) { return f.t * v.x + f.b * v.y + f.n * v.z; }

#endif
