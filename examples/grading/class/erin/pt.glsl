// erin's path tracer (a made-up submission for docs/grading.md): diffuse bounces sampled
// uniformly over the hemisphere, their density 1 / (2 pi) in every MIS weight. Correct.
// pt: a unidirectional path tracer, written to read like the textbook (Veach 1997, pbrt).
// The host calls radiance() once per sample with the camera ray and its first hit; it
// handles pixels, seeds, accumulation and the NaN/Inf guard.
// Parameters (plugin.toml): max_depth, rr_depth, rr_min_survival, min_bounce, only_bounce.
//
// Bounce k is the light that reached the camera after k scatterings: bounce 0 is the
// emitters seen directly, bounce 1 direct light, 2 the first indirect bounce, and so on.
// Emission found at path vertex `depth` is bounce `depth`; the light sample taken at
// vertex `depth` is bounce `depth + 1`. Only bounces in [first_bounce, last_bounce] are
// added to L, but the path is sampled the same way whatever the window, so the images of
// the single bounces of one seed add up to the full image.

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.0);
    vec3 throughput = vec3(1.0);
    float bsdf_pdf_prev = 0.0;   // solid-angle pdf of the direction that led here
    bool specular_prev = true;   // camera rays and delta lobes: no MIS for what they hit
    vec3 p_prev = ray.origin;
    int first_bounce = only_bounce >= 0 ? only_bounce : min_bounce;
    int last_bounce = only_bounce >= 0 ? min(only_bounce, max_depth) : max_depth;

    for (int depth = 0; ; ++depth) {
        bool counted = depth >= first_bounce;  // light that ends its path here is bounce `depth`
        // ---- Escaped: the environment ----
        if (hit.prim == NO_HIT) {
#ifdef HAS_ENVIRONMENT
            float w = specular_prev ? 1.0 : power_heuristic(bsdf_pdf_prev, env_light_pdf(ray.dir));
            if (counted) L += throughput * env_radiance(ray.dir) * w;
#endif
            break;
        }
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;

        // ---- Emission found by the path ----
#ifdef HAS_EMISSIVE
        vec3 Le = surface_emission(s, wo_world);
        if (counted && any(greaterThan(Le, vec3(0.0)))) {
            float w = specular_prev ? 1.0 : power_heuristic(bsdf_pdf_prev, light_pdf(p_prev, s, ray.dir, hit.t));
            L += throughput * Le * w;
        }
#endif
        if (depth >= last_bounce) break;

        Material m = materials[s.material];
        Frame frame = shading_frame(s, m, wo_world);
        vec3 wo = to_local(frame, wo_world);

        bool uniform_diffuse = bsdf_type(m) == MAT_DIFFUSE;

        // ---- Next event estimation: one light sample, weighted against BSDF sampling ----
#if defined(HAS_EMISSIVE) || defined(HAS_ENVIRONMENT)
        if (!bsdf_is_delta(m)) {
            LightSample ls;
            // rng_ld2: low-discrepancy for the first light and BSDF samples of the path.
            // The light is sampled even where its bounce (depth + 1) is not counted, so that
            // every window draws the same random numbers; only the shadow ray is saved.
            if (sample_light(s.p, vec3(rng_next(rng), rng_ld2(rng)), ls) && depth + 1 >= first_bounce) {
                vec3 wi = to_local(frame, ls.wi);
                vec3 f = bsdf_eval(m, wo, wi);
                if (any(greaterThan(f, vec3(0.0))) && !trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist))) {
                    float w = power_heuristic(ls.pdf, uniform_diffuse ? (wi.z > 0.0 ? 0.5 * LIFT_INV_PI : 0.0) : bsdf_pdf(m, wo, wi));
                    L += throughput * f * ls.radiance * (w / ls.pdf);
                }
            }
        }
#endif

        // ---- BSDF sampling: the next direction ----
        BsdfSample bs;
        if (uniform_diffuse) {
            vec2 u = rng_ld2(rng);
            rng_next(rng);
            float z = u.x, r = sqrt(max(0.0, 1.0 - z * z)), phi = 2.0 * LIFT_PI * u.y;
            bs.wi = vec3(r * cos(phi), r * sin(phi), z);
            bs.pdf = 0.5 * LIFT_INV_PI;
            bs.weight = bsdf_eval(m, wo, bs.wi) / bs.pdf;  // bsdf_eval holds the cosine
            bs.is_delta = false;
        } else if (!bsdf_sample(m, wo, vec3(rng_ld2(rng), rng_next(rng)), bs)) break;
        vec3 wi_world = to_world(frame, bs.wi);
        // A reflection that the shading normal allows but the true surface does not.
        if (int(m.color_type.w) != MAT_DIELECTRIC && dot(wi_world, s.ng) * dot(wo_world, s.ng) <= 0.0) break;
        throughput *= bs.weight;
        bsdf_pdf_prev = bs.pdf;
        specular_prev = bs.is_delta;
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
