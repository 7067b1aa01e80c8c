// drt_lab: lab 1's distribution ray tracer (the starter). Read handout.md first.
//
// THE CONTRACT. The host writes main() (pixels, seeds, averaging, the NaN/Inf guard) and
// calls radiance() once per sample. `ray` is a pinhole camera ray through this sample's point
// of the pixel, `hit` its first hit from the raster G-buffer (hit.prim == NO_HIT: the ray
// left the scene). Return the radiance arriving at the camera along `ray`: linear RGB.
// Every parameter of plugin.toml is a uniform of the same name (max_depth, light_samples).
//
// THE LIBRARY (shaders/lift/*.glsl, already included; docs/plugins.md has the full table):
//   surface_at(ray, hit)              -> Surface s: s.p, s.ng (geometric normal), s.material
//   material_at(s.material, s.uv)     -> Material m (its texture applied)
//   bsdf_type(m)                      MAT_DIFFUSE, MAT_CONDUCTOR, MAT_DIELECTRIC, ...
//   bsdf_is_delta(m)                  a mirror or clear glass: one direction, no density
//   shading_frame(s, m, wo)           the local frame to shade in (z = the normal)
//   bsdf_sample(m, wo, u, bs)         samples one lobe's bs.wi; bs.weight = f * cos / pdf,
//                                     bs.pdf, bs.is_delta
//   bsdf_eval(m, wo, wi), bsdf_pdf(m, wo, wi)   f * cos, and the density of bsdf_sample
//   sample_light(p, u, ls)            a point on a light seen from p, from u in [0,1)^3:
//                                     ls.wi, ls.dist, ls.radiance, ls.pdf (solid angle)
//   light_pdf(p_prev, s, dir, t), env_light_pdf(dir)   the density sample_light gives them
//   env_radiance(dir), surface_emission(s, wo)
//   spawn_ray(s, dir), spawn_shadow_ray(s, dir, dist), trace_closest, trace_occluded
//   power_heuristic(pdf_a, pdf_b)     the MIS weight of strategy a against strategy b
//   u_cam_pos, u_cam_right, u_cam_up, u_cam_forward (unit vectors), u_lens_radius,
//   u_focus_distance                  the scene's camera (lift/camera.glsl)
//   rng_next(rng), rng_next2, rng_next3: uniform random numbers in [0, 1)
// Directions for bsdf_* are local (to_local(frame, w), to_world(frame, w)); all else world.
//
// AS HANDED OUT this is a Whitted-style ray caster: the camera ray's first hit is lit by one
// shadow ray to a fixed point of a light (hard shadows), and nothing is reflected or
// refracted. Steps 1-5 make it Cook's distribution ray tracer.
#include "lens.glsl"

// ---- YOUR TURN (step 4): depth of field ----
// Return the ray of a thin lens of radius u_lens_radius focused at u_focus_distance (along
// u_cam_forward) that passes through the point of the pinhole ray in focus, starting from the
// lens point that u picks (sample_lens in lens.glsl: write it first). A radius of 0 is a
// pinhole: the same ray.
Ray thin_lens_ray(Ray pinhole_ray, vec2 u) {
    return pinhole_ray;
}

// ---- Direct light ----
// Light arriving at s directly from the lights, reflected towards wo_world.
vec3 direct_light(Surface s, Material m, Frame frame, vec3 wo_world, bool branch_goes_on, inout Rng rng) {
    vec3 wo = to_local(frame, wo_world);
    // YOUR TURN (step 1): soft shadows. This asks sample_light for the same point every
    // time, so shadows are hard. Draw light_samples random points instead (rng_next3) and
    // return the mean of what they bring.
    // YOUR TURN (step 3): where the branch goes on (branch_goes_on), weigh each light
    // sample against BSDF sampling (power_heuristic).
    LightSample ls;
    if (!sample_light(s.p, vec3(0.5), ls)) return vec3(0.0);  // no light in the scene
    // Through the true surface of an opaque one: nothing (BSDF sampling agrees).
    if (is_opaque(m) && !same_side_of_surface(s, wo_world, ls.wi)) return vec3(0.0);
    vec3 f = bsdf_eval(m, wo, to_local(frame, ls.wi));  // BSDF times the cosine at s
    if (!any(greaterThan(f, vec3(0.0)))) return vec3(0.0);
    if (trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist))) return vec3(0.0);  // in shadow
    return f * ls.radiance / ls.pdf;
}

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    // ---- YOUR TURN (steps 4 and 5): this sample's camera ray ----
    // Step 4: turn the pinhole ray into a thin lens's (thin_lens_ray) and trace it again
    // (trace_closest): the raster's hit belongs to the pinhole ray.
    // Step 5: motion blur. In scenes with moving objects (#ifdef HAS_MOTION), every ray of
    // this sample must see the scene at one random moment of the shutter: set
    // g_ray_time (0 = open, 1 = closed) before tracing, and trace the camera ray again too.

    vec3 L = vec3(0.0);
    vec3 throughput = vec3(1.0);  // product of the weights of the lobes sampled so far
    bool specular_prev = true;    // the camera or a delta lobe: light it hits counts in full

    for (int depth = 0; ; ++depth) {
        // ---- The ray escaped: light from the environment ----
        if (hit.prim == NO_HIT) {
            if (specular_prev) L += throughput * env_radiance(ray.dir);
            break;
        }
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;

        // ---- The ray hit a light ----
        // YOUR TURN (step 3): after a glossy bounce the light samples of the vertex before
        // could have found this light too: weigh it (power_heuristic against
        // light_samples * light_pdf(...), env_light_pdf(...) above) instead of leaving it out.
        vec3 Le = surface_emission(s, wo_world);
        if (specular_prev) L += throughput * Le;
        if (depth >= max_depth) break;

        Material m = material_at(s.material, s.uv);  // textures applied
        Frame frame = shading_frame(s, m, wo_world);
        bool diffuse = bsdf_type(m) == MAT_DIFFUSE;

        // ---- Direct light (mirrors and clear glass have none) ----
        if (!bsdf_is_delta(m)) L += throughput * direct_light(s, m, frame, wo_world, !diffuse, rng);

        // ---- YOUR TURN (step 2): mirrors and glass ----
        // Here every branch ends. At a delta surface (bsdf_is_delta), sample its lobe
        // (bsdf_sample picks reflection or refraction), multiply the throughput by the
        // sample's weight and follow the new ray: spawn_ray, trace_closest, next iteration.
        // YOUR TURN (step 3): glossy surfaces. Follow every surface that is not diffuse the
        // same way, and remember what step 3's weight at the next hit needs.
        break;
    }
    return L;
}
