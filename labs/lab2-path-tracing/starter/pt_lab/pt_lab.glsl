// pt_lab: lab 2's path tracer (the starter). Read handout.md first.
//
// THE CONTRACT. The host writes main() (pixels, seeds, averaging, the NaN/Inf guard) and
// calls radiance() once per sample. `ray` is the camera ray, `hit` its first hit from the
// raster G-buffer (hit.prim == NO_HIT: the ray left the scene). Return the radiance arriving
// at the camera along `ray`: linear RGB. Every parameter of plugin.toml is a uniform of the
// same name (max_depth, min_bounce, only_bounce, mis, rr_depth, rr_min_survival).
//
// THE LIBRARY (shaders/lift/*.glsl, already included; docs/plugins.md has the full table):
//   surface_at(ray, hit)              -> Surface s: s.p, s.ng (geometric normal), s.material
//   material_at(s.material, s.uv)     -> Material m (its texture applied)
//   shading_frame(s, m, wo)           the local frame to shade in (z = the normal)
//   bsdf_sample(m, wo, u, bs)         samples bs.wi; bs.weight = f * cos / pdf, bs.pdf,
//                                     bs.is_delta (mirror, clear glass)
//   bsdf_eval_pdf(m, wo, wi, pdf)     f * cos for a given wi, and BSDF sampling's pdf of it
//   bsdf_is_delta(m)                  mirrors and clear glass: a light sample can't hit them
//   sample_light(p, u, ls)            a point on a light seen from p: ls.wi, ls.dist,
//                                     ls.radiance, ls.pdf (solid angle), ls.is_delta
//   light_pdf(p_prev, s, dir, t)      the pdf sample_light at p_prev gives the emitter point s
//   env_light_pdf(dir), env_radiance(dir), surface_emission(s, wo)
//   spawn_ray(s, dir), spawn_shadow_ray(s, dir, dist), trace_closest, trace_occluded
//   power_heuristic(pdf_a, pdf_b)     the weight of strategy a against strategy b
//   rng_next(rng), rng_next2, rng_next3: uniform random numbers in [0, 1)
// Directions for bsdf_* are local (to_local(frame, w), to_world(frame, w)); all else world.
//
// AS HANDED OUT this is the simplest correct path tracer: each sample follows one path by
// sampling the BSDF and adds whatever light the path runs into. It converges to the right
// image, slowly: it finds small lights only by chance. Steps 1-3 make it fast.

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.0);           // radiance found so far
    vec3 throughput = vec3(1.0);  // product of f * cos / pdf along the path
    // Bounces: light found at vertex `depth` has bounced `depth` times (0: an emitter seen
    // directly, 1: direct light...); only bounces first_bounce..last_bounce are added to L.
    // The light sample of step 1, taken at vertex `depth`, arrives after one bounce more.
    int first_bounce = only_bounce >= 0 ? only_bounce : min_bounce;
    int last_bounce = only_bounce >= 0 ? min(only_bounce, max_depth) : max_depth;

    for (int depth = 0; ; ++depth) {
        bool counted = depth >= first_bounce;

        // ---- The path left the scene: light from the environment ----
        // YOUR TURN (step 1): after step 1 the light sample has counted this light already,
        // unless the direction came from the camera or a delta lobe. (step 2): weigh it instead.
        if (hit.prim == NO_HIT) {
            if (counted) L += throughput * env_radiance(ray.dir);
            break;
        }

        // ---- The surface the path reached, and the light it emits back along the path ----
        // YOUR TURN (steps 1 and 2): the same question for light found on an emitter.
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;
        if (counted) L += throughput * surface_emission(s, wo_world);
        if (depth >= last_bounce) break;

        Material m = material_at(s.material, s.uv);
        Frame frame = shading_frame(s, m, wo_world);

        // ---- YOUR TURN (step 1): direct lighting ----
        // Sample a point on a light (sample_light), evaluate the BSDF towards it
        // (bsdf_eval_pdf), trace a shadow ray (trace_occluded) and add what arrives.
        // (step 2): weight it with power_heuristic when the parameter `mis` is on.

        // ---- The next direction: sample the BSDF ----
        BsdfSample bs;
        if (!bsdf_sample(m, to_local(frame, wo_world), rng_next3(rng), bs)) break;  // absorbed
        vec3 wi_world = to_world(frame, bs.wi);
        // A direction the shading normal allows but the true surface blocks.
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, wi_world)) break;
        throughput *= bs.weight;

        // ---- YOUR TURN (step 3): Russian roulette ----
        // From bounce rr_depth on, end dim paths at random; divide the survivors' throughput
        // by their chance of surviving (at least rr_min_survival).

        ray = spawn_ray(s, wi_world);
        trace_closest(ray, hit);
    }
    return L;
}
