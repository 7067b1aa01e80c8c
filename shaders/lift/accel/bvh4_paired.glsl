// lift/accel/bvh4_paired.glsl: a path vertex's shadow ray and next ray in one traversal loop of
// the 4-wide tree (LIFT_TRACE_PAIRED: trace_shadow_and_next). Internal to lift/trace.glsl
// (through accel/bvh4.glsl: it runs with either stack's visit and pop).
#ifndef LIFT_ACCEL_BVH4_PAIRED_GLSL
#define LIFT_ACCEL_BVH4_PAIRED_GLSL

// What lift_bvh_any(root, shadow, shadow.tmax) and then lift_bvh_closest(root, next, t, ...)
// return (the next ray visiting the same nodes in the same order, the shadow ray its hit
// children near to far), but in one loop: a lane whose shadow ray is done starts its next ray
// at once instead of idling until its warp's slowest shadow ray ends, and the program holds
// one traversal loop instead of two. Returns whether the shadow
// ray is blocked (false when not wanted); the closest hit as lift_bvh_closest (with t, prim,
// bary_out untouched when not wanted). trace_shadow_and_next below is the public call.
bool lift_bvh_shadow_then_closest(uint root, bool shadow_wanted, Ray shadow, bool next_wanted, Ray next,
                                  inout float t_next, inout uint prim, inout vec2 bary_out) {
    bool shadow_mode = shadow_wanted;
    Ray ray = shadow_mode ? shadow : next;
    float t = shadow_mode ? shadow.tmax : t_next;
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    uvec3 near = lift_bvh4_near_rows(inv);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint cur = root;
    bool occluded = false;
    bool live = shadow_wanted || next_wanted;
    while (live) {
        bool at_leaf = true;
        // near to far for both rays: the shadow ray's answer is the same in any order, and one
        // order keeps the two rays' lanes on one path through the loop (on an H100 that was
        // 1.02-1.06x faster than the shadow ray's slot order behind a branch)
        LIFT_BVH4_DESCEND(at_leaf)
        bool done = false;
        if (at_leaf) {
            uint first = lift_bvh4_leaf_first(cur);
            uint count = lift_bvh4_leaf_count(cur);
            for (uint i = first; i < first + count; ++i) {
                vec2 bary;
                if (lift_intersect_triangle(ray, shear, i, t, bary)) {
                    if (shadow_mode) { occluded = true; done = true; break; }
                    prim = i;
                    bary_out = bary;
                }
            }
        }
        if (!done) {
            if (sp == 0) done = true;
            else LIFT_BVH4_POP(cur)
        }
        if (done) {
            if (!shadow_mode || !next_wanted) break;
            // the shadow ray is done: the next ray starts from the root
            shadow_mode = false;
            ray = next;
            t = t_next;
            inv = lift_bvh_inv_dir(ray.dir);
            near = lift_bvh4_near_rows(inv);
            shear = lift_ray_shear(ray.dir);
            sp = 0;
            cur = root;
        }
    }
    if (next_wanted) t_next = t;
    return occluded;
}

#endif
