// lift/emission.glsl: light leaving the lights, for light tracing and bidirectional methods.
// lights.glsl samples a direction towards a light as seen from a point (next event
// estimation); this file samples the light itself:
//   sample_light_point  a point on an emitter (picked by power, uniform on its area), or a
//                       direction towards a light at infinity: the environment (uniform, or
//                       by an environment map's luminance) or a distant light (by power);
//                       pdf_light_point and env_light_pdf (lights.glsl) give its density.
//   sample_emission     a ray leaving a light: from an emitter point, a cosine-weighted
//                       direction about its front normal (pdf_emission_dir); from a light at
//                       infinity, a ray along the sampled direction whose origin is uniform on
//                       a disk of the scene's bounding radius across it (pdf_env_emission_pos),
//                       as pbrt-v3 samples its infinite lights.
// The kind of light and the light are chosen with the probabilities next event estimation
// uses (light_kind_probabilities), so both see the same lights as one distribution.
#ifndef LIFT_EMISSION_GLSL
#define LIFT_EMISSION_GLSL
#include "lift/lights.glsl"
#include "lift/frame.glsl"

uniform vec3 u_scene_center;  // bounding sphere of the scene (the host sets both)
uniform float u_scene_radius;

// A point on a light, or a direction towards a light at infinity (sample_light_point).
struct LightPoint {
    vec3 p;         // a point on an emitter; at infinity, the unit direction towards the light
    vec3 n;         // the emitter's front normal there (unused at infinity)
    vec3 radiance;  // radiance leaving the point from its front; of the environment along -p;
                    // a distant light's irradiance
    float pdf;      // area density of p, light choice included; environment: solid-angle
                    // density of the direction, choice included; distant light: the discrete
                    // probability of choosing it
    bool infinite;  // the environment or a distant light: p is a direction
    bool delta;     // a distant light: a delta in direction, which no path can hit
};

// ---- A point on a light (or a direction to a light at infinity) ----
// A point on a light chosen as next event estimation chooses them (u.x picks the kind and
// the light, u.yz the point or direction); false when there is none.
bool sample_light_point(vec3 u, out LightPoint lp) {
    lp = LightPoint(vec3(0.0), vec3(0.0), vec3(0.0), 0.0, false, false);
    vec3 kind = light_kind_probabilities();
#ifdef HAS_ENVIRONMENT
    if (u.x < kind.x) {
        float pdf;
        if (!sample_env_direction(u.yz, lp.p, pdf, lp.radiance)) return false;
        lp.pdf = kind.x * pdf;
        lp.infinite = true;
        return lp.pdf > 0.0 && lp.pdf < 1e30;
    }
#endif
    u.x -= kind.x;
#ifdef HAS_DISTANT_LIGHTS
    if (u.x < kind.y) {
        uint k = pick_distant(u.x / kind.y);
        lp.p = u_distant_dir[k].xyz;
        lp.radiance = u_distant_irradiance[k].rgb;
        lp.pdf = kind.y * u_distant_irradiance[k].w;
        lp.infinite = true;
        lp.delta = true;
        return lp.pdf > 0.0;
    }
#endif
    u.x -= kind.y;
#ifdef HAS_EMISSIVE
    if (u_num_lights == 0u || !(kind.z > 0.0)) return false;
    vec4 light = lights[pick_light(clamp(u.x / kind.z, 0.0, 1.0))];
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
    lp.pdf = kind.z * light.z / light.w;  // choice x 1 / area
    return lp.pdf > 0.0 && lp.pdf < 1e30;
#else
    return false;
#endif
}

// Area density with which sample_light_point picks the point of emitter surface `s`.
float pdf_light_point(Surface s) {
    if (s.light_select_pdf <= 0.0 || !(s.area > 0.0)) return 0.0;
    return light_kind_probabilities().z * s.light_select_pdf / s.area;
}

// ---- A ray leaving a light ----
// A ray leaving a light (sample_emission), with the densities of its origin and direction.
struct EmissionSample {
    Ray ray;        // leaves the light (from an emitter: offset off its surface)
    LightPoint light;
    float pdf_pos;  // area density of the origin (emitter: light.pdf; at infinity: the disk's)
    float pdf_dir;  // solid-angle density of ray.dir (at infinity: light.pdf)
};

// Solid-angle density of a direction leaving an emitter with front normal n.
float pdf_emission_dir(vec3 n, vec3 dir) {
    return max(dot(n, dir), 0.0) * LIFT_INV_PI;
}

// Area density of the origin of a ray from infinity on its disk (radius: the scene's
// bounding sphere); a surface point hit by it has the density times |cos| there.
float pdf_env_emission_pos() {
    return LIFT_INV_PI / (u_scene_radius * u_scene_radius);
}

// A ray leaving a light: its point from u_point (sample_light_point), its direction from
// u_dir (see the file's header). False when there is none.
bool sample_emission(vec3 u_point, vec2 u_dir, out EmissionSample es) {
    es.ray = Ray(vec3(0.0), vec3(0.0, 0.0, 1.0), 0.0, 1e30);
    es.pdf_pos = 0.0;
    es.pdf_dir = 0.0;
    if (!sample_light_point(u_point, es.light)) return false;
    if (es.light.infinite) {
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
