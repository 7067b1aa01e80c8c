// lift/emission.glsl: light leaving the lights, for light tracing and bidirectional methods.
// lights.glsl samples a direction towards a light as seen from a point (next event
// estimation); this file samples the light itself:
//   sample_light_point  a point on an emitter (picked by power, uniform on its area), or a
//                       direction towards the constant environment; pdf_light_point and
//                       pdf_light_env_dir give its density.
//   sample_emission     a ray leaving a light: from an emitter point, a cosine-weighted
//                       direction about its front normal (pdf_emission_dir); from the
//                       environment, a direction uniform over the sphere and an origin
//                       uniform on a disk of the scene's bounding radius across it
//                       (pdf_env_emission_pos).
// The emitter and the environment are chosen with the probabilities next event estimation
// uses (env_choice_probability), so both see the same light as one distribution.
#ifndef LIFT_EMISSION_GLSL
#define LIFT_EMISSION_GLSL
#if defined(HAS_ENVIRONMENT_MAP) || defined(HAS_DISTANT_LIGHTS)
#error light subpaths (bdpt) start only from emissive primitives and a constant environment: environment maps and distant lights are not supported yet
#endif
#include "lift/lights.glsl"
#include "lift/frame.glsl"

uniform vec3 u_scene_center;  // bounding sphere of the scene (the host sets both)
uniform float u_scene_radius;

struct LightPoint {
    vec3 p;         // a point on an emitter; for the environment, the unit direction towards it
    vec3 n;         // the emitter's front normal there (unused for the environment)
    vec3 radiance;  // radiance leaving the point from its front; of the environment
    float pdf;      // area density of p, light choice included; environment: solid-angle
                    // density of the direction, choice included
    bool is_env;
};

// ---- A point on a light (or a direction to the environment) ----
bool sample_light_point(vec3 u, out LightPoint lp) {
    lp = LightPoint(vec3(0.0), vec3(0.0), vec3(0.0), 0.0, false);
    float p_env = env_choice_probability();
#ifdef HAS_ENVIRONMENT
    if (u.x < p_env) {
        lp.p = sample_uniform_sphere(u.yz);
        lp.radiance = u_env_radiance;
        lp.pdf = p_env * pdf_uniform_sphere(lp.p);
        lp.is_env = true;
        return true;
    }
    u.x = (u.x - p_env) / (1.0 - p_env);
#endif
#ifdef HAS_EMISSIVE
    if (u_num_lights == 0u) return false;
    vec4 light = lights[pick_light(u.x)];
    uint prim = floatBitsToUint(light.x);
    uint material;
    if (prim < u_num_triangles) {
        vec2 b = sample_uniform_triangle(u.yz);
        uint i = 3u * prim;
        vec3 p0 = tri_pos_row(i).xyz, p1 = tri_pos_row(i + 1u).xyz, p2 = tri_pos_row(i + 2u).xyz;
        lp.p = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
        lp.n = normalize(cross(p1 - p0, p2 - p0));
        material = tri_info_at(prim).x;
    }
#ifdef HAS_SPHERES
    else {
        uint k = prim - u_num_triangles;
        vec4 cr = spheres[2u * k];
        lp.n = sample_uniform_sphere(u.yz);
        lp.p = cr.xyz + cr.w * lp.n;
        material = floatBitsToUint(spheres[2u * k + 1u].x);
    }
#else
    else return false;
#endif
    lp.radiance = materials[material].emission_alpha.rgb;
    lp.pdf = (1.0 - p_env) * light.z / light.w;  // choice x 1 / area
    return lp.pdf > 0.0 && lp.pdf < 1e30;
#else
    return false;
#endif
}

// Area density with which sample_light_point picks the point of emitter surface `s`.
float pdf_light_point(Surface s) {
    if (s.light_select_pdf <= 0.0 || !(s.area > 0.0)) return 0.0;
    return (1.0 - env_choice_probability()) * s.light_select_pdf / s.area;
}

// Solid-angle density with which sample_light_point picks a direction to the environment.
float pdf_light_env_dir() {
    return env_choice_probability() * LIFT_INV_4PI;
}

// ---- A ray leaving a light ----
struct EmissionSample {
    Ray ray;        // leaves the light (from an emitter: offset off its surface)
    LightPoint light;
    float pdf_pos;  // area density of the origin (emitter: light.pdf; environment: the disk's)
    float pdf_dir;  // solid-angle density of ray.dir (environment: light.pdf)
};

// Solid-angle density of a direction leaving an emitter with front normal n.
float pdf_emission_dir(vec3 n, vec3 dir) {
    return max(dot(n, dir), 0.0) * LIFT_INV_PI;
}

// Area density of the origin of an environment ray on its disk (radius: the scene's
// bounding sphere); a surface point hit by it has the density times |cos| there.
float pdf_env_emission_pos() {
    return LIFT_INV_PI / (u_scene_radius * u_scene_radius);
}

bool sample_emission(vec3 u_point, vec2 u_dir, out EmissionSample es) {
    es.ray = Ray(vec3(0.0), vec3(0.0, 0.0, 1.0), 0.0, 1e30);
    es.pdf_pos = 0.0;
    es.pdf_dir = 0.0;
    if (!sample_light_point(u_point, es.light)) return false;
    if (es.light.is_env) {
        // Light arrives from direction w, so it travels along -w; its rays cross a disk
        // perpendicular to w that covers the bounding sphere.
        vec3 w = es.light.p;
        Frame f = frame_from_normal(w);
        vec2 d = sample_concentric_disk(u_dir) * u_scene_radius;
        vec3 origin = u_scene_center + u_scene_radius * w + d.x * f.t + d.y * f.b;
        es.ray = Ray(origin, -w, 0.0, 1e30);
        es.pdf_pos = pdf_env_emission_pos();
        es.pdf_dir = es.light.pdf;
        return true;
    }
    Frame f = frame_from_normal(es.light.n);
    vec3 dir = to_world(f, sample_cosine_hemisphere(u_dir));
    es.pdf_dir = pdf_emission_dir(es.light.n, dir);
    if (!(es.pdf_dir > 0.0)) return false;
    es.ray = Ray(offset_ray_origin(es.light.p, es.light.n), dir, 0.0, 1e30);
    es.pdf_pos = es.light.pdf;
    return true;
}
#endif
