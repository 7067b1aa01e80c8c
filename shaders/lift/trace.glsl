// lift/trace.glsl: a plugin's rays against the scene: the closest hit, whether a shadow ray is
// blocked, and both at once.
//
// | name | what it gives |
// | --- | --- |
// | `Ray` | origin, unit direction `dir`, and the interval (`tmin`, `tmax`) a hit must lie in |
// | `Hit` | what a ray hit: distance `t`, primitive `prim` (`NO_HIT`: nothing), barycentrics `bary` |
// | `trace_closest(ray, hit)` | the closest hit in (`tmin`, `tmax`); false, and `hit.prim == NO_HIT`, when none |
// | `trace_occluded(ray)` | whether anything lies in (`tmin`, `tmax`), in any order: a shadow ray's answer |
// | `trace_shadow_and_next(...)` | a shadow ray's answer and the next ray's closest hit, in one call |
// | `intersect_triangle`, `intersect_sphere` | one primitive against a ray |
//
// Rays come from `camera_ray` (lift/camera.glsl) and, at a surface, `spawn_ray(s, dir)` and
// `spawn_shadow_ray(s, dir, dist)` (lift/surface.glsl), which start them off the surface; a hit
// becomes a shading point with `surface_at(ray, hit)`. A path vertex's light sample and bounce
// (plugins/pt/pt.glsl traces the two rays with one call):
//
//     LightSample ls;
//     if (sample_light(s.p, rng_next3(rng), ls) && !trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist)))
//         radiance += throughput * bsdf_eval(...) * ls.radiance / ls.pdf;
//     Hit hit;
//     if (!trace_closest(spawn_ray(s, wi), hit)) radiance += throughput * env_radiance(wi);
//
// Behind these calls are the acceleration structures, private to the library (lift/accel/: the
// BVH's layouts and traversals, chosen by the host for the device and the scene; docs/bvh.md,
// docs/gpu.md). A plugin calls this file's functions (lift/host.glsl includes it) and never
// lift/accel/. lift/bvh.glsl, this file's old name, includes it.
#ifndef LIFT_TRACE_GLSL
#define LIFT_TRACE_GLSL
#include "lift/scene_data.glsl"

// A ray: origin and unit direction dir (world space); it finds hits with t in (tmin, tmax).
// spawn_ray and camera_ray make them; trace_closest and trace_occluded query the scene.
struct Ray { vec3 origin; vec3 dir; float tmin; float tmax; };   // dir normalized
// What a ray hit: t, the distance along it (ray.dir is unit); prim, the triangle id (index
// into the reordered triangle arrays), or u_num_triangles + sphere index; NO_HIT when nothing
// was hit. bary = (b1, b2): p = (1-b1-b2)*p0 + b1*p1 + b2*p2.
// With HAS_INSTANCES, instance: the instance record whose BLAS holds triangle `prim`
// (NO_INSTANCE: world geometry); prim then indexes the BLAS's object-space triangles.
#ifdef HAS_INSTANCES
struct Hit { float t; uint prim; vec2 bary; uint instance; };
#else
struct Hit { float t; uint prim; vec2 bary; };
#endif
// Hit.prim of a ray that hit nothing (it left the scene: env_radiance(ray.dir)).
const uint NO_HIT = 0xffffffffu;

#ifdef HAS_MOTION
// The moment the current rays see, as a fraction of the shutter interval: 0 = open,
// 1 = close. One per invocation, like the ray it goes with: the host sets it for each camera
// sample (primary = "camera"); it stays 0, the G-buffer's moment, otherwise. Every query
// and surface lookup of this sample then sees the scene at that moment.
float g_ray_time = 0.0;
#endif

// Where primitive `prim` (a triangle id, or u_num_triangles + sphere index) has moved to
// from its stored position, at g_ray_time.
vec3 prim_displacement(uint prim) {
#ifdef HAS_MOTION
    return g_ray_time * motion[prim].xyz;
#else
    return vec3(0.0);
#endif
}

#include "lift/accel/stack.glsl"
#include "lift/accel/triangle.glsl"

// ---- One primitive ----
// The test for one triangle (lift/primary_hit.glsl, plugins), with its own ray shear.
bool intersect_triangle(Ray ray, uint tri, inout float t, out vec2 bary) {
    return lift_intersect_triangle(ray, lift_ray_shear(ray.dir), tri, t, bary);
}

// Both roots of |o + t d - c|^2 = r^2 (inside a sphere the far root is the hit).
// The discriminant is formed from the distance of the centre to the ray's line, which loses
// far less precision than b*b - c when the sphere is small and far away.
bool intersect_sphere(Ray ray, uint s, inout float t) {
    vec4 cr = spheres[2u * s];
    vec3 oc = ray.origin - (cr.xyz + prim_displacement(u_num_triangles + s));
    float b = dot(oc, ray.dir);
    vec3 q = oc - b * ray.dir;
    float h = cr.w * cr.w - dot(q, q);
    if (h < 0.0) return false;
    h = sqrt(h);
    float t0 = -b - h;
    float t1 = -b + h;
    if (t0 > ray.tmin && t0 < t) { t = t0; return true; }
    if (t1 > ray.tmin && t1 < t) { t = t1; return true; }
    return false;
}

#ifdef HAS_INSTANCES
// A world ray in instance k's object space (its direction not renormalised, so t is the same).
Ray instance_ray(uint k, Ray ray) {
    return Ray(instance_point_to_object(k, ray.origin), instance_dir_to_object(k, ray.dir), ray.tmin, ray.tmax);
}
#endif

// ---- The scene's acceleration structures (lift/accel/, as the host chose them) ----
#if defined(LIFT_BVH_WIDTH) && LIFT_BVH_WIDTH == 4
#include "lift/accel/bvh4.glsl"
#else
#include "lift/accel/bvh2.glsl"
#endif
#ifdef HAS_INSTANCES
#include "lift/accel/instances.glsl"
#endif

// ---- Tracing a ray through the scene ----
// The closest hit of `ray` in (ray.tmin, ray.tmax) among triangles (world BVH, then with
// HAS_INSTANCES the instances) and, with HAS_SPHERES, spheres. True when it hit something;
// else hit.prim = NO_HIT and hit.t = ray.tmax.
bool trace_closest(Ray ray, out Hit hit) {
    LIFT_COUNT_RAY();
    hit.t = ray.tmax;
    hit.prim = NO_HIT;
    hit.bary = vec2(0.0);
    float t = ray.tmax;
#ifdef HAS_SPHERES
    for (uint s = 0u; s < u_num_spheres; ++s) {
        if (intersect_sphere(ray, s, t)) hit.prim = u_num_triangles + s;
    }
#endif
#ifdef HAS_INSTANCES
    hit.instance = NO_INSTANCE;
    if (u_world_triangles > 0u) lift_bvh_closest(0u, ray, t, hit.prim, hit.bary);
    lift_trace_instances(ray, t, hit, false);
#else
    if (u_num_triangles > 0u) lift_bvh_closest(0u, ray, t, hit.prim, hit.bary);
#endif
    if (hit.prim != NO_HIT) {
        hit.t = t;
        if (hit.prim >= u_num_triangles) hit.bary = vec2(0.0);
    }
    return hit.prim != NO_HIT;
}

// Whether anything lies in (ray.tmin, ray.tmax): stops at the first hit, in any order. For
// shadow rays (spawn_shadow_ray): true means the light is blocked.
bool trace_occluded(Ray ray) {
    LIFT_COUNT_RAY();
    float t = ray.tmax;
#ifdef HAS_SPHERES
    for (uint s = 0u; s < u_num_spheres; ++s) {
        if (intersect_sphere(ray, s, t)) return true;
    }
#endif
#ifdef HAS_INSTANCES
    if (u_world_triangles > 0u && lift_bvh_any(0u, ray, t)) return true;
    Hit unused;
    return lift_trace_instances(ray, t, unused, true);
#else
    if (u_num_triangles == 0u) return false;
    return lift_bvh_any(0u, ray, t);
#endif
}

// trace_occluded(shadow) when shadow_wanted (else false), and trace_closest(next, hit) when
// next_wanted (else hit is NO_HIT): the same answers. With the 4-wide tree (LIFT_TRACE_PAIRED,
// set by the host) both rays go through one traversal loop, lift_bvh_shadow_then_closest:
// pt's path vertex traces its light sample's shadow ray and its next ray this way.
bool trace_shadow_and_next(bool shadow_wanted, Ray shadow, bool next_wanted, Ray next, out Hit hit) {
#if defined(LIFT_TRACE_PAIRED) && defined(LIFT_BVH_WIDTH) && LIFT_BVH_WIDTH == 4
    hit.t = next.tmax;
    hit.prim = NO_HIT;
    hit.bary = vec2(0.0);
    float t = next.tmax;
#ifdef HAS_SPHERES
    if (shadow_wanted) {
        float ts = shadow.tmax;
        bool blocked = false;
        for (uint s = 0u; s < u_num_spheres && !blocked; ++s) blocked = intersect_sphere(shadow, s, ts);
        if (blocked) {   // by a sphere: only the next ray traverses the tree
            LIFT_COUNT_RAY();
            if (next_wanted) trace_closest(next, hit);
            return true;
        }
    }
    if (next_wanted) {
        for (uint s = 0u; s < u_num_spheres; ++s) {
            if (intersect_sphere(next, s, t)) hit.prim = u_num_triangles + s;
        }
    }
#endif
    if (shadow_wanted) LIFT_COUNT_RAY();
    if (next_wanted) LIFT_COUNT_RAY();
    bool occluded = false;
    if (u_num_triangles > 0u) occluded = lift_bvh_shadow_then_closest(0u, shadow_wanted, shadow, next_wanted, next, t, hit.prim, hit.bary);
    if (hit.prim != NO_HIT) {
        hit.t = t;
        if (hit.prim >= u_num_triangles) hit.bary = vec2(0.0);
    }
    return occluded;
#else
    bool occluded = shadow_wanted && trace_occluded(shadow);
    if (next_wanted) {
        trace_closest(next, hit);
    } else {
        hit.t = next.tmax;
        hit.prim = NO_HIT;
        hit.bary = vec2(0.0);
#ifdef HAS_INSTANCES
        hit.instance = NO_INSTANCE;
#endif
    }
    return occluded;
#endif
}

#endif
