// hybrid: rendering in the manner of Firefly (an OpenGL + CUDA demo): direct light where the
// raster G-buffer puts the first hit, at full resolution; indirect light traced at reduced
// resolution and upsampled. BIASED: the upsampling filter blurs indirect light a little.
//
// The host calls
//   radiance()           for every pixel: bounces 0 and 1 (emitters seen, direct light)
//   indirect_radiance()  for one pixel in indirect_scale x indirect_scale: bounces 2 and up.
// The host divides the indirect estimate by the first hit's albedo, upsamples it with a joint
// bilateral filter on the G-buffer's normals and depths (passes/upsample.py), multiplies it by
// each pixel's own albedo and adds it to radiance(). Both halves are pt's estimator (NEE with
// MIS, Russian roulette), split by bounce: without the filter they would add up to pt.

// Light that reaches the camera after first_bounce..last_bounce scatterings.
vec3 path_radiance(Ray ray, Hit hit, inout Rng rng, int first_bounce, int last_bounce) {
    vec3 L = vec3(0.0);
    vec3 throughput = vec3(1.0);
    float bsdf_pdf_prev = 0.0;
    bool specular_prev = true;
    vec3 p_prev = ray.origin;
    float eta_scale = 1.0;  // the refractions' radiance scales so far, undone for the roulette (pt's)
    for (int depth = 0; ; ++depth) {
        bool counted = depth >= first_bounce;
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
        Material m = material_at(s.material, s.uv);  // textures applied
        Frame frame = shading_frame(s, m, wo_world);
        vec3 wo = to_local(frame, wo_world);
        // ---- Next event estimation (bounce depth + 1): a shadow ray ----
#if defined(HAS_EMISSIVE) || defined(HAS_ENVIRONMENT) || defined(HAS_DISTANT_LIGHTS)
        if (!bsdf_is_delta(m)) {
            LightSample ls;
            if (sample_light(s.p, vec3(rng_next(rng), rng_ld2(rng)), ls) && depth + 1 >= first_bounce) {
                vec3 wi = to_local(frame, ls.wi);
                vec3 f = bsdf_eval(m, wo, wi);
                if (is_opaque(m) && !same_side_of_surface(s, wo_world, ls.wi)) f = vec3(0.0);
                if (any(greaterThan(f, vec3(0.0))) && !trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist))) {
                    float w = ls.is_delta ? 1.0 : power_heuristic(ls.pdf, bsdf_pdf(m, wo, wi));  // distant: no MIS
                    L += throughput * f * ls.radiance * (w / ls.pdf);
                }
            }
        }
#endif
        // ---- BSDF sampling: the next direction ----
        BsdfSample bs;
        if (!bsdf_sample(m, wo, vec3(rng_ld2(rng), rng_next(rng)), bs)) break;
        vec3 wi_world = to_world(frame, bs.wi);
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, wi_world)) break;
        throughput *= bs.weight;
        eta_scale *= refraction_eta2(m, wo, bs.wi);
        bsdf_pdf_prev = bs.pdf;
        specular_prev = bs.is_delta;
        p_prev = s.p;
        // ---- Russian roulette ----
        if (depth + 1 >= rr_depth) {
            vec3 judged = throughput * eta_scale;
            float survive = clamp(max(judged.r, max(judged.g, judged.b)), rr_min_survival, 1.0);
            if (rng_next(rng) >= survive) break;
            throughput /= survive;
        }
        ray = spawn_ray(s, wi_world);
        trace_closest(ray, hit);
    }
    return L;
}

// Full resolution: the emitter seen and direct light (one shadow ray, one BSDF ray).
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    return path_radiance(ray, hit, rng, 0, min(1, max_depth));
}

// Reduced resolution: everything after the first bounce.
vec3 indirect_radiance(Ray ray, Hit hit, inout Rng rng) {
    return path_radiance(ray, hit, rng, 2, max_depth);
}
