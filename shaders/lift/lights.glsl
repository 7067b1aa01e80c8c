// lift/lights.glsl: next event estimation. sample_light picks a kind of light (the
// environment, the distant lights or the emissive primitives) with the probabilities the
// host computed (lift_gl/scene/light_choice.py), then one light of that kind: emissive
// primitives by power (the CDF in `lights`) or with LIFT_LIGHT_TREE by their importance
// at p (lift/light_tree.glsl); a point uniformly on the
// picked triangle, or for a sphere a direction uniform in the cone it subtends (uniform on
// its area from inside); the environment uniformly over the sphere, or, with an
// environment map, by the map's luminance (lift_gl/scene/envmap.py); a distant light by its power.
// Every sampler has its pdf beside it.
#ifndef LIFT_LIGHTS_GLSL
#define LIFT_LIGHTS_GLSL
#include "lift/surface.glsl"
#include "lift/sampling.glsl"
#ifdef LIFT_LIGHT_TREE
#include "lift/light_tree.glsl"
#endif

// A direction towards a light, chosen by sample_light from a shaded point.
struct LightSample {
    vec3 wi;        // world direction towards the light
    float dist;     // distance to the light point (1e30 for the environment)
    vec3 radiance;  // radiance arriving along -wi (a distant light: irradiance)
    float pdf;      // solid-angle pdf of this direction, light choice included; for a delta
                    // light (is_delta) the discrete probability of choosing it
    bool is_delta;  // a distant light: no MIS (BSDF sampling can never find it)
};

// Unnormalised weights of choosing the environment (x), the distant lights (y) or the
// emissive primitives (z); only the kinds compiled in take part.
uniform vec4 u_light_weights;

#define LIFT_MAX_DISTANT 4
uniform uint u_num_distant;
uniform vec4 u_distant_dir[LIFT_MAX_DISTANT];         // xyz: unit direction towards the light; w: cumulative choice probability
uniform vec4 u_distant_irradiance[LIFT_MAX_DISTANT];  // rgb: irradiance facing the light; w: choice probability

// Probabilities of the three kinds (environment, distant, emissive primitives).
vec3 light_kind_probabilities() {
    vec3 w = vec3(0.0);
#ifdef HAS_ENVIRONMENT
    w.x = u_light_weights.x;
#endif
#ifdef HAS_DISTANT_LIGHTS
    w.y = u_num_distant > 0u ? u_light_weights.y : 0.0;
#endif
#ifdef HAS_EMISSIVE
    w.z = u_num_lights > 0u ? u_light_weights.z : 0.0;
#endif
    float total = w.x + w.y + w.z;
    return total > 0.0 ? w / total : vec3(0.0);
}

// Probability of choosing the environment rather than another kind of light.
float env_choice_probability() { return light_kind_probabilities().x; }

// The emissive primitive (an index into `lights`) whose slice of the power CDF holds u.
uint pick_light(float u) {
    // Binary search of the first entry whose cumulative probability exceeds u.
    uint lo = 0u, hi = u_num_lights - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (u < lights[mid].y) hi = mid; else lo = mid + 1u;
    }
    return lo;
}

#ifdef HAS_ENVIRONMENT_MAP
// ---- Environment map: piecewise-constant 2D distribution over the lat-long image ----
// Layout and conventions: lift_gl/scene/images.py and envmap.py.
uniform uvec2 u_env_map_size;     // width, height; 0: no map (constant u_env_radiance)
uniform uvec4 u_env_map_offsets;  // words of: texels (RGBA float), marginal pdf + cdf + guide, conditional pdfs, conditional cdfs + guides
uniform mat3 u_env_to_world;      // the map's frame to world (orthonormal)
uniform mat3 u_env_from_world;

// Word i of the images buffer as a float (the map's tables).
float env_word(uint i) { return uintBitsToFloat(images[i]); }

// The last i in [0, n - 1] with cdf[i] <= u, for u in [0, 1) and cdf[n] = 1: then
// cdf[i] <= u < cdf[i + 1], so the chosen cell never has zero probability. The binary search
// runs between the first and last cell of u's bucket in the guide table (words from `guide`,
// envmap.search_guides): the same cell as a search of the whole cdf, in a step or two.
uint env_search_cdf(uint cdf, uint guide, uint n, float u) {
    uint g = images[guide + min(uint(u * float(n)), n - 1u)];
    uint lo = g & 0xffffu, hi = lo + (g >> 16u);
    while (lo < hi) {
        uint mid = (lo + hi + 1u) >> 1u;
        if (env_word(cdf + mid) <= u) lo = mid; else hi = mid - 1u;
    }
    return lo;
}

// The direction (the map's frame) of lat-long coordinates uv: u around the y axis from -z,
// v from +y (0) down to -y (1).
vec3 env_map_direction(vec2 uv) {
    float phi = 2.0 * LIFT_PI * uv.x, theta = LIFT_PI * uv.y;
    float s = sin(theta);
    return vec3(s * sin(phi), cos(theta), -s * cos(phi));
}

// The lat-long coordinates of unit direction d (the map's frame): env_map_direction inverted.
vec2 env_map_uv(vec3 d) {
    float u = atan(d.x, -d.z) * (0.5 * LIFT_INV_PI);
    return vec2(u < 0.0 ? u + 1.0 : u, acos(clamp(d.y, -1.0, 1.0)) * LIFT_INV_PI);
}

// Texel (x, y) of the map, linear RGB, row 0 at the top.
vec3 env_texel(int x, int y) {
    return uintBitsToFloat(images4[(u_env_map_offsets.x >> 2u) + uint(y * int(u_env_map_size.x) + x)].xyz);
}

// Bilinear between texel centres, repeating in u, clamped in v.
vec3 env_map_lookup(vec2 uv) {
    int w = int(u_env_map_size.x), h = int(u_env_map_size.y);
    vec2 p = uv * vec2(w, h) - 0.5;
    vec2 p0 = floor(p);
    vec2 f = p - p0;
    int x0 = int(mod(p0.x, float(w)));
    x0 = clamp(x0, 0, w - 1);
    int x1 = x0 + 1 == w ? 0 : x0 + 1;
    int y0 = clamp(int(p0.y), 0, h - 1), y1 = clamp(int(p0.y) + 1, 0, h - 1);
    vec3 top = mix(env_texel(x0, y0), env_texel(x1, y0), f.x);
    vec3 bottom = mix(env_texel(x0, y1), env_texel(x1, y1), f.x);
    return mix(top, bottom, f.y);
}

// Density over (u, v) in [0, 1]^2 of the cell holding uv.
float env_map_pdf_uv(vec2 uv) {
    uint w = u_env_map_size.x, h = u_env_map_size.y;
    uint x = min(uint(uv.x * float(w)), w - 1u), y = min(uint(uv.y * float(h)), h - 1u);
    return env_word(u_env_map_offsets.y + y) * env_word(u_env_map_offsets.z + y * w + x);
}

// A direction (world) with its solid-angle pdf (the map's choice only, not the kind's) and the
// map's value there, looked up at the sampled (u, v) rather than at the direction's (which
// would cost an atan and an acos to find the same point again, up to their rounding).
bool sample_env_map(vec2 u, out vec3 wi, out float pdf, out vec3 texel) {
    uint w = u_env_map_size.x, h = u_env_map_size.y;
    uint marginal_cdf = u_env_map_offsets.y + h;
    uint y = env_search_cdf(marginal_cdf, marginal_cdf + h + 1u, h, u.x);
    float c0 = env_word(marginal_cdf + y), c1 = env_word(marginal_cdf + y + 1u);
    float dv = clamp((u.x - c0) / (c1 - c0), 0.0, 1.0);
    uint row_cdf = u_env_map_offsets.w + y * (w + 1u);
    uint x = env_search_cdf(row_cdf, u_env_map_offsets.w + h * (w + 1u) + y * w, w, u.y);
    float d0 = env_word(row_cdf + x), d1 = env_word(row_cdf + x + 1u);
    float du = clamp((u.y - d0) / (d1 - d0), 0.0, 1.0);
    vec2 uv = vec2((float(x) + du) / float(w), (float(y) + dv) / float(h));
    float sin_theta = sin(LIFT_PI * uv.y);
    float pdf_uv = env_word(u_env_map_offsets.y + y) * env_word(u_env_map_offsets.z + y * w + x);
    if (!(sin_theta > 0.0) || !(pdf_uv > 0.0)) return false;
    wi = normalize(u_env_to_world * env_map_direction(uv));
    pdf = pdf_uv / (2.0 * LIFT_PI * LIFT_PI * sin_theta);
    texel = env_map_lookup(uv);
    return true;
}

// Solid-angle pdf with which sample_env_map produces the world direction wi.
float env_map_pdf(vec3 wi) {
    vec3 d = normalize(u_env_from_world * wi);
    float sin_theta = sqrt(max(0.0, d.x * d.x + d.z * d.z));
    if (!(sin_theta > 0.0)) return 0.0;
    return env_map_pdf_uv(env_map_uv(d)) / (2.0 * LIFT_PI * LIFT_PI * sin_theta);
}
#endif

// (declared here for the samplers above; defined at the end of this file)
vec3 env_radiance(vec3 wi);

#ifdef HAS_ENVIRONMENT
// A direction towards the environment (world), its solid-angle pdf, the choice of the
// environment among the kinds of light excluded (by the map's luminance, else uniform), and
// the radiance arriving from it (env_radiance(wi)).
bool sample_env_direction(vec2 u, out vec3 wi, out float pdf, out vec3 radiance) {
    radiance = u_env_radiance;
#ifdef HAS_ENVIRONMENT_MAP
    if (u_env_map_size.x > 0u) {
        vec3 texel;
        bool ok = sample_env_map(u, wi, pdf, texel) && pdf > 0.0 && pdf < 1e30;
        radiance *= texel;
        return ok;
    }
#endif
    wi = sample_uniform_sphere(u);
    pdf = pdf_uniform_sphere(wi);
    return true;
}
#endif

#ifdef HAS_DISTANT_LIGHTS
// One of the distant lights, by power: v uniform in [0, 1).
uint pick_distant(float v) {
    uint k = 0u;
    while (k + 1u < u_num_distant && v >= u_distant_dir[k].w) ++k;
    return k;
}
#endif

#if defined(HAS_EMISSIVE) && defined(HAS_SPHERES)
// ---- The cone of directions that a sphere (centre cr.xyz, radius cr.w) subtends at p ----
// False where p is inside (or on) the sphere. one_minus_cos_max = 1 - cos(half angle), in a
// form without cancellation for small, far spheres: sin^2 / (1 + cos).
bool sphere_cone(vec3 p, vec4 cr, out float one_minus_cos_max) {
    vec3 d = cr.xyz - p;
    float dc2 = dot(d, d), r2 = cr.w * cr.w;
    one_minus_cos_max = 0.0;
#ifdef LIFT_SPHERE_AREA_LIGHTS
    return false;  // the old sampler, uniform on the area, kept for comparisons (tests)
#endif
    if (!(dc2 > r2 * 1.0001)) return false;
    float sin2_max = r2 / dc2;
    one_minus_cos_max = sin2_max / (1.0 + sqrt(1.0 - sin2_max));
    return one_minus_cos_max > 0.0;
}

// A direction uniform in that cone (solid-angle density 1 / (2 pi one_minus_cos_max)) and
// the distance along it to the near side of the sphere.
bool sample_sphere_cone(vec3 p, vec4 cr, float one_minus_cos_max, vec2 u, out vec3 wi, out float dist) {
    vec3 d = cr.xyz - p;
    float dc = length(d);
    vec3 axis = d / dc;
    float t = u.x * one_minus_cos_max;           // 1 - cos(theta), uniform
    float cos_t = 1.0 - t, sin2_t = t * (2.0 - t);
    float sin_t = sqrt(max(sin2_t, 0.0)), phi = 2.0 * LIFT_PI * u.y;
    vec3 a = abs(axis.x) > 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 tx = normalize(cross(a, axis)), ty = cross(axis, tx);
    wi = normalize(cos_t * axis + sin_t * (cos(phi) * tx + sin(phi) * ty));
    // Nearest root of |p + s wi - c| = r; the discriminant vanishes only at the silhouette.
    float disc = max(cr.w * cr.w - dc * dc * sin2_t, 0.0);
    dist = dc * cos_t - sqrt(disc);
    return dist > 0.0;
}
#endif

// Next event estimation from world point p: chooses a kind of light and a light (u.x), then a
// direction towards it (u.yz), as the file's header says. ls.wi points from p towards the
// light, ls.dist is how far (1e30 at infinity: trace spawn_shadow_ray(s, ls.wi, ls.dist)),
// ls.radiance what arrives along -ls.wi if nothing blocks it, and ls.pdf the solid-angle
// density (light choice included; for a distant light, ls.is_delta, the discrete
// probability). False when there is no sample (no light, the back of an emitter).
// light_pdf and env_light_pdf give the density of a direction found otherwise.
bool sample_light(vec3 p, vec3 u, out LightSample ls) {
    ls.pdf = 0.0;
    ls.is_delta = false;
    vec3 kind = light_kind_probabilities();
#ifdef HAS_ENVIRONMENT
    // ---- The environment ----
    if (u.x < kind.x) {
        ls.dist = 1e30;
        float pdf;
        if (!sample_env_direction(u.yz, ls.wi, pdf, ls.radiance)) return false;
        ls.pdf = kind.x * pdf;
        return ls.pdf > 0.0 && ls.pdf < 1e30;
    }
#endif
    u.x -= kind.x;
#ifdef HAS_DISTANT_LIGHTS
    // ---- A distant light: a delta in direction ----
    if (u.x < kind.y) {
        uint k = pick_distant(u.x / kind.y);
        ls.wi = u_distant_dir[k].xyz;
        ls.dist = 1e30;
        ls.radiance = u_distant_irradiance[k].rgb;
        ls.pdf = kind.y * u_distant_irradiance[k].w;
        ls.is_delta = true;
        return ls.pdf > 0.0;
    }
#endif
    u.x -= kind.y;
#ifdef HAS_EMISSIVE
    // ---- An emissive primitive ----
    if (u_num_lights == 0u || !(kind.z > 0.0)) return false;
#ifdef LIFT_LIGHT_TREE
    uint index;
    float pick_pdf;
    if (!light_tree_pick(p, clamp(u.x / kind.z, 0.0, 0.99999994), index, pick_pdf)) return false;
    vec4 light = lights[index];
    float select_pdf = pick_pdf * kind.z;
#else
    uint index = pick_light(clamp(u.x / kind.z, 0.0, 1.0));
    vec4 light = lights[index];
    float select_pdf = light.z * kind.z;
#endif
    uint prim = floatBitsToUint(light.x);
    vec3 point, n;
    uint material;
    if (prim < u_num_triangles) {
        vec2 b = sample_uniform_triangle(u.yz);
        uint i = 3u * prim;
        vec3 p0 = tri_pos_row(i).xyz, p1 = tri_pos_row(i + 1u).xyz, p2 = tri_pos_row(i + 2u).xyz;
        point = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2 + prim_displacement(prim);
        n = normalize(cross(p1 - p0, p2 - p0));
        material = tri_info_at(prim).x;
    }
#ifdef HAS_SPHERES
    else {
        vec4 cr = spheres[2u * (prim - u_num_triangles)];
        cr.xyz += prim_displacement(prim);
        material = floatBitsToUint(spheres[2u * (prim - u_num_triangles) + 1u].x);
        float one_minus_cos_max;
        if (sphere_cone(p, cr, one_minus_cos_max)) {
            // Outside: a direction uniform in the cone the sphere subtends, so that every
            // sample lands on the visible cap (area sampling wastes half on the far side).
            if (!sample_sphere_cone(p, cr, one_minus_cos_max, u.yz, ls.wi, ls.dist)) return false;
            ls.radiance = materials[material].emission_alpha.rgb;
            ls.pdf = select_pdf / (2.0 * LIFT_PI * one_minus_cos_max);
            return ls.pdf > 0.0 && ls.pdf < 1e30;
        }
        // Inside (or on it): uniform on the area, as for triangles; from inside the one-sided
        // emission faces away, and the test below rejects the sample.
        n = sample_uniform_sphere(u.yz);
        point = cr.xyz + cr.w * n;
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
    if (light.light_select_pdf <= 0.0) return 0.0;
#ifdef LIFT_LIGHT_TREE
    float select_pdf = light_tree_pdf(p, light.prim);
#else
    float select_pdf = light.light_select_pdf;
#endif
#if defined(HAS_EMISSIVE) && defined(HAS_SPHERES)
    if (light.prim >= u_num_triangles) {
        vec4 cr = spheres[2u * (light.prim - u_num_triangles)];
        cr.xyz += prim_displacement(light.prim);
        float one_minus_cos_max;
        if (sphere_cone(p, cr, one_minus_cos_max))
            return light_kind_probabilities().z * select_pdf / (2.0 * LIFT_PI * one_minus_cos_max);
    }
#endif
    float cos_light = abs(dot(wi, light.ng));
    if (cos_light <= 0.0) return 0.0;
    return light_kind_probabilities().z * select_pdf * dist * dist / (light.area * cos_light);
}

// Solid-angle pdf with which sample_light produces the escaping direction wi.
float env_light_pdf(vec3 wi) {
#ifdef HAS_ENVIRONMENT
#ifdef HAS_ENVIRONMENT_MAP
    if (u_env_map_size.x > 0u) return env_choice_probability() * env_map_pdf(wi);
#endif
    return env_choice_probability() * pdf_uniform_sphere(wi);
#else
    return 0.0;
#endif
}

// Radiance arriving from the environment along -wi (wi: world, towards the environment).
vec3 env_radiance(vec3 wi) {
#ifdef HAS_ENVIRONMENT
#ifdef HAS_ENVIRONMENT_MAP
    if (u_env_map_size.x > 0u) return u_env_radiance * env_map_lookup(env_map_uv(normalize(u_env_from_world * wi)));
#endif
    return u_env_radiance;
#else
    return vec3(0.0);
#endif
}
#endif
