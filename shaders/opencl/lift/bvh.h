// lift/bvh.h: ray queries against the scene, the OpenCL twin of shaders/lift/bvh.glsl: the
// same BVH layout (built by lift_gl/accel/bvh.py), the same tests in the same order.
#ifndef LIFT_CL_BVH_H
#define LIFT_CL_BVH_H
#include "lift/scene.h"

typedef struct { float3 origin; float3 dir; float tmin; float tmax; } Ray;  // dir normalized
// prim: triangle id, or num_triangles + sphere index; NO_HIT when nothing was hit.
// bary = (b1, b2): p = (1-b1-b2)*p0 + b1*p1 + b2*p2.
typedef struct { float t; uint prim; float2 bary; } Hit;
#define NO_HIT 0xffffffffu

// The build limits the tree to 48 levels: at most one postponed sibling per level.
#define LIFT_BVH_STACK 48

Ray make_ray(float3 origin, float3 dir, float tmin, float tmax) {
    Ray r;
    r.origin = origin;
    r.dir = dir;
    r.tmin = tmin;
    r.tmax = tmax;
    return r;
}

// ---- Ray/triangle test: the watertight test of Woop, Benthin and Wald (JCGT 2013), as in
// shaders/lift/bvh.glsl (which says why), with the same arithmetic: the axes permuted so that
// z is the ray's largest, a shear that makes the ray run along +z from (0, 0), both folded
// into two rows per ray, and 2D edge functions U, V, W that two triangles sharing an edge
// compute as exact negations.

typedef struct {
    float3 row_x, row_y;  // frame x = dot(row_x, p - origin): the axis after the ray's largest, sheared
    float inv_dz;         // 1 / the direction's largest component
    int kz;               // the ray's largest axis
} LiftRayShear;

// v's axes in the frame's order (x, y, z), z the ray's largest axis; a cyclic permutation.
float3 lift_permute(float3 v, int kz) { return kz == 0 ? v.yzx : (kz == 1 ? v.zxy : v); }

LiftRayShear lift_ray_shear(float3 dir) {
    float3 a = fabs(dir);
    int kz = a.x >= a.y ? (a.x >= a.z ? 0 : 2) : (a.y >= a.z ? 1 : 2);
    float3 d = lift_permute(dir, kz);
    float inv_dz = 1.0f / d.z;
    float3 ez = (float3)(kz == 0 ? 1.0f : 0.0f, kz == 1 ? 1.0f : 0.0f, kz == 2 ? 1.0f : 0.0f);
    LiftRayShear sh;
    sh.row_x = ez.zxy - (d.x * inv_dz) * ez;
    sh.row_y = ez.yzx - (d.y * inv_dz) * ez;
    sh.inv_dz = inv_dz;
    sh.kz = kz;
    return sh;
}

float lift_shear(float3 p, float3 row) { return fma(p.z, row.z, fma(p.y, row.y, p.x * row.x)); }

// Updates t and returns true when the hit is in (ray.tmin, t); bary = (b1, b2), as in Hit.
bool lift_intersect_triangle(const Scene* scene, Ray ray, LiftRayShear sh, uint tri, float* t, float2* bary) {
    // no contraction into fused multiply-adds (OpenCL's default allows it): the edge
    // functions of a shared edge must stay exact negations
#pragma OPENCL FP_CONTRACT OFF
    *bary = (float2)(0.0f);
    uint i = 3u * tri;
    float3 a = scene->tri_pos[i].xyz - ray.origin;
    float3 b = scene->tri_pos[i + 1u].xyz - ray.origin;
    float3 c = scene->tri_pos[i + 2u].xyz - ray.origin;
    float ax = lift_shear(a, sh.row_x), ay = lift_shear(a, sh.row_y);
    float bx = lift_shear(b, sh.row_x), by = lift_shear(b, sh.row_y);
    float cx = lift_shear(c, sh.row_x), cy = lift_shear(c, sh.row_y);
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if (!((u >= 0.0f && v >= 0.0f && w >= 0.0f) || (u <= 0.0f && v <= 0.0f && w <= 0.0f))) return false;
    float det = u + v + w;
    if (det == 0.0f) return false;
    float inv_det = 1.0f / det;
    float th = (u * lift_permute(a, sh.kz).z + v * lift_permute(b, sh.kz).z + w * lift_permute(c, sh.kz).z)
               * sh.inv_dz * inv_det;
    if (!(th > ray.tmin && th < *t)) return false;  // a NaN th fails too
    *t = th;
    *bary = (float2)(v, w) * inv_det;
    return true;
}

// The test for one triangle (the host's gbuffer_hit, plugins), with its own ray shear.
bool intersect_triangle(const Scene* scene, Ray ray, uint tri, float* t, float2* bary) {
    return lift_intersect_triangle(scene, ray, lift_ray_shear(ray.dir), tri, t, bary);
}

// Both roots of |o + t d - c|^2 = r^2; the discriminant from the centre's distance to the line.
bool intersect_sphere(const Scene* scene, Ray ray, uint s, float* t) {
    float4 cr = scene->spheres[2u * s];
    float3 oc = ray.origin - cr.xyz;
    float b = dot(oc, ray.dir);
    float3 q = oc - b * ray.dir;
    float h = cr.w * cr.w - dot(q, q);
    if (h < 0.0f) return false;
    h = sqrt(h);
    float t0 = -b - h;
    float t1 = -b + h;
    if (t0 > ray.tmin && t0 < *t) { *t = t0; return true; }
    if (t1 > ray.tmin && t1 < *t) { *t = t1; return true; }
    return false;
}

// 1/dir with zero components replaced by a tiny value of the same sign (no 0 * inf = NaN).
float3 lift_bvh_inv_dir(float3 d) {
    float3 s = (float3)(d.x >= 0.0f ? 1.0f : -1.0f, d.y >= 0.0f ? 1.0f : -1.0f, d.z >= 0.0f ? 1.0f : -1.0f);
    return 1.0f / (s * fmax(fabs(d), (float3)(1e-30f)));
}

// Slab test of node n's box against (tmin, tmax), conservative; *tn: entry distance.
bool lift_bvh_box(const Scene* scene, uint n, float3 org, float3 inv, float tmin, float tmax, float* tn) {
    float3 t0 = (scene->bvh_nodes[2u * n].xyz - org) * inv;
    float3 t1 = (scene->bvh_nodes[2u * n + 1u].xyz - org) * inv;
    float3 lo = fmin(t0, t1);
    float3 hi = fmax(t0, t1);
    *tn = fmax(fmax(lo.x, lo.y), fmax(lo.z, tmin));
    // the exit enlarged by Ize's rounding bound, as in lift/bvh.glsl (which says why)
    float tf = fmin(fmin(hi.x, hi.y), fmin(hi.z, tmax)) * 1.0000004f;
    return *tn <= tf;
}

// Closest hit among triangles (BVH, nearer child first) and, with HAS_SPHERES, spheres.
bool trace_closest(const Scene* scene, Ray ray, Hit* hit) {
    hit->t = ray.tmax;
    hit->prim = NO_HIT;
    hit->bary = (float2)(0.0f);
    float t = ray.tmax;
#ifdef HAS_SPHERES
    for (uint s = 0u; s < scene->num_spheres; ++s) {
        if (intersect_sphere(scene, ray, s, &t)) hit->prim = scene->num_triangles + s;
    }
#endif
    if (scene->num_triangles > 0u) {
        float3 inv = lift_bvh_inv_dir(ray.dir);
        LiftRayShear shear = lift_ray_shear(ray.dir);
        uint stack_node[LIFT_BVH_STACK];
        float stack_t[LIFT_BVH_STACK];  // entry distance, to skip nodes behind a closer hit
        int sp = 0;
        uint node = 0u;
        float troot;
        bool live = lift_bvh_box(scene, 0u, ray.origin, inv, ray.tmin, t, &troot);
        while (live) {
            uint first = as_uint(scene->bvh_nodes[2u * node].w);
            uint count = as_uint(scene->bvh_nodes[2u * node + 1u].w);
            if (count > 0u) {
                for (uint i = first; i < first + count; ++i) {
                    float2 bary;
                    if (lift_intersect_triangle(scene, ray, shear, i, &t, &bary)) {
                        hit->prim = i;
                        hit->bary = bary;
                    }
                }
            } else {
                float ta, tb;
                bool ha = lift_bvh_box(scene, first, ray.origin, inv, ray.tmin, t, &ta);
                bool hb = lift_bvh_box(scene, first + 1u, ray.origin, inv, ray.tmin, t, &tb);
                if (ha && hb && sp < LIFT_BVH_STACK) {
                    bool a_first = ta <= tb;
                    stack_node[sp] = a_first ? first + 1u : first;
                    stack_t[sp] = a_first ? tb : ta;
                    ++sp;
                    node = a_first ? first : first + 1u;
                    continue;
                }
                if (ha || hb) {
                    node = ha ? first : first + 1u;
                    continue;
                }
            }
            // pop the next postponed node that may still hold something nearer than t
            live = false;
            while (sp > 0) {
                --sp;
                if (stack_t[sp] <= t) { node = stack_node[sp]; live = true; break; }
            }
        }
    }
    if (hit->prim != NO_HIT) {
        hit->t = t;
        if (hit->prim >= scene->num_triangles) hit->bary = (float2)(0.0f);
    }
    return hit->prim != NO_HIT;
}

// Whether anything lies in (ray.tmin, ray.tmax): stops at the first hit, in any order.
bool trace_occluded(const Scene* scene, Ray ray) {
    float t = ray.tmax;
#ifdef HAS_SPHERES
    for (uint s = 0u; s < scene->num_spheres; ++s) {
        if (intersect_sphere(scene, ray, s, &t)) return true;
    }
#endif
    if (scene->num_triangles == 0u) return false;
    float3 inv = lift_bvh_inv_dir(ray.dir);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    uint stack_node[LIFT_BVH_STACK];
    int sp = 0;
    float troot;
    if (!lift_bvh_box(scene, 0u, ray.origin, inv, ray.tmin, t, &troot)) return false;
    uint node = 0u;
    while (true) {
        uint first = as_uint(scene->bvh_nodes[2u * node].w);
        uint count = as_uint(scene->bvh_nodes[2u * node + 1u].w);
        if (count > 0u) {
            for (uint i = first; i < first + count; ++i) {
                float2 bary;
                if (lift_intersect_triangle(scene, ray, shear, i, &t, &bary)) return true;
            }
        } else {
            float ta, tb;
            bool ha = lift_bvh_box(scene, first, ray.origin, inv, ray.tmin, t, &ta);
            bool hb = lift_bvh_box(scene, first + 1u, ray.origin, inv, ray.tmin, t, &tb);
            if (ha && hb && sp < LIFT_BVH_STACK) {
                stack_node[sp++] = first + 1u;
                node = first;
                continue;
            }
            if (ha || hb) {
                node = ha ? first : first + 1u;
                continue;
            }
        }
        if (sp == 0) return false;
        node = stack_node[--sp];
    }
    return false;
}

#endif
