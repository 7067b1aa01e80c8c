// template: the starting point of your own integrator.
//
//   lift-gl new-plugin mine                  copies this folder to plugins/mine/
//   lift-gl render scenes/cornell.toml --integrator mine --spp 64 --out mine.png
//   python -m pytest plugins/mine            runs the test that came with it
//
// THE CONTRACT. The host writes main() (pixels, seeds, averaging, the NaN/Inf guard:
// shaders/lift/host_main.comp) and calls radiance() once per sample. `ray` is the camera ray,
// `hit` its first hit (hit.prim == NO_HIT: the ray left the scene). Return the radiance
// arriving at the camera along `ray`: linear RGB, world units. Parameters from plugin.toml
// are uniforms of the same name (max_depth, min_bounce, only_bounce below).
//
// THE LIBRARY (shaders/lift/*.glsl, already included; docs/glsl-library.md is the
// reference: every function, its arguments and what it returns, every struct's fields):
//   surface_at(ray, hit)              -> Surface s: s.p position, s.ng / s.ns geometric and
//                                        shading normals, s.material (world space)
//   material_at(s.material, s.uv)     -> Material m (its image texture applied, if any)
//   bsdf_sample(m, wo, u, bs)         samples wi; bs.weight = f * cos / pdf  (local frame:
//   bsdf_eval(m, wo, wi), bsdf_pdf     z = normal; wo, wi point away from the surface)
//   bsdf_eval_pdf(m, wo, wi, pdf)     both at once (what a light sample's MIS weight needs)
//   shading_frame(s, m, wo)           the local frame to shade s in, seen from wo (opaque
//                                        surfaces from wo's side; lift/surface.glsl)
//   frame_from_normal, to_local, to_world
//   spawn_ray(s, dir), trace_closest(ray, hit), trace_occluded(shadow_ray)
//   sample_light(p, u, ls), light_pdf  next event estimation (see plugins/pt)
//   env_radiance(dir), surface_emission(s, w)
//   rng_next(rng), rng_next2, rng_next3: uniform random numbers in [0, 1)
//
// AS SHIPPED this is the simplest correct path tracer: each sample follows one path by
// sampling the BSDF and adds whatever light the path runs into. It converges to the same
// image as pt, only more slowly. The places to start are marked YOUR TURN.

// Bounces: light the path finds at vertex `depth` has bounced `depth` times (0: an emitter
// seen directly, 1: direct light, 2: the first indirect bounce...). The parameters
// only_bounce and min_bounce choose which bounces are added to L; the path is sampled the
// same way whatever they are, so the single bounces of one seed add up to the full image.
// When you add light sampling, its light arrives after one more bounce: depth + 1.
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    vec3 L = vec3(0.0);           // radiance found so far
    vec3 throughput = vec3(1.0);  // product of f * cos / pdf along the path
    int first_bounce = only_bounce >= 0 ? only_bounce : min_bounce;
    int last_bounce = only_bounce >= 0 ? min(only_bounce, max_depth) : max_depth;

    for (int depth = 0; ; ++depth) {
        bool counted = depth >= first_bounce;

        // ---- The path left the scene: light from the environment ----
        if (hit.prim == NO_HIT) {
            if (counted) L += throughput * env_radiance(ray.dir);
            break;
        }

        // ---- The surface the path reached, and the light it emits back along the path ----
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;
        if (counted) L += throughput * surface_emission(s, wo_world);
        if (depth >= last_bounce) break;

        // ---- YOUR TURN: direct lighting ----
        // Sample a point on a light (sample_light) and trace a shadow ray (trace_occluded).
        // Then light found by BSDF sampling, just above, must be weighted (MIS) or left out.

        // ---- The next direction: sample the BSDF ----
        Material m = material_at(s.material, s.uv);
        Frame frame = shading_frame(s, m, wo_world);
        BsdfSample bs;
        if (!bsdf_sample(m, to_local(frame, wo_world), rng_next3(rng), bs)) break;  // absorbed
        vec3 wi_world = to_world(frame, bs.wi);
        // A direction the shading normal allows but the true surface blocks.
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, wi_world)) break;
        throughput *= bs.weight;

        // ---- YOUR TURN: Russian roulette ----
        // End dim paths at random and divide the survivors' throughput by their chance.

        ray = spawn_ray(s, wi_world);
        trace_closest(ray, hit);
    }
    return L;
}
