// lift/accel/bvh4_children.glsl: the 4-wide traversals with a stack of child entries: a node's
// hit children but the nearest pushed, the farthest first. Internal to lift/trace.glsl
// (through accel/bvh4.glsl, which defines the node tests and loops used here).
#ifndef LIFT_ACCEL_BVH4_CHILDREN_GLSL
#define LIFT_ACCEL_BVH4_CHILDREN_GLSL

// The n hit children of node `cur` near to far: the nearest becomes cur, the others go on the
// stack, the farthest first (the collapse bounds the pushes of any root path by
// LIFT_BVH_STACK); and a pop. Macros: the stack may be a local array of the caller's.
#define LIFT_BVH4_VISIT_NEAR_FAR(hit, tn, e, n) { \
    uint e0 = e.x, e1 = e.y, e2 = e.z, e3 = e.w; \
    LIFT_BVH4_SORT(hit, tn, e0, e1, e2, e3) \
    if (n > 3u) { LIFT_BVH_STACK_SET(sp, e3); ++sp; } \
    if (n > 2u) { LIFT_BVH_STACK_SET(sp, e2); ++sp; } \
    if (n > 1u) { LIFT_BVH_STACK_SET(sp, e1); ++sp; } \
    cur = e0; }
#define LIFT_BVH4_POP(cur) { --sp; cur = LIFT_BVH_STACK_GET(sp); }

// Closest hit below the root, as lift_bvh_closest for the binary tree: while-while, an inner
// loop over wide nodes down to the next leaf entry. At each node the hit children are sorted
// near to far (a 5-exchange network); the nearest is visited next and the others pushed, the
// farthest first. Leaf entries go on the stack like nodes and are never fetched as nodes.
bool lift_bvh_closest(uint root, Ray ray, inout float t, inout uint prim, inout vec2 bary_out) {
    bool found = false;
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    uvec3 near = lift_bvh4_near_rows(inv);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint cur = root;
    bool live = true;
    while (live) {
        while ((cur & LIFT_BVH4_LEAF) == 0u) {   // a wide node: test its children
            vec4 tn;
            uvec4 e;
            bvec4 hit = lift_bvh4_children(cur, ray.origin, inv, near, ray.tmin, t, tn, e);
            uint n = uint(hit.x) + uint(hit.y) + uint(hit.z) + uint(hit.w);
            if (n == 0u) {
                if (sp == 0) { live = false; break; }
                LIFT_BVH4_POP(cur)
                continue;
            }
            LIFT_BVH4_VISIT_NEAR_FAR(hit, tn, e, n)
        }
        if (!live) break;
        LIFT_BVH4_CLOSEST_LEAF
        if (sp == 0) break;
        LIFT_BVH4_POP(cur)
    }
    return found;
}

// Whether any triangle lies in (ray.tmin, t): the same loops; the first hit found ends the
// query, so the order is free and the answer the same in every order: the hit children are
// taken in slot order, unsorted (sorting them near to far, or testing a node's leaf children
// first, ran shadow rays 0.79-0.96x as fast on an H100: docs/alternatives.md).
bool lift_bvh_any(uint root, Ray ray, float t) {
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    uvec3 near = lift_bvh4_near_rows(inv);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint cur = root;
    while (true) {
        while ((cur & LIFT_BVH4_LEAF) == 0u) {
            vec4 tn;
            uvec4 e;
            bvec4 hit = lift_bvh4_children(cur, ray.origin, inv, near, ray.tmin, t, tn, e);
            bool h0 = hit.x, h1 = hit.y, h2 = hit.z, h3 = hit.w;
            uint e0 = e.x, e1 = e.y, e2 = e.z, e3 = e.w;
            // visit the first child left next, push the others (the last first)
            bool have = false;
            uint next = 0u;
            if (h3) { next = e3; have = true; }
            if (h2) { if (have) { LIFT_BVH_STACK_SET(sp, next); ++sp; } next = e2; have = true; }
            if (h1) { if (have) { LIFT_BVH_STACK_SET(sp, next); ++sp; } next = e1; have = true; }
            if (h0) { if (have) { LIFT_BVH_STACK_SET(sp, next); ++sp; } next = e0; have = true; }
            if (have) {
                cur = next;
            } else {
                if (sp == 0) return false;
                LIFT_BVH4_POP(cur)
            }
        }
        if (lift_bvh4_any_leaf(cur, ray, shear, t)) return true;
        if (sp == 0) return false;
        LIFT_BVH4_POP(cur)
    }
    return false;
}

#endif
