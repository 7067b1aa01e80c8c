// bdpt: bidirectional path tracing (Veach 1997, ch. 10; the structure of pbrt-v3, ch. 16).
//
// Each sample traces a camera subpath z0 z1 ... (z0 the pinhole, z1 the G-buffer's hit) and a
// light subpath y0 y1 ... (y0 on an emitter picked by power, or a direction of the environment
// or of a distant light, whose ray starts on a disk across the scene: lift/emission.glsl),
// then makes a full path of every pair of prefixes: s light vertices and t camera vertices.
//   s = 0        the camera subpath hit a light by itself
//   s = 1        a fresh light sample joined to z_{t-1} (next event estimation, as in pt)
//   t = 1        y_{s-1} joined to the pinhole: light tracing, splatted to the pixel it lands on
//   otherwise    y_{s-1} joined to z_{t-1} with a shadow ray
// Every (s, t) is an unbiased estimate of the paths it can make; multiple importance sampling
// (bdpt_mis.glsl) weights them so that together they count each path once. Delta vertices
// (mirrors, smooth glass) are never joined; the strategies that would need it get weight 0.
// A distant light is a delta in direction: no camera subpath can hit it (s = 0 gets weight 0),
// but it can be sampled (s = 1) and can start light subpaths (s >= 2, t = 1).
// Parameters (plugin.toml): max_depth, rr_depth, rr_min_survival, mis_power, only_s, only_depth.
#include "lift/emission.glsl"
#include "lift/camera_importance.glsl"
#include "bdpt_vertex.glsl"
#include "bdpt_subpaths.glsl"
#include "bdpt_mis.glsl"

// ---- s = 0: camera vertex t-1 is on a light ----
vec3 strategy_emitted(int t) {
    int z = t - 1;
    PathVertex v = bdpt_path[z];
    vec3 emitted;
    float pt_rev;            // density of the light subpath starting at z_{t-1}
    float pt_minus_rev = 0.0;  // ... and reaching z_{t-2} from there
    if (vertex_kind(z) == VERTEX_ENV) {
        emitted = env_radiance(v.p);
        pt_rev = env_light_pdf(v.p);
        if (t > 2) pt_minus_rev = pdf_env_emission_pos() * abs(dot(bdpt_path[z - 1].ng, v.p));
    } else if (vertex_kind(z) == VERTEX_SURFACE && v.emitter_pdf > 0.0 && dot(v.wo, v.ng) > 0.0) {
        emitted = materials[vertex_material(z)].emission_alpha.rgb;  // emitters emit from the front
        pt_rev = v.emitter_pdf;
        if (t > 2) pt_minus_rev = area_density(pdf_emission_dir(v.ng, v.wo), v.p, z - 1);
    } else {
        return vec3(0.0);
    }
    if (all(equal(emitted, vec3(0.0)))) return vec3(0.0);
    return v.beta * emitted * mis_weight(0, t, pt_rev, pt_minus_rev, 0.0, 0.0, 0.0, false);
}

// ---- s = 1: a light point sampled afresh, joined to camera vertex t-1 ----
vec3 strategy_light_sample(int t, inout Rng rng) {
    int z = t - 1;
    if (!vertex_connectible(z)) return vec3(0.0);
    LightPoint light;
    if (!sample_light_point(rng_next3(rng), light)) return vec3(0.0);
    PathVertex v = bdpt_path[z];
    vec3 wi;                     // from z_{t-1} towards the light
    float dist = 1e30;
    float cos_light_over_d2 = 1.0;  // the light's half of the geometry term (1: at infinity)
    if (light.infinite) {
        wi = light.p;
    } else {
        vec3 d = light.p - v.p;
        float dist2 = dot(d, d);
        if (!(dist2 > 0.0)) return vec3(0.0);
        dist = sqrt(dist2);
        wi = d / dist;
        cos_light_over_d2 = dot(light.n, -wi) / dist2;
        if (cos_light_over_d2 <= 0.0) return vec3(0.0);  // the back of a one-sided emitter
    }
    VertexScatter at_z = vertex_scatter(z, v.wo, wi, false);
    vec3 contribution = v.beta * at_z.f * light.radiance * (cos_light_over_d2 / light.pdf);
    if (all(equal(contribution, vec3(0.0))) || !vertex_sees(z, wi, dist)) return vec3(0.0);

    float qs_rev = at_z.pdf_out * cos_light_over_d2;  // the camera subpath going on to the light
    float cos_z = abs(dot(v.ng, wi));
    float pt_rev = light.infinite ? pdf_env_emission_pos() * cos_z
                                : pdf_emission_dir(light.n, -wi) * cos_z / (dist * dist);
    float pt_minus_rev = area_density(at_z.pdf_back, v.p, z - 1);
    return contribution * mis_weight(1, t, pt_rev, pt_minus_rev, qs_rev, 0.0, light.pdf, light.delta);
}

// ---- t = 1: light vertex s-1 seen by the pinhole, splatted to its pixel ----
void strategy_light_tracing(int s) {
    int y = BDPT_LIGHT_BASE + s - 1;
    if (!vertex_connectible(y)) return;
    PathVertex v = bdpt_path[y];
    vec2 pixel_pos;
    if (!camera_project(v.p, pixel_pos)) return;
    vec3 to_camera = u_cam_pos - v.p;
    float dist2 = dot(to_camera, to_camera);
    float dist = sqrt(dist2);
    vec3 wi = to_camera / dist;
    VertexScatter at_y = vertex_scatter(y, v.wo, wi, true);
    // W_e cos / d^2: the camera's importance and its half of the geometry term.
    float importance = camera_importance(-wi) * dot(-wi, u_cam_forward) / dist2;
    vec3 contribution = v.beta * at_y.f * importance;
    if (all(equal(contribution, vec3(0.0))) || !vertex_sees(y, wi, dist)) return;

    float qs_rev = camera_pdf_dir(-wi) * abs(dot(v.ng, wi)) / dist2;  // a camera ray reaching y
    float qs_minus_rev = area_density(at_y.pdf_back, v.p, y - 1);
    splat(pixel_pos, contribution * mis_weight(s, 1, 0.0, 0.0, qs_rev, qs_minus_rev, 0.0, false));
}

// ---- s >= 2, t >= 2: light vertex s-1 and camera vertex t-1 joined by a shadow ray ----
vec3 strategy_connect(int s, int t) {
    int y = BDPT_LIGHT_BASE + s - 1;
    int z = t - 1;
    if (!vertex_connectible(y) || !vertex_connectible(z)) return vec3(0.0);
    vec3 d = bdpt_path[y].p - bdpt_path[z].p;
    float dist2 = dot(d, d);
    if (!(dist2 > 0.0)) return vec3(0.0);
    float dist = sqrt(dist2);
    vec3 wi = d / dist;  // from z_{t-1} towards y_{s-1}
    VertexScatter at_z = vertex_scatter(z, bdpt_path[z].wo, wi, false);
    VertexScatter at_y = vertex_scatter(y, bdpt_path[y].wo, -wi, true);
    vec3 contribution = bdpt_path[z].beta * at_z.f * at_y.f * bdpt_path[y].beta / dist2;
    if (all(equal(contribution, vec3(0.0))) || !vertex_sees(z, wi, dist)) return vec3(0.0);

    float pt_rev = area_density(at_y.pdf_out, bdpt_path[y].p, z);
    float pt_minus_rev = area_density(at_z.pdf_back, bdpt_path[z].p, z - 1);
    float qs_rev = area_density(at_z.pdf_out, bdpt_path[z].p, y);
    float qs_minus_rev = area_density(at_y.pdf_back, bdpt_path[y].p, y - 1);
    return contribution * mis_weight(s, t, pt_rev, pt_minus_rev, qs_rev, qs_minus_rev, 0.0, false);
}

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    int depth_limit = min(max_depth, BDPT_MAX_DEPTH);
    int camera_vertices = camera_subpath(ray, hit, depth_limit, rng);
    int light_vertices = light_subpath(depth_limit, rng);

    // ---- Every strategy (s, t) whose path has at most depth_limit bounces ----
    vec3 L = vec3(0.0);
    for (int t = 1; t <= camera_vertices; ++t) {
        for (int s = 0; s <= max(light_vertices, 1); ++s) {
            int depth = s + t - 2;  // bounces of the full path
            if ((s == 1 && t == 1) || depth < 0 || depth > depth_limit) continue;
            if ((only_depth >= 0 && depth != only_depth) || (only_s >= 0 && s != only_s)) continue;
            if (t == 1) {
                if (s >= 2) strategy_light_tracing(s);
            } else if (s == 0) {
                L += strategy_emitted(t);
            } else if (s == 1) {
                L += strategy_light_sample(t, rng);
            } else {
                L += strategy_connect(s, t);
            }
        }
    }
    return L;
}
