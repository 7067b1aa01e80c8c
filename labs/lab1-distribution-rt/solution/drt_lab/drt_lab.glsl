// drt_lab: lab 1's distribution ray tracer, the instructor's solution.
//
// Whitted's ray tracer follows mirror and glass rays recursively and lights every hit with
// one shadow ray per point light. Cook's tracer distributes those rays over what they stand
// for, which turns aliasing into noise and shows what Whitted could not:
//   step 1  soft shadows          shadow rays go to random points on area lights
//   step 2  mirrors and glass     the branch follows a delta lobe (bsdf_sample picks
//                                 reflection or refraction by Fresnel)
//   step 3  glossy reflection     the branch follows a direction sampled from a rough lobe;
//                                 light it hits is weighed against the light samples (MIS)
//   step 4  depth of field        the camera ray starts at a random point of a thin lens
//   step 5  motion blur           each camera sample sees the scene at a random moment of the
//                                 shutter; every ray of the sample keeps it (g_ray_time)
// GLSL has no recursion, so the ray tree is walked as a loop along one branch: each bounce
// samples one lobe and multiplies the branch's throughput by that lobe's weight. A diffuse
// surface ends the branch: light it gets from other surfaces (diffuse interreflection,
// caustics) is left out, as in Whitted's and Cook's tracers; lab 2's path tracer adds it.
// Parameters (plugin.toml): max_depth, light_samples.
#include "lens.glsl"

// ---- Step 4: depth of field ----
// The host's ray is a pinhole's, through this sample's point of the pixel. A thin lens of
// radius u_lens_radius (the scene's camera aperture) focuses every ray through one lens point
// on the point of the pinhole ray at u_focus_distance (measured along the view direction).
Ray thin_lens_ray(Ray pinhole_ray, vec2 u) {
    if (u_lens_radius <= 0.0) return pinhole_ray;
    vec3 focus_point = pinhole_ray.origin + pinhole_ray.dir * (u_focus_distance / dot(pinhole_ray.dir, u_cam_forward));
    vec2 lens = sample_lens(u) * u_lens_radius;  // uniform on the lens's disk (lens.glsl)
    vec3 origin = pinhole_ray.origin + lens.x * u_cam_right + lens.y * u_cam_up;
    return Ray(origin, normalize(focus_point - origin), 0.0, 1e30);
}

// ---- Step 1: direct light with soft shadows ----
// Light arriving at s directly from the emitters and the environment, reflected towards wo:
// the mean of light_samples shadow rays to random points of the lights. Where the branch
// goes on (a glossy surface), its bounce may hit the same light, so both estimates are
// weighted by multiple importance sampling (step 3: power heuristic, light_samples light
// samples against one BSDF sample).
vec3 direct_light(Surface s, Material m, Frame frame, vec3 wo_world, bool branch_goes_on, inout Rng rng) {
    vec3 wo = to_local(frame, wo_world);
    vec3 sum = vec3(0.0);
    float n_light = float(light_samples);
    for (int k = 0; k < light_samples; ++k) {
        LightSample ls;
        if (!sample_light(s.p, rng_next3(rng), ls)) continue;  // no light in the scene
        // Through the true surface of an opaque one: nothing (BSDF sampling agrees).
        if (is_opaque(m) && !same_side_of_surface(s, wo_world, ls.wi)) continue;
        vec3 wi = to_local(frame, ls.wi);
        vec3 f = bsdf_eval(m, wo, wi);  // BSDF times the cosine at s
        if (!any(greaterThan(f, vec3(0.0)))) continue;
        if (trace_occluded(spawn_shadow_ray(s, ls.wi, ls.dist))) continue;  // in shadow
        // A delta light (distant) can't be found by BSDF sampling: no MIS.
        float w = branch_goes_on && !ls.is_delta ? power_heuristic(n_light * ls.pdf, bsdf_pdf(m, wo, wi)) : 1.0;
        sum += f * ls.radiance * (w / ls.pdf);
    }
    return sum / n_light;
}

// ---- Step 3: the weight of light that the branch ran into ----
// After the camera or a delta lobe it counts in full (no light sample can find it); after a
// glossy bounce the light samples of the vertex before could have found it too.
float emission_weight(bool specular_prev, float bsdf_pdf_prev, float light_pdf_here) {
    return specular_prev ? 1.0 : power_heuristic(bsdf_pdf_prev, float(light_samples) * light_pdf_here);
}

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    // ---- Steps 4 and 5: this sample's camera ray, traced again ----
    bool own_camera_ray = u_lens_radius > 0.0;
#ifdef HAS_MOTION
    g_ray_time = rng_next(rng);  // uniform over the shutter interval: a box shutter
    own_camera_ray = true;       // the raster saw the scene at the shutter's opening
#endif
    if (own_camera_ray) {
        ray = thin_lens_ray(ray, rng_next2(rng));
        trace_closest(ray, hit);
    }

    vec3 L = vec3(0.0);
    vec3 throughput = vec3(1.0);  // product of the weights of the lobes sampled so far
    bool specular_prev = true;    // the camera or a delta lobe: light it hits counts in full
    float bsdf_pdf_prev = 0.0;    // solid-angle pdf of the glossy bounce that led here
    vec3 p_prev = ray.origin;

    for (int depth = 0; ; ++depth) {
        // ---- The ray escaped: light from the environment ----
        if (hit.prim == NO_HIT) {
            L += throughput * env_radiance(ray.dir) * emission_weight(specular_prev, bsdf_pdf_prev, env_light_pdf(ray.dir));
            break;
        }
        Surface s = surface_at(ray, hit);
        vec3 wo_world = -ray.dir;

        // ---- The ray hit a light ----
        vec3 Le = surface_emission(s, wo_world);
        if (any(greaterThan(Le, vec3(0.0))))
            L += throughput * Le * emission_weight(specular_prev, bsdf_pdf_prev, light_pdf(p_prev, s, ray.dir, hit.t));
        if (depth >= max_depth) break;

        Material m = material_at(s.material, s.uv);  // textures applied
        Frame frame = shading_frame(s, m, wo_world);
        bool diffuse = bsdf_type(m) == MAT_DIFFUSE;

        // ---- Direct light with soft shadows (mirrors and clear glass have none) ----
        if (!bsdf_is_delta(m)) L += throughput * direct_light(s, m, frame, wo_world, !diffuse, rng);

        // ---- A diffuse surface ends the branch ----
        if (diffuse) break;

        // ---- Steps 2 and 3: reflection or refraction, one lobe, one direction, sampled ----
        BsdfSample bs;
        if (!bsdf_sample(m, to_local(frame, wo_world), rng_next3(rng), bs)) break;
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
