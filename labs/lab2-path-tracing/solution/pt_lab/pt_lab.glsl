// pt_lab: lab 2's path tracer, the instructor's solution.
//
// The host calls radiance() once per sample with the camera ray and its first hit (from the
// raster G-buffer); it handles pixels, seeds, averaging and the NaN/Inf guard. One sample
// follows one path: at each vertex it adds the light arriving there directly (a light sample,
// step 1), weighted against BSDF sampling by multiple importance sampling (step 2), samples
// the BSDF for the next direction, and may end the path by Russian roulette (step 3).
// Parameters (plugin.toml): max_depth, min_bounce, only_bounce, mis, rr_depth, rr_min_survival.

// ---- Step 2: the weight of light that BSDF sampling ran into ----
// specular_prev: the direction came from the camera or a delta lobe (mirror, clear glass),
// which a light sample can never produce, so that light counts in full. Otherwise the light
// sample of the previous vertex could have found the same light: weigh the two strategies
// (power heuristic) or, without MIS, leave it to the light sample (weight 0).
float emission_weight(bool specular_prev, float bsdf_pdf_prev, float light_pdf_here) {
    if (specular_prev) return 1.0;
    return mis ? power_heuristic(bsdf_pdf_prev, light_pdf_here) : 0.0;
}

// ---- Step 1: next event estimation ----
// Light arriving at s directly from one point sampled on a light (an emitter, the
// environment or a distant light), reflected towards wo_world; zero in shadow.
vec3 direct_light(Surface s, Material m, Frame frame, vec3 wo_world, inout Rng rng) {
    LightSample ls;
    if (!sample_light(s.p, rng_next3(rng), ls)) return vec3(0.0);        // no light in the scene
    // Through the true surface of an opaque one: no light (BSDF sampling agrees).
    if (is_opaque(m) && !same_side_of_surface(s, wo_world, ls.wi)) return vec3(0.0);
    float pdf_bsdf;  // the density of BSDF sampling choosing the same direction
    vec3 f = bsdf_eval_pdf(m, to_local(frame, wo_world), to_local(frame, ls.wi), pdf_bsdf);  // f * cos
    if (!any(greaterThan(f, vec3(0.0)))) return vec3(0.0);
    if (trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist))) return vec3(0.0);  // in shadow
    // A distant light is a delta: BSDF sampling never finds it, so it needs no weight.
    float w = ls.is_delta ? 1.0 : (mis ? power_heuristic(ls.pdf, pdf_bsdf) : 1.0);
    return f * ls.radiance * (w / ls.pdf);
}

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.0);           // radiance found so far
    vec3 throughput = vec3(1.0);  // product of f * cos / pdf along the path
    bool specular_prev = true;    // the camera ray: what it hits counts in full
    float bsdf_pdf_prev = 0.0;    // solid-angle pdf of the direction that led here
    vec3 p_prev = ray.origin;     // the vertex that direction left from
    // Bounces: light found at vertex `depth` has bounced `depth` times; the light sample
    // taken at vertex `depth` arrives after one bounce more.
    int first_bounce = only_bounce >= 0 ? only_bounce : min_bounce;
    int last_bounce = only_bounce >= 0 ? min(only_bounce, max_depth) : max_depth;

    for (int depth = 0; ; ++depth) {
        bool counted = depth >= first_bounce;

        // ---- The path left the scene: light from the environment ----
        if (hit.prim == NO_HIT) {
            if (counted) L += throughput * env_radiance(ray.dir)
                              * emission_weight(specular_prev, bsdf_pdf_prev, env_light_pdf(ray.dir));
            break;
        }

        // ---- The surface the path reached, and the light it emits back along the path ----
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;
        vec3 Le = surface_emission(s, wo_world);
        if (counted && any(greaterThan(Le, vec3(0.0))))
            L += throughput * Le * emission_weight(specular_prev, bsdf_pdf_prev, light_pdf(p_prev, s, ray.dir, hit.t));
        if (depth >= last_bounce) break;

        Material m = material_at(s.material, s.uv);
        Frame frame = shading_frame(s, m, wo_world);

        // ---- Direct lighting: one light sample (none at mirrors and clear glass) ----
        if (!bsdf_is_delta(m) && depth + 1 >= first_bounce)
            L += throughput * direct_light(s, m, frame, wo_world, rng);

        // ---- The next direction: sample the BSDF ----
        BsdfSample bs;
        if (!bsdf_sample(m, to_local(frame, wo_world), rng_next3(rng), bs)) break;  // absorbed
        vec3 wi_world = to_world(frame, bs.wi);
        // A direction the shading normal allows but the true surface blocks.
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, wi_world)) break;
        throughput *= bs.weight;
        specular_prev = bs.is_delta;
        bsdf_pdf_prev = bs.pdf;
        p_prev = s.p;

        // ---- Russian roulette: end dim paths, reweight the survivors ----
        if (depth + 1 >= rr_depth) {
            float survive = clamp(max(throughput.r, max(throughput.g, throughput.b)), rr_min_survival, 1.0);
            if (rng_next(rng) >= survive) break;
            throughput /= survive;
        }

        ray = spawn_ray(s, wi_world);
        trace_closest(ray, hit);
    }
    return L;
}
