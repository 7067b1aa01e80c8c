// drt: a distribution ray tracer (Cook, Porter and Carpenter 1984), lab 1 of the course.
//
// Whitted's ray tracer follows mirror and glass rays recursively and lights every hit with
// one shadow ray per point light. Cook's tracer distributes those rays over the quantities
// they stand for, which turns aliasing into noise and gives effects Whitted could not show:
//   glossy reflection and refraction  the bounce direction is sampled from the BSDF lobe
//                                     (bsdf_sample), one lobe per bounce
//   soft shadows                      shadow rays go to random points on area lights
//                                     (sample_light)
//   depth of field                    camera rays start at a random point of the lens: the
//                                     host does it for primary = "camera" (camera_ray_lens)
//   motion blur                       each camera sample sees the scene at a random moment of
//                                     the shutter; the host sets g_ray_time and every ray of
//                                     this sample keeps it
// GLSL has no recursion, so the ray tree is walked as a loop along one branch: each bounce
// samples one lobe and multiplies the branch's throughput by that lobe's weight.
// A diffuse surface ends the branch: light that reaches it from other surfaces (diffuse
// interreflection, caustics) is left out, as in Whitted's and Cook's tracers. pt adds it.
// Parameters (plugin.toml): max_depth, light_samples.

// Light arriving at s directly from the emitters and the environment, reflected towards wo:
// the mean of light_samples shadow rays. Where the branch goes on (a glossy surface), the
// bounce may hit the same light, so both estimates are weighted by multiple importance
// sampling (power heuristic, light_samples light samples against one BSDF sample).
vec3 direct_light(Surface s, Material m, Frame frame, vec3 wo_world, bool branch_goes_on, inout Rng rng) {
    vec3 wo = to_local(frame, wo_world);
    vec3 sum = vec3(0.0);
#if defined(HAS_EMISSIVE) || defined(HAS_ENVIRONMENT) || defined(HAS_DISTANT_LIGHTS)
    float n_light = float(light_samples);
    for (int k = 0; k < light_samples; ++k) {
        LightSample ls;
        if (!sample_light(s.p, rng_next3(rng), ls)) continue;
        vec3 wi = to_local(frame, ls.wi);
        vec3 f = bsdf_eval(m, wo, wi);  // BSDF times the cosine at s
        // Through the true surface of an opaque one: nothing (BSDF sampling agrees).
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, ls.wi)) continue;
        if (!any(greaterThan(f, vec3(0.0)))) continue;
        if (trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist))) continue;  // in shadow
        // A delta light (distant) can't be found by BSDF sampling: no MIS.
        float w = branch_goes_on && !ls.is_delta ? power_heuristic(n_light * ls.pdf, bsdf_pdf(m, wo, wi)) : 1.0;
        sum += f * ls.radiance * (w / ls.pdf);
    }
    sum /= n_light;
#endif
    return sum;
}

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.0);
    vec3 throughput = vec3(1.0);  // product of the weights of the lobes sampled so far
    bool specular_prev = true;    // the camera or a delta lobe: light it hits counts in full
    float bsdf_pdf_prev = 0.0;    // solid-angle pdf of the glossy bounce that led here
    vec3 p_prev = ray.origin;
    float n_light = float(light_samples);

    for (int depth = 0; ; ++depth) {
        // ---- The ray escaped: light from the environment ----
        if (hit.prim == NO_HIT) {
#ifdef HAS_ENVIRONMENT
            float w = specular_prev ? 1.0 : power_heuristic(bsdf_pdf_prev, n_light * env_light_pdf(ray.dir));
            L += throughput * env_radiance(ray.dir) * w;
#endif
            break;
        }
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;

        // ---- The ray hit a light ----
#ifdef HAS_EMISSIVE
        vec3 Le = surface_emission(s, wo_world);
        if (any(greaterThan(Le, vec3(0.0)))) {
            float w = specular_prev ? 1.0
                : power_heuristic(bsdf_pdf_prev, n_light * light_pdf(p_prev, s, ray.dir, hit.t));
            L += throughput * Le * w;
        }
#endif
        if (depth >= max_depth) break;

        Material m = material_at(s.material, s.uv);  // textures applied
        Frame frame = shading_frame(s, m, wo_world);
        vec3 wo = to_local(frame, wo_world);
        bool diffuse = bsdf_type(m) == MAT_DIFFUSE;

        // ---- Direct light with soft shadows (mirrors and clear glass have none) ----
        if (!bsdf_is_delta(m)) L += throughput * direct_light(s, m, frame, wo_world, !diffuse, rng);

        // ---- A diffuse surface ends the branch ----
        if (diffuse) break;

        // ---- Reflection or refraction: one lobe, one direction, sampled ----
        BsdfSample bs;
        if (!bsdf_sample(m, wo, rng_next3(rng), bs)) break;
        vec3 wi_world = to_world(frame, bs.wi);
        // A reflection that the shading normal allows but the true surface does not.
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, wi_world)) break;
        throughput *= bs.weight;
        specular_prev = bs.is_delta;
        bsdf_pdf_prev = bs.pdf;
        p_prev = s.p;

        ray = spawn_ray(s, wi_world);
        trace_closest(ray, hit);
    }
    return L;
}
