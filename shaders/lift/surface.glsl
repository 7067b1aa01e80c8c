// lift/surface.glsl: from a ray hit to the surface it hit (position, normals, material),
// and robust ray offsets for rays that leave that surface.
#ifndef LIFT_SURFACE_GLSL
#define LIFT_SURFACE_GLSL
#include "lift/trace.glsl"
#include "lift/frame.glsl"
#include "lift/textures.glsl"

// A surface point a ray hit, in world space (surface_at).
struct Surface {
    vec3 p;                  // world position
    vec3 ng;                 // geometric normal, unit; for triangles from the winding, for spheres outward
    vec3 ns;                 // shading normal, unit, in the same hemisphere as ng
    vec2 uv;                 // texture coordinates (OpenGL's: (0, 0) is the image's bottom-left)
    uint material;           // index into `materials`: material_at(s.material, s.uv) applies its texture
    uint prim;               // the hit's primitive (triangle id, or u_num_triangles + sphere index)
#ifdef HAS_INSTANCES
    uint instance;           // the hit's instance (NO_INSTANCE: world geometry)
#endif
    float light_select_pdf;  // probability that light sampling picks this primitive (0: not a light)
    float area;              // primitive area, for light pdfs
};

// The surface that `hit` (a hit of `ray`, not NO_HIT) found: position, normals, texture
// coordinates and material, interpolated over the triangle (or exact on a sphere). The
// position comes from the barycentrics, not from ray.origin + hit.t * ray.dir, which is less
// accurate far from the camera.
Surface surface_at(Ray ray, Hit hit) {
    Surface s;
    s.prim = hit.prim;
#ifdef HAS_INSTANCES
    s.instance = NO_INSTANCE;
#endif
    if (hit.prim < u_num_triangles) {
        uint i = 3u * hit.prim;
        vec3 moved = prim_displacement(hit.prim);
        vec3 p0 = tri_pos_row(i).xyz + moved, p1 = tri_pos_row(i + 1u).xyz + moved, p2 = tri_pos_row(i + 2u).xyz + moved;
        vec3 n0 = tri_normal_row(i).xyz, n1 = tri_normal_row(i + 1u).xyz, n2 = tri_normal_row(i + 2u).xyz;
#ifdef HAS_INSTANCES
        s.instance = hit.instance;
        if (hit.instance != NO_INSTANCE) {  // object space to world: corners, and normals by the inverse transpose
            p0 = instance_point_to_world(hit.instance, p0);
            p1 = instance_point_to_world(hit.instance, p1);
            p2 = instance_point_to_world(hit.instance, p2);
            n0 = instance_normal_to_world(hit.instance, n0);
            n1 = instance_normal_to_world(hit.instance, n1);
            n2 = instance_normal_to_world(hit.instance, n2);
        }
#endif
        float b0 = 1.0 - hit.bary.x - hit.bary.y;
        // The barycentric point is more accurate than origin + t * dir far from the camera.
        s.p = b0 * p0 + hit.bary.x * p1 + hit.bary.y * p2;
        vec3 n = cross(p1 - p0, p2 - p0);
#ifdef HAS_INSTANCES
        // A mirroring transform turns the winding around: keep the front where the author's was.
        if (hit.instance != NO_INSTANCE && instance_info(hit.instance).w != 0u) n = -n;
#endif
        float len = length(n);
        s.ng = len > 0.0 ? n / len : -ray.dir;
        s.area = 0.5 * len;
        vec3 ns = b0 * n0 + hit.bary.x * n1 + hit.bary.y * n2;
        float ns_len = length(ns);
        s.ns = ns_len > 0.0 ? ns / ns_len : s.ng;
        if (dot(s.ns, s.ng) < 0.0) s.ns = -s.ns;  // authored normals may disagree with the winding
        s.uv = b0 * tri_uv_row(i).xy + hit.bary.x * tri_uv_row(i + 1u).xy + hit.bary.y * tri_uv_row(i + 2u).xy;
        uvec2 info = tri_info_at(hit.prim);
        s.material = info.x;
        s.light_select_pdf = uintBitsToFloat(info.y);
#ifdef HAS_INSTANCES
        if (hit.instance != NO_INSTANCE) s.material = instance_material(hit.instance, hit.prim);
#endif
    }
#ifdef HAS_SPHERES
    else {
        uint k = hit.prim - u_num_triangles;
        vec4 cr = spheres[2u * k];
        cr.xyz += prim_displacement(hit.prim);
        vec3 p = ray.origin + hit.t * ray.dir;
        s.ng = normalize(p - cr.xyz);
        s.p = cr.xyz + cr.w * s.ng;  // re-project onto the sphere
        s.ns = s.ng;
        s.uv = sphere_uv(s.ng);
        s.material = floatBitsToUint(spheres[2u * k + 1u].x);
        s.light_select_pdf = uintBitsToFloat(floatBitsToUint(spheres[2u * k + 1u].y));
        s.area = 4.0 * 3.14159265 * cr.w * cr.w;
    }
#endif
    return s;
}

// Move p off the surface along n, past the rounding error of p, so that rays leaving the
// surface do not hit it again, at any scale and any distance from the origin. That error
// grows with p's own magnitude (a few ulps of p) and with the magnitude of the vertices p
// was interpolated from (`scale`): the step is 2^-15 of the first, 2^-18 of the second,
// both far above the few ulps of error (after Waechter and Binder 2019, with pbrt's
// vertex-magnitude bound for points near zero; tests/test_stress.py checks 1e-3 to 1e4).
vec3 offset_ray_origin_scaled(vec3 p, vec3 n, float scale) {
    vec3 step = max(abs(p) * (1.0 / 32768.0), vec3(scale * (1.0 / 262144.0)));
    return p + step * n;
}

// The same for a point whose vertices are of p's own magnitude, or about 1.
vec3 offset_ray_origin(vec3 p, vec3 n) {
    return offset_ray_origin_scaled(p, n, max(1.0, max(abs(p.x), max(abs(p.y), abs(p.z)))));
}

// Largest |coordinate| among the vertices that s.p was interpolated from.
float surface_coordinate_scale(Surface s) {
    if (s.prim < u_num_triangles) {
        uint i = 3u * s.prim;
        vec3 p0 = tri_pos_row(i).xyz, p1 = tri_pos_row(i + 1u).xyz, p2 = tri_pos_row(i + 2u).xyz;
#ifdef HAS_INSTANCES
        if (s.instance != NO_INSTANCE) {  // the world corners s.p was interpolated from
            p0 = instance_point_to_world(s.instance, p0);
            p1 = instance_point_to_world(s.instance, p1);
            p2 = instance_point_to_world(s.instance, p2);
        }
#endif
        vec3 m = max(max(abs(p0), abs(p1)), abs(p2));
        return max(m.x, max(m.y, m.z));
    }
#ifdef HAS_SPHERES
    vec4 cr = spheres[2u * (s.prim - u_num_triangles)];
    vec3 m = abs(cr.xyz) + vec3(cr.w);
    return max(m.x, max(m.y, m.z));
#else
    return max(abs(s.p.x), max(abs(s.p.y), abs(s.p.z)));
#endif
}

// A ray leaving surface s in direction dir (world space), started on the side dir goes to.
Ray spawn_ray(Surface s, vec3 dir) {
    vec3 n = dot(dir, s.ng) >= 0.0 ? s.ng : -s.ng;
    return Ray(offset_ray_origin_scaled(s.p, n, surface_coordinate_scale(s)), dir, 0.0, 1e30);
}

// A shadow ray from s towards a point at distance dist along dir; stops just short of it.
// It is aimed from the offset origin at the point itself, so that the offset cannot carry
// its end through the light's surface (a light met at a grazing angle, or a large offset).
// Written in units of dist so that nothing overflows for the environment (dist = 1e30).
Ray spawn_shadow_ray(Surface s, vec3 dir, float dist) {
    Ray r = spawn_ray(s, dir);
    vec3 to_target = dir + (s.p - r.origin) / dist;  // (target - origin) / dist
    float len = length(to_target);
    r.dir = to_target / len;
    r.tmax = dist * len * (1.0 - 1e-4);
    return r;
}

// The shading normal of an opaque surface seen from wo (world space, away from it): s.ns
// turned to wo's side of the geometric surface. Where wo is still below that shading
// hemisphere (interpolated or authored normals tilted away from the viewer) the BSDF would
// be zero and the surface black: the geometric normal is used there instead.
vec3 facing_shading_normal(Surface s, vec3 wo) {
    float side = dot(wo, s.ng) >= 0.0 ? 1.0 : -1.0;
    vec3 ns = side * s.ns;
    return dot(wo, ns) > 0.0 ? ns : side * s.ng;
}

// Whether world directions a and b (both away from s) lie on the same side of the true
// surface: an opaque surface reflects only between such directions, whatever its shading
// normal says (light sampling and BSDF sampling must agree on this, or MIS is biased).
bool same_side_of_surface(Surface s, vec3 a, vec3 b) { return dot(a, s.ng) * dot(b, s.ng) > 0.0; }

// Whether m is opaque: every material but glass (MAT_DIELECTRIC).
bool is_opaque(Material m) { return int(m.color_type.w) != MAT_DIELECTRIC; }

// The normal to shade s with, seen from wo_world (world, away from the surface). Opaque
// surfaces shade from the side the ray came from (facing_shading_normal, which also rescues
// normals tilted away from the viewer); glass keeps its orientation (s.ns, outward) so that
// wo.z < 0 tells the BSDF the ray is inside.
vec3 shading_normal(Surface s, Material m, vec3 wo_world) {
    return is_opaque(m) ? facing_shading_normal(s, wo_world) : s.ns;
}

// The local frame to shade s in (z: shading_normal): to_local(frame, w) gives the BSDF's
// directions, to_world(frame, bs.wi) a sampled one back in world space.
Frame shading_frame(Surface s, Material m, vec3 wo_world) {
    return frame_from_normal(shading_normal(s, m, wo_world));
}

// Radiance emitted by s towards direction w (world space); emitters emit from the front.
vec3 surface_emission(Surface s, vec3 w) {
    return dot(w, s.ng) > 0.0 ? materials[s.material].emission_alpha.rgb : vec3(0.0);
}
#endif
