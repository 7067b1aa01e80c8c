// lift/lights.glsl: next event estimation. Emissive primitives are picked in proportion to
// their power (the CDF in `lights`), then a point uniformly on the picked one; the constant
// environment is sampled uniformly over the sphere. Every sampler has its pdf beside it.
#ifndef LIFT_LIGHTS_GLSL
#define LIFT_LIGHTS_GLSL
#include "lift/surface.glsl"
#include "lift/sampling.glsl"

struct LightSample {
    vec3 wi;        // world direction towards the light
    float dist;     // distance to the light point (1e30 for the environment)
    vec3 radiance;  // radiance arriving along -wi
    float pdf;      // solid-angle pdf of this direction, light choice included
};

// Probability of choosing the environment rather than an emissive primitive.
float env_choice_probability() {
#if defined(HAS_ENVIRONMENT) && defined(HAS_EMISSIVE)
    return u_num_lights > 0u ? 0.5 : 1.0;
#elif defined(HAS_ENVIRONMENT)
    return 1.0;
#else
    return 0.0;
#endif
}

uint pick_light(float u) {
    // Binary search of the first entry whose cumulative probability exceeds u.
    uint lo = 0u, hi = u_num_lights - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (u < lights[mid].y) hi = mid; else lo = mid + 1u;
    }
    return lo;
}

bool sample_light(vec3 p, vec3 u, out LightSample ls) {
    ls.pdf = 0.0;
    float p_env = env_choice_probability();
#ifdef HAS_ENVIRONMENT
    if (u.x < p_env) {
        ls.wi = sample_uniform_sphere(u.yz);
        ls.dist = 1e30;
        ls.radiance = u_env_radiance;
        ls.pdf = p_env * pdf_uniform_sphere(ls.wi);
        return true;
    }
    u.x = (u.x - p_env) / (1.0 - p_env);
#endif
#ifdef HAS_EMISSIVE
    if (u_num_lights == 0u) return false;
    uint index = pick_light(u.x);
    vec4 light = lights[index];
    uint prim = floatBitsToUint(light.x);
    float select_pdf = light.z * (1.0 - p_env);
    vec3 point, n;
    uint material;
    if (prim < u_num_triangles) {
        vec2 b = sample_uniform_triangle(u.yz);
        uint i = 3u * prim;
        vec3 p0 = tri_pos[i].xyz, p1 = tri_pos[i + 1u].xyz, p2 = tri_pos[i + 2u].xyz;
        point = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2 + prim_displacement(prim);
        n = normalize(cross(p1 - p0, p2 - p0));
        material = tri_info[prim].x;
    }
#ifdef HAS_SPHERES
    else {
        vec4 cr = spheres[2u * (prim - u_num_triangles)];
        n = sample_uniform_sphere(u.yz);
        point = cr.xyz + prim_displacement(prim) + cr.w * n;
        material = floatBitsToUint(spheres[2u * (prim - u_num_triangles) + 1u].x);
    }
#else
    else return false;
#endif
    vec3 to_light = point - p;
    float dist2 = dot(to_light, to_light);
    if (!(dist2 > 0.0)) return false;
    ls.dist = sqrt(dist2);
    ls.wi = to_light / ls.dist;
    float cos_light = -dot(ls.wi, n);
    if (cos_light <= 0.0) return false;  // the back of a one-sided emitter
    ls.radiance = materials[material].emission_alpha.rgb;
    ls.pdf = select_pdf * dist2 / (light.w * cos_light);
    return ls.pdf > 0.0 && ls.pdf < 1e30;
#else
    return false;
#endif
}

// Solid-angle pdf with which sample_light, called at p, would produce the direction wi
// that hit the emitter surface `light` at distance dist.
float light_pdf(vec3 p, Surface light, vec3 wi, float dist) {
    float cos_light = abs(dot(wi, light.ng));
    if (light.light_select_pdf <= 0.0 || cos_light <= 0.0) return 0.0;
    return (1.0 - env_choice_probability()) * light.light_select_pdf * dist * dist / (light.area * cos_light);
}

// Solid-angle pdf with which sample_light produces the escaping direction wi.
float env_light_pdf(vec3 wi) {
#ifdef HAS_ENVIRONMENT
    return env_choice_probability() * pdf_uniform_sphere(wi);
#else
    return 0.0;
#endif
}

vec3 env_radiance(vec3 wi) {
#ifdef HAS_ENVIRONMENT
    return u_env_radiance;
#else
    return vec3(0.0);
#endif
}
#endif
