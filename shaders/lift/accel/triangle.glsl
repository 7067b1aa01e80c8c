// lift/accel/triangle.glsl: the watertight ray/triangle test the traversals run. Internal to
// lift/trace.glsl (which declares Ray and prim_displacement first, and intersect_triangle
// for plugins).
#ifndef LIFT_ACCEL_TRIANGLE_GLSL
#define LIFT_ACCEL_TRIANGLE_GLSL

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

#endif
