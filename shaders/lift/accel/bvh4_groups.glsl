// lift/accel/bvh4_groups.glsl: the 4-wide traversals with a stack of node groups
// (LIFT_BVH_GROUP_STACK): an entry a level. Internal to lift/trace.glsl (through
// accel/bvh4.glsl, which defines the node tests and loops used here).
#ifndef LIFT_ACCEL_BVH4_GROUPS_GLSL
#define LIFT_ACCEL_BVH4_GROUPS_GLSL

// With a stack of child entries (accel/bvh4_children.glsl) a node whose children are all hit pushes
// three, so the stack must hold the tree's largest sum of (children hit - 1) along a root
// path (wide.stack_bound: 54 in Lift's dining room). Here an entry is a node with children
// still to visit: node << 8 | their slots, 2 bits each, in visiting order << 2 | (how many
// - 1). A pop takes the first slot, keeps the entry while others are left, and reads that
// child's entry from the node again. A root path holds at most one entry a level, so the
// stack needs as many entries as the tree has levels (wide.levels: 18 there), and on GPUs it
// takes that much less shared memory, which is also the SM's L1 cache (docs/gpu.md "A stack
// of node groups"). Node ids get 24 bits (the host keeps the other stack past 2^24 nodes).
// Each function pops in one place only: the pop is longer than the other stack's.
// The child entry in slot s (0-3) of a node's four, by selects (no dynamic vector index).
uint lift_bvh4_pick(uvec4 e, uint s) { return s == 0u ? e.x : s == 1u ? e.y : s == 2u ? e.z : e.w; }
uint lift_bvh4_group(uint node, uint slots, uint left) { return node << 8u | slots << 2u | (left - 1u); }
uvec4 lift_bvh4_entries(uint n) {
#ifdef LIFT_BVH_QUANTIZED
    return floatBitsToUint(bvh_node_row(4u * n + 3u));
#else
    return floatBitsToUint(bvh_node_row(8u * n + 6u));
#endif
}
// cur = the next child of the stack's top group; the group is dropped with its last child
// (a macro: the stack may be a local array of the caller's)
#define LIFT_BVH4_POP(cur) { \
    uint g_ = LIFT_BVH_STACK_GET(sp - 1); \
    if ((g_ & 3u) == 0u) --sp; \
    else LIFT_BVH_STACK_SET(sp - 1, (g_ & 0xffffff00u) | ((g_ >> 2u) & 0x3cu) | ((g_ & 3u) - 1u)); \
    cur = lift_bvh4_pick(lift_bvh4_entries(g_ >> 8u), (g_ >> 2u) & 3u); }
// The n hit children of node `cur` near to far: the nearest becomes cur, the others one group
// entry. Sort keys: each an entry distance's bits (>= 0: they order as the distances do) with
// its slot in the two low bits, a miss all ones (last).
#define LIFT_BVH4_VISIT_NEAR_FAR(hit, tn, e, n) { \
    uvec4 k = (floatBitsToUint(tn) & 0x7ffffffcu) | uvec4(0u, 1u, 2u, 3u); \
    k |= uvec4(not(hit)) * 0xfffffffcu; \
    uint a = min(k.x, k.y), b = max(k.x, k.y), c = min(k.z, k.w), d = max(k.z, k.w); \
    uint k0 = min(a, c), x = max(a, c), y = min(b, d), k3 = max(b, d); \
    uint k1 = min(x, y), k2 = max(x, y); \
    if (n > 1u) { LIFT_BVH_STACK_SET(sp, lift_bvh4_group(cur, (k1 & 3u) | (k2 & 3u) << 2u | (k3 & 3u) << 4u, n - 1u)); ++sp; } \
    cur = lift_bvh4_pick(e, k0 & 3u); }

bool lift_bvh_closest(uint root, Ray ray, inout float t, inout uint prim, inout vec2 bary_out) {
    bool found = false;
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    uvec3 near = lift_bvh4_near_rows(inv);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint cur = root;
    while (true) {
        bool at_leaf = true;
        LIFT_BVH4_DESCEND(at_leaf)
        if (at_leaf) LIFT_BVH4_CLOSEST_LEAF
        if (sp == 0) break;
        LIFT_BVH4_POP(cur)
    }
    return found;
}

bool lift_bvh_any(uint root, Ray ray, float t) {
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    uvec3 near = lift_bvh4_near_rows(inv);
    LiftRayShear shear = lift_ray_shear(ray.dir);
    LIFT_BVH_STACK_DECLARE
    int sp = 0;
    uint cur = root;
    while (true) {
        bool at_leaf = true;
        while ((cur & LIFT_BVH4_LEAF) == 0u) {
            vec4 tn;
            uvec4 e;
            bvec4 hit = lift_bvh4_children(cur, ray.origin, inv, near, ray.tmin, t, tn, e);
            uint n = uint(hit.x) + uint(hit.y) + uint(hit.z) + uint(hit.w);
            if (n == 0u) { at_leaf = false; break; }
            // the hit children in slot order: the first visited next, the others one entry
            uint s0 = hit.x ? 0u : hit.y ? 1u : hit.z ? 2u : 3u;
            uint rest = 0u, left = 0u;
            if (hit.y && s0 < 1u) { rest |= 1u << (2u * left); ++left; }
            if (hit.z && s0 < 2u) { rest |= 2u << (2u * left); ++left; }
            if (hit.w && s0 < 3u) { rest |= 3u << (2u * left); ++left; }
            if (left > 0u) { LIFT_BVH_STACK_SET(sp, lift_bvh4_group(cur, rest, left)); ++sp; }
            cur = lift_bvh4_pick(e, s0);
        }
        if (at_leaf && lift_bvh4_any_leaf(cur, ray, shear, t)) return true;
        if (sp == 0) return false;
        LIFT_BVH4_POP(cur)
    }
    return false;
}

#endif
