// lift/surface.h: from a hit to the surface it hit, and rays that leave it (the OpenCL twin
// of shaders/lift/surface.glsl).
#ifndef LIFT_CL_SURFACE_H
#define LIFT_CL_SURFACE_H
#include "lift/bvh.h"

typedef struct {
    float3 p;                // world position
    float3 ng;               // geometric normal, unit (triangles: from the winding; spheres: outward)
    float3 ns;               // shading normal, unit, in the same hemisphere as ng
    float2 uv;
    uint material;
    uint prim;
    float light_select_pdf;  // probability that light sampling picks this primitive (0: not a light)
    float area;              // primitive area
} Surface;

Surface surface_at(const Scene* scene, Ray ray, Hit hit) {
    Surface s;
    s.prim = hit.prim;
    if (hit.prim < scene->num_triangles) {
        uint i = 3u * hit.prim;
        float3 p0 = scene->tri_pos[i].xyz, p1 = scene->tri_pos[i + 1u].xyz, p2 = scene->tri_pos[i + 2u].xyz;
        float b0 = 1.0f - hit.bary.x - hit.bary.y;
        s.p = b0 * p0 + hit.bary.x * p1 + hit.bary.y * p2;
        float3 n = cross(p1 - p0, p2 - p0);
        float len = length(n);
        s.ng = len > 0.0f ? n / len : -ray.dir;
        s.area = 0.5f * len;
        float3 ns = b0 * scene->tri_normal[i].xyz + hit.bary.x * scene->tri_normal[i + 1u].xyz
                  + hit.bary.y * scene->tri_normal[i + 2u].xyz;
        float ns_len = length(ns);
        s.ns = ns_len > 0.0f ? ns / ns_len : s.ng;
        if (dot(s.ns, s.ng) < 0.0f) s.ns = -s.ns;
        s.uv = b0 * scene->tri_uv[i].xy + hit.bary.x * scene->tri_uv[i + 1u].xy + hit.bary.y * scene->tri_uv[i + 2u].xy;
        uint2 info = scene->tri_info[hit.prim];
        s.material = info.x;
        s.light_select_pdf = as_float(info.y);
    }
#ifdef HAS_SPHERES
    else {
        uint k = hit.prim - scene->num_triangles;
        float4 cr = scene->spheres[2u * k];
        float3 p = ray.origin + hit.t * ray.dir;
        s.ng = normalize(p - cr.xyz);
        s.p = cr.xyz + cr.w * s.ng;
        s.ns = s.ng;
        s.uv = (float2)(atan2(s.ng.z, s.ng.x) * 0.15915494f + 0.5f, acos(clamp(s.ng.y, -1.0f, 1.0f)) * 0.31830989f);
        s.material = as_uint(scene->spheres[2u * k + 1u].x);
        s.light_select_pdf = scene->spheres[2u * k + 1u].y;
        s.area = 4.0f * 3.14159265f * cr.w * cr.w;
    }
#endif
    return s;
}

// Move p off the surface along n by a few ulps of its own magnitude (Waechter and Binder 2019).
float3 offset_ray_origin(float3 p, float3 n) {
    const float near_origin = 1.0f / 32.0f;
    const float float_step = 1.0f / 65536.0f;
    const float int_step = 256.0f;
    int3 of = convert_int3(int_step * n);
    float3 p_int = (float3)(as_float(as_int(p.x) + (p.x < 0.0f ? -of.x : of.x)),
                            as_float(as_int(p.y) + (p.y < 0.0f ? -of.y : of.y)),
                            as_float(as_int(p.z) + (p.z < 0.0f ? -of.z : of.z)));
    return (float3)(fabs(p.x) < near_origin ? p.x + float_step * n.x : p_int.x,
                    fabs(p.y) < near_origin ? p.y + float_step * n.y : p_int.y,
                    fabs(p.z) < near_origin ? p.z + float_step * n.z : p_int.z);
}

// A ray leaving surface s in direction dir (world space), started on the side dir goes to.
Ray spawn_ray(Surface s, float3 dir) {
    float3 n = dot(dir, s.ng) >= 0.0f ? s.ng : -s.ng;
    return make_ray(offset_ray_origin(s.p, n), dir, 0.0f, 1e30f);
}

// A shadow ray from s towards a point at distance dist along dir; stops just short of it.
Ray spawn_shadow_ray(Surface s, float3 dir, float dist) {
    Ray r = spawn_ray(s, dir);
    r.tmax = dist * (1.0f - 1e-4f);
    return r;
}

// Radiance emitted by s towards direction w (world space); emitters emit from the front.
float3 surface_emission(const Scene* scene, Surface s, float3 w) {
    return dot(w, s.ng) > 0.0f ? scene->materials[s.material].emission_alpha.xyz : (float3)(0.0f);
}
#endif
