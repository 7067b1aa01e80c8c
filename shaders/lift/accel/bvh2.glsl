// lift/accel/bvh2.glsl: the binary BVH's traversals (lift_gl/accel/bvh.py builds it; its layout
// is in lift/scene_data.glsl): what shaders with motion blur or traced instances use, and
// OpenCL plugins' tree. Internal to lift/trace.glsl.
#ifndef LIFT_ACCEL_BVH2_GLSL
#define LIFT_ACCEL_BVH2_GLSL
#include "lift/accel/slabs.glsl"
#include "lift/accel/stack.glsl"

// Closest triangle hit in the tree under node `root`: the world BVH (root 0), or with
// HAS_INSTANCES an instance's BLAS, the ray then in that instance's object space; updates t,
// prim and bary when it finds a hit nearer than t. While-while traversal (Aila and Laine
// 2009): an inner loop descends through interior nodes to the next leaf, whose triangles are
// then tested, so the lanes of a SIMD group that are between leaves step together. The stack
// holds node ids only: a popped node is not re-tested, its children are tested against the t
// found so far (entry distances on the stack doubled its size for little culling; docs/gpu.md).
bool lift_bvh_closest(uint root, Ray ray, inout float t, inout uint prim, inout vec2 bary_out) {
    bool found = false;
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint node = root;
    float troot;
    bool live = lift_bvh_box(root, ray.origin, inv, ray.tmin, t, troot);
    while (live) {
        uint first = floatBitsToUint(bvh_node_row(2u * node).w);
        uint count = floatBitsToUint(bvh_node_row(2u * node + 1u).w);
        while (count == 0u) {   // interior: go to the nearer child hit, postpone the other
            float ta, tb;
            bool ha = lift_bvh_box(first, ray.origin, inv, ray.tmin, t, ta);
            bool hb = lift_bvh_box(first + 1u, ray.origin, inv, ray.tmin, t, tb);
            if (ha && hb && sp < LIFT_BVH_STACK) {   // the bound holds by construction
                bool a_first = ta <= tb;
                LIFT_BVH_STACK_SET(sp, a_first ? first + 1u : first);
                ++sp;
                node = a_first ? first : first + 1u;
            } else if (ha || hb) {
                node = ha ? first : first + 1u;
            } else if (sp > 0) {
                { --sp; node = LIFT_BVH_STACK_GET(sp); }
            } else {
                live = false;
                break;
            }
            first = floatBitsToUint(bvh_node_row(2u * node).w);
            count = floatBitsToUint(bvh_node_row(2u * node + 1u).w);
        }
        for (uint i = first; i < first + count; ++i) {   // a leaf (count 0 when none was left)
            vec2 bary;
            if (lift_intersect_triangle(ray, shear, i, t, bary)) {
                prim = i;
                bary_out = bary;
                found = true;
            }
        }
        live = live && sp > 0;
        if (live) { --sp; node = LIFT_BVH_STACK_GET(sp); }
    }
    return found;
}

// Whether any triangle of the tree under `root` lies in (ray.tmin, t): stops at the first.
// The same while-while traversal as lift_bvh_closest.
bool lift_bvh_any(uint root, Ray ray, float t) {
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    float troot;
    if (!lift_bvh_box(root, ray.origin, inv, ray.tmin, t, troot)) return false;
    uint node = root;
    while (true) {
        uint first = floatBitsToUint(bvh_node_row(2u * node).w);
        uint count = floatBitsToUint(bvh_node_row(2u * node + 1u).w);
        while (count == 0u) {
            float ta, tb;
            bool ha = lift_bvh_box(first, ray.origin, inv, ray.tmin, t, ta);
            bool hb = lift_bvh_box(first + 1u, ray.origin, inv, ray.tmin, t, tb);
            if (ha && hb && sp < LIFT_BVH_STACK) {
                LIFT_BVH_STACK_SET(sp, first + 1u);
                ++sp;
                node = first;
            } else if (ha || hb) {
                node = ha ? first : first + 1u;
            } else if (sp > 0) {
                { --sp; node = LIFT_BVH_STACK_GET(sp); }
            } else {
                return false;
            }
            first = floatBitsToUint(bvh_node_row(2u * node).w);
            count = floatBitsToUint(bvh_node_row(2u * node + 1u).w);
        }
        for (uint i = first; i < first + count; ++i) {
            vec2 bary;
            if (lift_intersect_triangle(ray, shear, i, t, bary)) return true;
        }
        if (sp == 0) return false;
        { --sp; node = LIFT_BVH_STACK_GET(sp); }
    }
    return false;
}

#endif
