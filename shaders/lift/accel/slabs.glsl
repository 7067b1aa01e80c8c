// lift/accel/slabs.glsl: slab tests of boxes against a ray: its inverse direction, and the box
// of a binary BVH node (with HAS_MOTION, blended to the ray's moment). Internal to lift/trace.glsl.
#ifndef LIFT_ACCEL_SLABS_GLSL
#define LIFT_ACCEL_SLABS_GLSL

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

#endif
