// pt: a unidirectional path tracer, written to read like the textbook (Veach 1997, pbrt).
// The host calls radiance() once per sample with the camera ray and its first hit (or, with
// several samples a frame, path_start and path_step: see PathState); it handles pixels,
// seeds, accumulation and the NaN/Inf guard.
// Parameters (plugin.toml): max_depth, rr_depth, rr_min_survival, low_discrepancy.

// Two numbers for a light or BSDF sample: low-discrepancy pairs, or independent ones.
vec2 sample_pair(inout Rng rng) {
    return low_discrepancy ? rng_ld2(rng) : rng_next2(rng);
}

// The bounce window (parameters min_bounce and only_bounce). Bounce k is the light that
// reached the camera after k scatterings: bounce 0 is the emitters seen directly, bounce 1
// direct light, 2 the first indirect bounce, and so on.
// Emission found at path vertex `depth` is bounce `depth`; the light sample taken at
// vertex `depth` is bounce `depth + 1`. Only bounces in [first_bounce, last_bounce] are
// added to L, but the path is sampled the same way whatever the window, so the images of
// the single bounces of one seed add up to the full image.
int first_bounce() { return only_bounce >= 0 ? only_bounce : min_bounce; }
int last_bounce() { return only_bounce >= 0 ? min(only_bounce, max_depth) : max_depth; }

// A path under way: what the loop of radiance() carries from one vertex to the next. The
// path advances one vertex per path_step(), so that the host can start a lane's next sample
// as soon as its path ends (LIFT_PATH_STEPS, lift_gl/passes/trace.py) instead of idling
// until the longest path of its SIMD batch ends (docs/cpu-speed.md).
#define LIFT_PATH_STEPS
struct PathState {
    Ray ray;               // the ray that reached this vertex ...
    Hit hit;               // ... and what it hit
    vec3 L;
    vec3 throughput;
    float bsdf_pdf_prev;   // solid-angle pdf of the direction that led here
    bool specular_prev;    // camera rays and delta lobes: no MIS for what they hit
    vec3 p_prev;
    int depth;
    float eta_scale;       // the refractions' radiance scales so far, undone for the roulette
};

PathState path_start(Ray ray, Hit hit) {
    return PathState(ray, hit, vec3(0.0), vec3(1.0), 0.0, true, ray.origin, 0, 1.0);
}

// One vertex of the path: what it adds to L, then the next ray, traced. False: the path ended.
bool path_step(inout PathState path, inout Rng rng) {
    int depth = path.depth;
    bool counted = depth >= first_bounce();  // light that ends its path here is bounce `depth`
    // ---- Escaped: the environment ----
    if (path.hit.prim == NO_HIT) {
#ifdef HAS_ENVIRONMENT
        float w = path.specular_prev ? 1.0 : power_heuristic(path.bsdf_pdf_prev, env_light_pdf(path.ray.dir));
        if (counted) path.L += path.throughput * env_radiance(path.ray.dir) * w;
#endif
        return false;
    }
    Surface s = surface_at(path.ray, path.hit);
    vec3 wo_world = -path.ray.dir;

    // ---- Emission found by the path ----
#ifdef HAS_EMISSIVE
    vec3 Le = surface_emission(s, wo_world);
    if (counted && any(greaterThan(Le, vec3(0.0)))) {
        float w = path.specular_prev ? 1.0 : power_heuristic(path.bsdf_pdf_prev, light_pdf(path.p_prev, s, path.ray.dir, path.hit.t));
        path.L += path.throughput * Le * w;
    }
#endif
    if (depth >= last_bounce()) return false;

    Material m = material_at(s.material, s.uv);  // textures applied
    Frame frame = shading_frame(s, m, wo_world);
    vec3 wo = to_local(frame, wo_world);

    // ---- Next event estimation: one light sample, weighted against BSDF sampling ----
    // Its shadow ray is traced below, with the next ray (trace_shadow_and_next).
    bool shadow_wanted = false;
    Ray shadow_ray = path.ray;
    vec3 L_light = vec3(0.0);   // what the light sample adds if its shadow ray is unblocked
#if defined(HAS_EMISSIVE) || defined(HAS_ENVIRONMENT) || defined(HAS_DISTANT_LIGHTS)
    if (!bsdf_is_delta(m)) {
        LightSample ls;
        // The light is sampled even where its bounce (depth + 1) is not counted, so that
        // every window draws the same random numbers; only the shadow ray is saved.
        if (sample_light(s.p, vec3(rng_next(rng), sample_pair(rng)), ls) && depth + 1 >= first_bounce()) {
            vec3 wi = to_local(frame, ls.wi);
            float pdf_bsdf;  // the density of BSDF sampling choosing wi, for the MIS weight
            vec3 f = bsdf_eval_pdf(m, wo, wi, pdf_bsdf);
            // Through the true surface of an opaque one: nothing (BSDF sampling agrees).
            if (is_opaque(m) && !same_side_of_surface(s, wo_world, ls.wi)) f = vec3(0.0);
            if (any(greaterThan(f, vec3(0.0)))) {
                // A delta light (distant) can't be found by BSDF sampling: no MIS.
                float w = ls.is_delta ? 1.0 : power_heuristic(ls.pdf, pdf_bsdf);
                L_light = path.throughput * f * ls.radiance * (w / ls.pdf);
                shadow_ray = spawn_shadow_ray(s, ls.wi, ls.dist);
                shadow_wanted = true;
            }
        }
    }
#endif

    // ---- BSDF sampling: the next direction ----
    BsdfSample bs;
    bool goes_on = bsdf_sample(m, wo, vec3(sample_pair(rng), rng_next(rng)), bs);
    vec3 wi_world = to_world(frame, bs.wi);
    // A reflection that the shading normal allows but the true surface does not.
    if (goes_on && is_opaque(m) && !same_side_of_surface(s, wo_world, wi_world)) goes_on = false;
    if (goes_on) {
        path.throughput *= bs.weight;
        // A refraction scales radiance by 1 / etap^2 (into glass 1 / 1.5^2), a factor the way
        // out undoes: the roulette judges the throughput without it (pbrt's etaScale), so a
        // path is not ended for having entered glass, nor kept for having left it.
        path.eta_scale *= refraction_eta2(m, wo, bs.wi);
        path.bsdf_pdf_prev = bs.pdf;
        path.specular_prev = bs.is_delta;
        path.p_prev = s.p;
        // ---- Russian roulette: end dim paths, reweight the survivors ----
        if (depth + 1 >= rr_depth) {
            vec3 judged = path.throughput * path.eta_scale;
            float survive = clamp(max(judged.r, max(judged.g, judged.b)), rr_min_survival, 1.0);
            if (rng_next(rng) >= survive) goes_on = false;
            else path.throughput /= survive;
        }
    }

    // ---- The shadow ray and the next ray ----
    Ray next_ray = goes_on ? spawn_ray(s, wi_world) : path.ray;
    Hit next_hit;
    if (!trace_shadow_and_next(shadow_wanted, shadow_ray, goes_on, next_ray, next_hit) && shadow_wanted)
        path.L += L_light;
    if (!goes_on) return false;
    path.ray = next_ray;
    path.hit = next_hit;
    path.depth = depth + 1;
    return true;
}

vec3 path_radiance(PathState path) { return path.L; }

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    PathState path = path_start(ray, hit);
    while (path_step(path, rng)) {}
    return path_radiance(path);
}
