// lift/accel/instances.glsl: traced instances (HAS_INSTANCES): the TLAS over their world boxes,
// then each one's BLAS in the instance's object space (lift_gl/scene/instances.py has the
// records' layout). Internal to lift/trace.glsl (which declares instance_ray first).
#ifndef LIFT_ACCEL_INSTANCES_GLSL
#define LIFT_ACCEL_INSTANCES_GLSL
#include "lift/accel/slabs.glsl"
#include "lift/accel/stack.glsl"

// The ray goes into the instance's object space unnormalised: o' + t d' is the object-space
// image of o + t d, so t, tmin and the closest t so far keep their meaning in every BLAS.
// A TLAS node's box against (tmin, tmax); tn: the entry distance.
bool lift_tlas_box(uint n, vec3 org, vec3 inv, float tmin, float tmax, out float tn) {
    vec3 t0 = (instances[2u * n].xyz - org) * inv;
    vec3 t1 = (instances[2u * n + 1u].xyz - org) * inv;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    tn = max(max(lo.x, lo.y), max(lo.z, tmin));
    float tf = min(min(hi.x, hi.y), min(hi.z, tmax));
    return tn <= tf;
}

// The TLAS's nodes, nearer first; `shadow`: stop at the first hit (shadow rays).
bool lift_trace_instances(Ray ray, inout float t, inout Hit hit, bool shadow) {
    if (u_num_instances == 0u) return false;
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    uint stack_node[LIFT_BVH_STACK];
    float stack_t[LIFT_BVH_STACK];
    int sp = 0;
    uint node = 0u;
    float troot;
    bool found = false;
    bool live = lift_tlas_box(0u, ray.origin, inv, ray.tmin, t, troot);
    while (live) {
        uint first = floatBitsToUint(instances[2u * node].w);
        uint count = floatBitsToUint(instances[2u * node + 1u].w);
        if (count > 0u) {
            for (uint k = first; k < first + count; ++k) {
                Ray local = instance_ray(k, ray);
                uint root = instance_info(k).x;
                if (shadow) {
                    if (lift_bvh_any(root, local, t)) return true;
                } else if (lift_bvh_closest(root, local, t, hit.prim, hit.bary)) {
                    hit.instance = k;
                    found = true;
                }
            }
        } else {
            float ta, tb;
            bool ha = lift_tlas_box(first, ray.origin, inv, ray.tmin, t, ta);
            bool hb = lift_tlas_box(first + 1u, ray.origin, inv, ray.tmin, t, tb);
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
        live = false;
        while (sp > 0) {
            --sp;
            if (stack_t[sp] <= t) { node = stack_node[sp]; live = true; break; }
        }
    }
    return found;
}

#endif
