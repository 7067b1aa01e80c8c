#include "lift/scene_data.glsl"
// lift/bvh.glsl: ray queries against the scene: the triangle BVH (built by
// lift_gl/accel/bvh.py, layout in scene_data.glsl) and, with HAS_SPHERES, analytic spheres.
#ifndef LIFT_BVH_GLSL
#define LIFT_BVH_GLSL

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

// The build limits the tree to 48 levels, so a stack of 48 never overflows: it holds at most
// one postponed sibling per level of the current path. The 4-wide tree (LIFT_BVH_WIDTH 4,
// lift_gl/accel/wide.py) pushes up to 3 children a level; its collapse keeps the deepest
// stack a tree can need within 64 (wide.STACK), or the scene keeps the binary tree.
#if defined(LIFT_BVH_WIDTH) && LIFT_BVH_WIDTH == 4
#if defined(HAS_MOTION) || defined(HAS_INSTANCES)
#error "the 4-wide BVH has no motion boxes and no BLAS roots: such scenes keep the binary tree (scene/pack.py)"
#endif
// The host declares the stack its tree needs (LIFT_BVH_STACK_SIZE, wide.stack_size: at most 64):
// on GPUs it is shared memory, and a smaller one lets more warps run on an SM.
#ifdef LIFT_BVH_STACK_SIZE
#if LIFT_BVH_STACK_SIZE > 64
#error "LIFT_BVH_STACK_SIZE above the 4-wide collapse's bound (wide.STACK)"
#endif
#define LIFT_BVH_STACK LIFT_BVH_STACK_SIZE
#else
#define LIFT_BVH_STACK 64
#endif
#else
#define LIFT_BVH_STACK 48
#endif

// Where the traversal stack lives. A per-invocation array indexed at run time is local
// memory on NVIDIA GPUs (off-chip, one vec4 slot per element in its assembly): on an H100
// that made pt's trace pass 1.7-2.2x slower than the same stack in shared memory
// (docs/gpu.md). A compute host that knows its work-group size defines
// LIFT_BVH_SHARED_STACK to it (lift_gl/passes/trace.py, on GPUs), and each invocation then
// keeps its stack in one column of a shared array (consecutive invocations in consecutive
// words: no bank conflicts). No two traversals of one invocation overlap, so they share it.
// Otherwise (CPU rasterizers, fragment shaders, other hosts) the stack is a local array.
//
// Shared memory is also what bounds how many warps an SM runs at once (a 64-entry stack in
// 8x4 groups: 8 KiB a group), hence a stack only as deep as the scene's tree needs
// (LIFT_BVH_STACK_SIZE above). LIFT_BVH_SHARED_DEPTH n (a host's option) keeps only the top n
// entries of each stack in shared memory and spills the deeper ones to a local array: on the
// H100 that made pt's trace slower (its rays often go deeper than 16 entries and local memory
// is slow) though the light ray-casting kernels gained (docs/gpu.md "A stack as deep as the
// tree needs"), so by default the whole stack is shared. Entries are written with
// LIFT_BVH_STACK_SET(i, v) and read with LIFT_BVH_STACK_GET(i) (i without side effects: it
// may be evaluated twice).
#ifdef LIFT_BVH_SHARED_STACK
#ifndef LIFT_BVH_SHARED_DEPTH
#define LIFT_BVH_SHARED_DEPTH LIFT_BVH_STACK
#endif
#if LIFT_BVH_SHARED_DEPTH >= LIFT_BVH_STACK
shared uint lift_bvh_stack[LIFT_BVH_STACK * LIFT_BVH_SHARED_STACK];
#define LIFT_BVH_STACK_DECLARE
#define LIFT_BVH_SHARED_AT(i) lift_bvh_stack[uint(i) * uint(LIFT_BVH_SHARED_STACK) + gl_LocalInvocationIndex]
#define LIFT_BVH_STACK_SET(i, v) LIFT_BVH_SHARED_AT(i) = (v)
#define LIFT_BVH_STACK_GET(i) LIFT_BVH_SHARED_AT(i)
#else
shared uint lift_bvh_stack[LIFT_BVH_SHARED_DEPTH * LIFT_BVH_SHARED_STACK];
#define LIFT_BVH_STACK_DECLARE uint lift_bvh_spill[LIFT_BVH_STACK - LIFT_BVH_SHARED_DEPTH];
#define LIFT_BVH_SHARED_AT(i) lift_bvh_stack[uint(i) * uint(LIFT_BVH_SHARED_STACK) + gl_LocalInvocationIndex]
#define LIFT_BVH_STACK_SET(i, v) if ((i) < LIFT_BVH_SHARED_DEPTH) LIFT_BVH_SHARED_AT(i) = (v); else lift_bvh_spill[(i) - LIFT_BVH_SHARED_DEPTH] = (v)
#define LIFT_BVH_STACK_GET(i) ((i) < LIFT_BVH_SHARED_DEPTH ? LIFT_BVH_SHARED_AT(i) : lift_bvh_spill[(i) - LIFT_BVH_SHARED_DEPTH])
#endif
#else
#define LIFT_BVH_STACK_DECLARE uint lift_bvh_stack[LIFT_BVH_STACK];
#define LIFT_BVH_STACK_SET(i, v) lift_bvh_stack[i] = (v)
#define LIFT_BVH_STACK_GET(i) lift_bvh_stack[i]
#endif

// With LIFT_COUNT_RAYS (lift-gl bench), each invocation counts its traversals here and the
// host adds the count to the statistics once, at the end: one atomic per pixel, not per ray.
#ifdef LIFT_COUNT_RAYS
uint lift_rays_traced = 0u;
#define LIFT_COUNT_RAY() (++lift_rays_traced)
#else
#define LIFT_COUNT_RAY()
#endif

// ---- Ray/triangle test --------------------------------------------------------------------
// The watertight test of Woop, Benthin and Wald (JCGT 2013): the triangle is
// moved into a frame where the ray runs along +z from (0, 0) (the axes permuted so that z is
// the ray's largest, then a shear), and three 2D edge functions U, V, W decide the hit. Two
// triangles sharing an edge compute its edge function from the same two products, subtracted
// in the opposite order, so the one is exactly the negation of the other and a ray through
// the edge or a shared vertex cannot slip between them (Möller–Trumbore computes each
// triangle's barycentrics from its own edge vectors and lets 3-5% of such rays through:
// tests/test_watertight.py). The permutation and the shear depend only on the ray:
// the traversal computes them once (lift_ray_shear) as two rows, the frame's x and y axes in
// world space, so a corner's frame x and y are two fused dot products, and its z (for t) is
// read only for a hit. On an H100 this costs pt's trace pass 1-4% over Möller–Trumbore; the
// permutation done by selecting swizzles of each corner cost 8-16%, and a vec3 indexed by a
// per-ray axis up to 40% (local memory); docs/gpu.md. The paper also swaps x and y when the
// ray runs towards -z, to keep the triangles' winding; this test accepts both windings and
// t, b1, b2 are ratios of U, V, W, so the swap (which negates all three) would change nothing.
struct LiftRayShear {
    vec3 row_x, row_y;   // frame x = dot(row_x, p - origin): the axis after the ray's largest, sheared
    float inv_dz;        // 1 / the direction's largest component
    int kz;              // the ray's largest axis
};

// v's axes in the frame's order (x, y, z), z the ray's largest axis; a cyclic permutation.
vec3 lift_permute(vec3 v, int kz) { return kz == 0 ? v.yzx : (kz == 1 ? v.zxy : v); }

LiftRayShear lift_ray_shear(vec3 dir) {
    vec3 a = abs(dir);
    int kz = a.x >= a.y ? (a.x >= a.z ? 0 : 2) : (a.y >= a.z ? 1 : 2);
    vec3 d = lift_permute(dir, kz);
    float inv_dz = 1.0 / d.z;   // |d.z| >= |dir| / sqrt(3): finite for any nonzero dir
    vec3 ez = vec3(equal(ivec3(0, 1, 2), ivec3(kz)));
    vec3 ex = ez.zxy, ey = ez.yzx;   // the frame's x and y axes, one-hot
    return LiftRayShear(ex - (d.x * inv_dz) * ez, ey - (d.y * inv_dz) * ez, inv_dz, kz);
}

// A corner's frame coordinate: one rounding where the row's 1 and 0 come first (kz = 2), two
// otherwise; the same operations for every corner, which is what watertightness needs.
float lift_shear(vec3 p, vec3 row) {
    precise float x = fma(p.z, row.z, fma(p.y, row.y, p.x * row.x));   // precise: fma() fused, always
    return x;
}

// Updates t and returns true when the hit is in (ray.tmin, t); bary = (b1, b2), as in Hit.
// A triangle with a repeated corner has U + V + W == 0 exactly and never hits, nor does one
// seen exactly edge-on; a NaN anywhere (corner, direction) fails the test.
bool lift_intersect_triangle(Ray ray, LiftRayShear sh, uint tri, inout float t, out vec2 bary) {
    bary = vec2(0.0);
    uint i = 3u * tri;
    // `precise` (no operation fused or reordered by the compiler): a corner shared by two
    // triangles gets the same coordinates in both, and the edge functions stay exact negations
    precise vec3 org = ray.origin - prim_displacement(tri);  // a moving triangle: where it is now
    precise vec3 a = tri_pos_row(i).xyz - org;
    precise vec3 b = tri_pos_row(i + 1u).xyz - org;
    precise vec3 c = tri_pos_row(i + 2u).xyz - org;
    precise float ax = lift_shear(a, sh.row_x), ay = lift_shear(a, sh.row_y);
    precise float bx = lift_shear(b, sh.row_x), by = lift_shear(b, sh.row_y);
    precise float cx = lift_shear(c, sh.row_x), cy = lift_shear(c, sh.row_y);
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float w = bx * ay - by * ax;
    // An edge function of exactly 0 counts as inside, so a ray through an edge or vertex hits
    // every triangle there (the closest hit keeps one).
    if (!((u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0))) return false;
    precise float det = u + v + w;
    if (det == 0.0) return false;
    float inv_det = 1.0 / det;
    // t from the corners' distances along the ray's largest axis, weighted by U, V, W
    float th = (u * lift_permute(a, sh.kz).z + v * lift_permute(b, sh.kz).z + w * lift_permute(c, sh.kz).z)
               * sh.inv_dz * inv_det;
    if (!(th > ray.tmin && th < t)) return false;   // a NaN th fails too
    t = th;
    bary = vec2(v, w) * inv_det;
    return true;
}

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

// 1/dir with zero components replaced by a tiny value of the same sign: the slab distances
// stay finite, so an origin lying on a slab plane gives 0 * big = 0 rather than 0 * inf = NaN.
vec3 lift_bvh_inv_dir(vec3 d) {
    vec3 s = mix(vec3(-1.0), vec3(1.0), greaterThanEqual(d, vec3(0.0)));
    return 1.0 / (s * max(abs(d), vec3(1e-30)));
}

// Slab test of node n's box against the interval (tmin, tmax), conservative; tn: entry distance.
bool lift_bvh_box(uint n, vec3 org, vec3 inv, float tmin, float tmax, out float tn) {
    vec3 bmin = bvh_node_row(2u * n).xyz;
    vec3 bmax = bvh_node_row(2u * n + 1u).xyz;
#ifdef HAS_MOTION
    // The node's boxes at shutter open and close, blended to the ray's moment: for linear
    // motion this bounds every triangle below the node at that moment, and it stays as
    // tight as a still scene's box where the whole node moves as one.
    uint close = u_num_triangles + u_num_spheres + 2u * n;
    bmin = mix(bmin, motion[close].xyz, g_ray_time);
    bmax = mix(bmax, motion[close + 1u].xyz, g_ray_time);
#endif
    vec3 t0 = (bmin - org) * inv;
    vec3 t1 = (bmax - org) * inv;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    tn = max(max(lo.x, lo.y), max(lo.z, tmin));
    // The exit enlarged by the rounding bound of Ize (JCGT 2013: 1 + 2 gamma(3)), so that a ray
    // through a triangle's corner or edge lying on its leaf's box is not culled by the
    // rounding of the slab distances (without it 5 of tests/test_watertight.py's 8,236 rays
    // through shared edges slip through): watertight triangles need conservative boxes.
    float tf = min(min(hi.x, hi.y), min(hi.z, tmax)) * 1.0000004;
    return tn <= tf;
}

#if defined(LIFT_BVH_WIDTH) && LIFT_BVH_WIDTH == 4
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

#ifndef LIFT_BVH_GROUP_STACK
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

#endif

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

#ifndef LIFT_BVH_GROUP_STACK
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
#else  // LIFT_BVH_GROUP_STACK
// ---- A stack of node groups -------------------------------------------------------------
// With the stack above an entry is a child entry: a node whose children are all hit pushes
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
#endif  // LIFT_BVH_GROUP_STACK

// ---- A shadow ray and the next path ray in one traversal loop ----------------------------
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
#else
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

#endif  // LIFT_BVH_WIDTH

#ifdef HAS_INSTANCES
// ---- Instances: the TLAS over their world boxes, then each one's BLAS -------------------
// The ray goes into the instance's object space unnormalised: o' + t d' is the object-space
// image of o + t d, so t, tmin and the closest t so far keep their meaning in every BLAS.

bool lift_tlas_box(uint n, vec3 org, vec3 inv, float tmin, float tmax, out float tn) {
    vec3 t0 = (instances[2u * n].xyz - org) * inv;
    vec3 t1 = (instances[2u * n + 1u].xyz - org) * inv;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    tn = max(max(lo.x, lo.y), max(lo.z, tmin));
    float tf = min(min(hi.x, hi.y), min(hi.z, tmax));
    return tn <= tf;
}

// A world ray in instance k's object space (its direction not renormalised, so t is the same).
Ray instance_ray(uint k, Ray ray) {
    return Ray(instance_point_to_object(k, ray.origin), instance_dir_to_object(k, ray.dir), ray.tmin, ray.tmax);
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
