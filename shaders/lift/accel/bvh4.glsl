// lift/accel/bvh4.glsl: the 4-wide BVH (LIFT_BVH_WIDTH 4: lift_gl/accel/wide.py collapses the
// binary tree into it and has the layout): node tests with float or 8-bit boxes
// (LIFT_BVH_QUANTIZED), the loops both stacks share, then the traversals of the stack the host
// chose (a child an entry, accel/bvh4_children.glsl, or a node group an entry,
// accel/bvh4_groups.glsl) and the paired loop of a shadow ray and the next ray
// (accel/bvh4_paired.glsl). Internal to lift/trace.glsl.
#ifndef LIFT_ACCEL_BVH4_GLSL
#define LIFT_ACCEL_BVH4_GLSL
#if defined(HAS_MOTION) || defined(HAS_INSTANCES)
#error "the 4-wide BVH has no motion boxes and no BLAS roots: such scenes keep the binary tree (scene/pack.py)"
#endif
#include "lift/accel/slabs.glsl"
#include "lift/accel/stack.glsl"

// ---- The 4-wide tree (lift_gl/accel/wide.py has the layout) -----------------------------
// Eight vec4 rows a node: min.x, max.x, min.y, max.y, min.z, max.z of its four children,
// their entries, one unused row. An entry is a wide node id, or with LIFT_BVH4_LEAF set a
// leaf: (count - 1) in bits 27-30, its first triangle below.
#define LIFT_BVH4_LEAF 0x80000000u
#define LIFT_BVH4_FIRST_MASK 0x07ffffffu

// Rows of a node's near and far planes for this ray, by the sign of each direction
// component: (near x, near y, near z); a far plane is its near plane's row ^ 1. Taking the
// planes by sign gives the binary test's min/max of the two slab distances bit for bit,
// and an empty slot's box (+inf, -inf) is then never entered.
uvec3 lift_bvh4_near_rows(vec3 inv) {
    return uvec3(inv.x < 0.0 ? 1u : 0u, inv.y < 0.0 ? 3u : 2u, inv.z < 0.0 ? 5u : 4u);
}

#ifndef LIFT_BVH_QUANTIZED
// Slab tests of node n's four children against (tmin, tmax): entry distances, which hit, and
// the children's entries.
bvec4 lift_bvh4_children(uint n, vec3 org, vec3 inv, uvec3 near, float tmin, float tmax, out vec4 tn,
                         out uvec4 e) {
    uint base = 8u * n;
    vec4 nx = (bvh_node_row(base + near.x) - org.x) * inv.x;
    vec4 fx = (bvh_node_row(base + (near.x ^ 1u)) - org.x) * inv.x;
    vec4 ny = (bvh_node_row(base + near.y) - org.y) * inv.y;
    vec4 fy = (bvh_node_row(base + (near.y ^ 1u)) - org.y) * inv.y;
    vec4 nz = (bvh_node_row(base + near.z) - org.z) * inv.z;
    vec4 fz = (bvh_node_row(base + (near.z ^ 1u)) - org.z) * inv.z;
    e = floatBitsToUint(bvh_node_row(base + 6u));
    tn = max(max(nx, ny), max(nz, vec4(tmin)));
    vec4 tf = min(min(fx, fy), min(fz, vec4(tmax))) * 1.0000004;   // Ize's bound, as lift_bvh_box
    return lessThanEqual(tn, tf);
}
#else
// Quantized child boxes (LIFT_BVH_QUANTIZED, wide.quantize): four rows a node, origin and
// per-axis power-of-two scales, each child's planes as bytes. A plane is origin + q * s, the
// product exact; `precise` keeps the compiler from reassociating the add, so the planes are
// the ones the host checked to contain the float boxes.
vec4 lift_bvh4_bytes(uint w) { return vec4((uvec4(w) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu); }

bvec4 lift_bvh4_children(uint n, vec3 org, vec3 inv, uvec3 near, float tmin, float tmax, out vec4 tn,
                         out uvec4 e) {
    uint base = 4u * n;
    vec4 r0 = bvh_node_row(base);
    uvec4 qxy = floatBitsToUint(bvh_node_row(base + 1u));
    uvec2 qz = floatBitsToUint(bvh_node_row(base + 2u).xy);
    e = floatBitsToUint(bvh_node_row(base + 3u));
    vec3 s = uintBitsToFloat(((uvec3(floatBitsToUint(r0.w)) >> uvec3(0u, 8u, 16u)) & 0xffu) << 23u);
    bool fx_lo = near.x == 1u, fy_lo = near.y == 3u, fz_lo = near.z == 5u;   // negative directions
    precise vec4 px_n = r0.x + lift_bvh4_bytes(fx_lo ? qxy.y : qxy.x) * s.x;
    precise vec4 px_f = r0.x + lift_bvh4_bytes(fx_lo ? qxy.x : qxy.y) * s.x;
    precise vec4 py_n = r0.y + lift_bvh4_bytes(fy_lo ? qxy.w : qxy.z) * s.y;
    precise vec4 py_f = r0.y + lift_bvh4_bytes(fy_lo ? qxy.z : qxy.w) * s.y;
    precise vec4 pz_n = r0.z + lift_bvh4_bytes(fz_lo ? qz.y : qz.x) * s.z;
    precise vec4 pz_f = r0.z + lift_bvh4_bytes(fz_lo ? qz.x : qz.y) * s.z;
    vec4 nx = (px_n - org.x) * inv.x, fx = (px_f - org.x) * inv.x;
    vec4 ny = (py_n - org.y) * inv.y, fy = (py_f - org.y) * inv.y;
    vec4 nz = (pz_n - org.z) * inv.z, fz = (pz_f - org.z) * inv.z;
    tn = max(max(nx, ny), max(nz, vec4(tmin)));
    vec4 tf = min(min(fx, fy), min(fz, vec4(tmax))) * 1.0000004;   // Ize's bound, as lift_bvh_box
    // an empty slot (entry 0xffffffff) has qlo 255 > qhi 0, but a tiny scale may round both to
    // the origin: its entry rules it out
    return bvec4(uvec4(lessThanEqual(tn, tf)) & uvec4(notEqual(e, uvec4(0xffffffffu))));
}
#endif

// One compare-exchange of a sorting network on (distance, entry) pairs.
#define LIFT_BVH4_ORDER(ta, ea, tb, eb) if (tb < ta) { float t_ = ta; ta = tb; tb = t_; uint e_ = ea; ea = eb; eb = e_; }
// The four children's entries e0..e3 sorted near to far by their entry distances tn (t0..t3
// declared here), a child missed (hit false) sorting last: a 5-exchange network.
#define LIFT_BVH4_SORT(hit, tn, e0, e1, e2, e3) \
    float t0 = hit.x ? tn.x : LIFT_BVH4_MISS, t1 = hit.y ? tn.y : LIFT_BVH4_MISS; \
    float t2 = hit.z ? tn.z : LIFT_BVH4_MISS, t3 = hit.w ? tn.w : LIFT_BVH4_MISS; \
    LIFT_BVH4_ORDER(t0, e0, t1, e1) \
    LIFT_BVH4_ORDER(t2, e2, t3, e3) \
    LIFT_BVH4_ORDER(t0, e0, t2, e2) \
    LIFT_BVH4_ORDER(t1, e1, t3, e3) \
    LIFT_BVH4_ORDER(t1, e1, t2, e2)
const float LIFT_BVH4_MISS = uintBitsToFloat(0x7f800000u);   // +inf: misses sort last
// A leaf entry's triangles: the first, and how many (1-16).
uint lift_bvh4_leaf_first(uint leaf) { return leaf & LIFT_BVH4_FIRST_MASK; }
uint lift_bvh4_leaf_count(uint leaf) { return ((leaf >> 27u) & 15u) + 1u; }

// The while-while traversals' two inner loops, shared by the closest-hit traversal of either
// stack kind, the one loop of a shadow ray and the next ray, and benchmarks/gpu_ray_queue.py.
// Macros over the caller's names: cur, sp and the stack, ray, inv, near, shear, t (and for the
// leaf: prim, bary_out, found). LIFT_BVH4_DESCEND: from node `cur` down to the next leaf entry,
// its hit children near to far (LIFT_BVH4_VISIT_NEAR_FAR, per stack kind below); at_leaf false
// where a node's children all missed. LIFT_BVH4_CLOSEST_LEAF: leaf entry cur's triangles
// against (ray.tmin, t), the nearer hits kept.
#define LIFT_BVH4_DESCEND(at_leaf) \
    while ((cur & LIFT_BVH4_LEAF) == 0u) { \
        vec4 tn; \
        uvec4 e; \
        bvec4 hit = lift_bvh4_children(cur, ray.origin, inv, near, ray.tmin, t, tn, e); \
        uint n = uint(hit.x) + uint(hit.y) + uint(hit.z) + uint(hit.w); \
        if (n == 0u) { at_leaf = false; break; } \
        LIFT_BVH4_VISIT_NEAR_FAR(hit, tn, e, n) \
    }
#define LIFT_BVH4_CLOSEST_LEAF { \
    uint first = lift_bvh4_leaf_first(cur); \
    uint count = lift_bvh4_leaf_count(cur); \
    for (uint i = first; i < first + count; ++i) { \
        vec2 bary; \
        if (lift_intersect_triangle(ray, shear, i, t, bary)) { \
            prim = i; \
            bary_out = bary; \
            found = true; \
        } \
    } }

// Tests the triangles of leaf entry `leaf` against (ray.tmin, t): true at the first hit.
bool lift_bvh4_any_leaf(uint leaf, Ray ray, LiftRayShear shear, float t) {
    uint first = lift_bvh4_leaf_first(leaf);
    uint count = lift_bvh4_leaf_count(leaf);
    for (uint i = first; i < first + count; ++i) {
        vec2 bary;
        if (lift_intersect_triangle(ray, shear, i, t, bary)) return true;
    }
    return false;
}

#ifdef LIFT_BVH_GROUP_STACK
#include "lift/accel/bvh4_groups.glsl"
#else
#include "lift/accel/bvh4_children.glsl"
#endif
#include "lift/accel/bvh4_paired.glsl"

#endif
