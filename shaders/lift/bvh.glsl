#include "lift/scene_data.glsl"
// lift/bvh.glsl: ray queries against the scene: the triangle BVH (built by
// lift_gl/accel/bvh.py, laid out for the GPU by lift_gl/accel/gpu_layout.py; scene_data.glsl) and, with HAS_SPHERES, analytic spheres.
#ifndef LIFT_BVH_GLSL
#define LIFT_BVH_GLSL

struct Ray { vec3 origin; vec3 dir; float tmin; float tmax; };   // dir normalized
// prim: triangle id (index into the reordered triangle arrays), or u_num_triangles + sphere
// index; NO_HIT when nothing was hit. bary = (b1, b2): p = (1-b1-b2)*p0 + b1*p1 + b2*p2.
struct Hit { float t; uint prim; vec2 bary; };
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
// one postponed sibling per level of the current path.
#define LIFT_BVH_STACK 48

// With LIFT_COUNT_RAYS (lift-gl bench), each invocation counts its traversals here and the
// host adds the count to the statistics once, at the end: one atomic per pixel, not per ray.
#ifdef LIFT_COUNT_RAYS
uint lift_rays_traced = 0u;
#define LIFT_COUNT_RAY() (++lift_rays_traced)
#else
#define LIFT_COUNT_RAY()
#endif

// The watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013): the triangle is
// moved into a frame where the ray runs along +z from the origin (a permutation that makes z
// the ray's largest axis, and a shear), and the 2D edge functions U, V, W decide the hit.
// A point on an edge shared by two triangles gets the same edge function (same operands,
// same rounding) in both, so no ray slips between neighbours; a ray exactly on an edge may
// hit both, which the closest-hit test settles. (The paper's double-precision fallback for
// an edge function of exactly 0 is left out: 0 counts as inside, so such rays hit too.)
// Triangles seen edge-on and zero-area ones have U + V + W == 0 and never hit.
struct LiftRayFrame { uvec3 k; vec3 shear; };  // k: axes (x, y, z) of the frame; shear (Sx, Sy, Sz)

LiftRayFrame lift_ray_frame(vec3 dir) {
    vec3 a = abs(dir);
    uint kz = a.x > a.y ? (a.x > a.z ? 0u : 2u) : (a.y > a.z ? 1u : 2u);
    uint kx = kz == 2u ? 0u : kz + 1u;
    uint ky = kx == 2u ? 0u : kx + 1u;
    if (dir[kz] < 0.0) { uint k = kx; kx = ky; ky = k; }  // keep the winding: U, V, W keep their sign
    float dz = dir[kz];
    return LiftRayFrame(uvec3(kx, ky, kz), vec3(dir[kx] / dz, dir[ky] / dz, 1.0 / dz));
}

// Updates t and returns true when the hit is in (ray.tmin, t); bary as for the other tests.
bool intersect_triangle(Ray ray, LiftRayFrame f, uint tri, inout float t, out vec2 bary) {
    bary = vec2(0.0);
    uint i = 3u * tri;
    vec3 org = ray.origin - prim_displacement(tri);  // a moving triangle: where it is now
    vec3 a = tri_pos[i].xyz - org;
    vec3 b = tri_pos[i + 1u].xyz - org;
    vec3 c = tri_pos[i + 2u].xyz - org;
    vec3 az = vec3(a[f.k.z], b[f.k.z], c[f.k.z]);   // z of the three corners
    vec3 ax = vec3(a[f.k.x], b[f.k.x], c[f.k.x]) - f.shear.x * az;
    vec3 ay = vec3(a[f.k.y], b[f.k.y], c[f.k.y]) - f.shear.y * az;
    // `precise`: no fused multiply-add, so an edge's function in the neighbour (operands
    // swapped) is exactly the negation of this one
    precise float u = ax.z * ay.y - ay.z * ax.y;   // C x B
    precise float v = ax.x * ay.z - ay.x * ax.z;   // A x C
    precise float w = ax.y * ay.x - ay.y * ax.x;   // B x A
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    float det = u + v + w;
    if (det == 0.0) return false;
    float inv_det = 1.0 / det;
    float th = dot(vec3(u, v, w), f.shear.z * az) * inv_det;
    // written so that a NaN th fails the test
    if (!(th > ray.tmin && th < t)) return false;
    t = th;
    bary = vec2(v, w) * inv_det;
    return true;
}

// The same test for one ray and one triangle (the G-buffer's primary hit rebuilt: passes/trace.py).
bool intersect_triangle(Ray ray, uint tri, inout float t, out vec2 bary) {
    return intersect_triangle(ray, lift_ray_frame(ray.dir), tri, t, bary);
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

// Slab test of the box lo..hi against the interval (tmin, tmax); tn: entry distance.
bool lift_bvh_slab(vec3 lo, vec3 hi, vec3 org, vec3 inv, float tmin, float tmax, out float tn) {
    vec3 t0 = (lo - org) * inv;
    vec3 t1 = (hi - org) * inv;
    vec3 near = min(t0, t1);
    vec3 far = max(t0, t1);
    tn = max(max(near.x, near.y), max(near.z, tmin));
    // The exit distance is enlarged by the rounding bound of Ize (JCGT 2013), so that a ray
    // through a corner of a leaf's triangle (which lies on the leaf's box) is not culled
    // by the rounding of the slab distances: watertight triangles need conservative boxes.
    float tf = min(min(far.x, far.y), min(far.z, tmax)) * 1.0000004;
    return tn <= tf;
}

// The two children of BVH record `node` (layout in scene_data.glsl): which of them the ray
// enters before tmax, at which distances, and their links (ref, count) as in the record.
void lift_bvh_children(uint node, vec3 org, vec3 inv, float tmin, float tmax,
                       out bvec2 enter, out vec2 tn, out uvec4 link) {
    vec4 a_lo = bvh_nodes[4u * node];
    vec4 a_hi = bvh_nodes[4u * node + 1u];
    vec4 b_lo = bvh_nodes[4u * node + 2u];
    vec4 b_hi = bvh_nodes[4u * node + 3u];
    link = uvec4(floatBitsToUint(a_lo.w), floatBitsToUint(a_hi.w), floatBitsToUint(b_lo.w), floatBitsToUint(b_hi.w));
#ifdef HAS_MOTION
    // The children's boxes at shutter open and close, blended to the ray's moment: for linear
    // motion this bounds every triangle below the child at that moment, and it stays as
    // tight as a still scene's box where the whole child moves as one.
    uint close = u_num_triangles + u_num_spheres + 4u * node;
    a_lo.xyz = mix(a_lo.xyz, motion[close].xyz, g_ray_time);
    a_hi.xyz = mix(a_hi.xyz, motion[close + 1u].xyz, g_ray_time);
    b_lo.xyz = mix(b_lo.xyz, motion[close + 2u].xyz, g_ray_time);
    b_hi.xyz = mix(b_hi.xyz, motion[close + 3u].xyz, g_ray_time);
#endif
    float ta, tb;
    enter.x = lift_bvh_slab(a_lo.xyz, a_hi.xyz, org, inv, tmin, tmax, ta);
    enter.y = lift_bvh_slab(b_lo.xyz, b_hi.xyz, org, inv, tmin, tmax, tb);
    tn = vec2(ta, tb);
}

// Closest hit among triangles (BVH, nearer child first) and, with HAS_SPHERES, spheres.
// Each step fetches one record and tests both children's boxes; a leaf child is tested on
// the spot, so only interior nodes are visited and stacked.
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
    if (u_num_triangles > 0u) {
        vec3 inv = lift_bvh_inv_dir(ray.dir);
        LiftRayFrame frame = lift_ray_frame(ray.dir);
        uint stack_node[LIFT_BVH_STACK];
        float stack_t[LIFT_BVH_STACK];   // entry distance, to skip nodes behind a closer hit
        int sp = 0;
        uint node = 0u;
        while (true) {
            bvec2 enter;
            vec2 tn;
            uvec4 link;   // (A.ref, A.count, B.ref, B.count)
            lift_bvh_children(node, ray.origin, inv, ray.tmin, t, enter, tn, link);
            if (enter.x && link.y > 0u) {
                for (uint i = link.x; i < link.x + link.y; ++i) {
                    vec2 bary;
                    if (intersect_triangle(ray, frame, i, t, bary)) { hit.prim = i; hit.bary = bary; }
                }
                enter.x = false;
            }
            if (enter.y && link.w > 0u && tn.y <= t) {
                for (uint i = link.z; i < link.z + link.w; ++i) {
                    vec2 bary;
                    if (intersect_triangle(ray, frame, i, t, bary)) { hit.prim = i; hit.bary = bary; }
                }
                enter.y = false;
            }
            enter.y = enter.y && tn.y <= t;  // a leaf's hit may have moved t in front of B
            if (enter.x && enter.y && sp < LIFT_BVH_STACK) {   // the bound holds by construction
                bool a_first = tn.x <= tn.y;
                stack_node[sp] = a_first ? link.z : link.x;
                stack_t[sp] = a_first ? tn.y : tn.x;
                ++sp;
                node = a_first ? link.x : link.z;
                continue;
            }
            if (enter.x || enter.y) {
                node = enter.x ? link.x : link.z;
                continue;
            }
            // pop the next postponed node that may still hold something nearer than t
            bool live = false;
            while (sp > 0) {
                --sp;
                if (stack_t[sp] <= t) { node = stack_node[sp]; live = true; break; }
            }
            if (!live) break;
        }
    }
    if (hit.prim != NO_HIT) {
        hit.t = t;
        if (hit.prim >= u_num_triangles) hit.bary = vec2(0.0);
    }
    return hit.prim != NO_HIT;
}

// Whether anything lies in (ray.tmin, ray.tmax): stops at the first hit, in any order
// (leaf children of a record are tested before anything is stacked).
bool trace_occluded(Ray ray) {
    LIFT_COUNT_RAY();
    float t = ray.tmax;
#ifdef HAS_SPHERES
    for (uint s = 0u; s < u_num_spheres; ++s) {
        if (intersect_sphere(ray, s, t)) return true;
    }
#endif
    if (u_num_triangles == 0u) return false;
    vec3 inv = lift_bvh_inv_dir(ray.dir);
    LiftRayFrame frame = lift_ray_frame(ray.dir);
    uint stack_node[LIFT_BVH_STACK];
    int sp = 0;
    uint node = 0u;
    while (true) {
        bvec2 enter;
        vec2 tn;
        uvec4 link;
        lift_bvh_children(node, ray.origin, inv, ray.tmin, t, enter, tn, link);
        if (enter.x && link.y > 0u) {
            for (uint i = link.x; i < link.x + link.y; ++i) {
                vec2 bary;
                if (intersect_triangle(ray, frame, i, t, bary)) return true;
            }
            enter.x = false;
        }
        if (enter.y && link.w > 0u) {
            for (uint i = link.z; i < link.z + link.w; ++i) {
                vec2 bary;
                if (intersect_triangle(ray, frame, i, t, bary)) return true;
            }
            enter.y = false;
        }
        if (enter.x && enter.y && sp < LIFT_BVH_STACK) {
            stack_node[sp++] = link.z;
            node = link.x;
            continue;
        }
        if (enter.x || enter.y) {
            node = enter.x ? link.x : link.z;
            continue;
        }
        if (sp == 0) return false;
        node = stack_node[--sp];
    }
    return false;
}

#endif
