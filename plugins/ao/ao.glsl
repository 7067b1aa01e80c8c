// ao: ambient occlusion at the first hit p, with normal n on the side the camera sees:
//
//   AO(p) = 1/pi * integral over the hemisphere of V(p, w) cos(theta) dw
//
// V(p, w) = 1 when a ray from p along w travels `radius` without hitting anything.
// One direction per sample, drawn with pdf cos(theta) / pi: the cosine and the pdf cancel,
// so each sample is exactly 0 or 1 and the pixel mean is the unoccluded fraction.
// plugins/ao_cl/ao_cl.cl is the same estimator in OpenCL C, drawing the same random numbers.

vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
    if (hit.prim == NO_HIT) return vec3(0.0);
    Surface s = surface_at(ray, hit);

    // ---- The hemisphere on the side the camera sees ----
    bool front = dot(s.ng, ray.dir) < 0.0;
    vec3 ng = front ? s.ng : -s.ng;
    vec3 ns = front ? s.ns : -s.ns;  // surface_at keeps ns on ng's side

    // ---- One cosine-distributed direction around the shading normal ----
    vec3 wi = to_world(frame_from_normal(ns), sample_cosine_hemisphere(rng_next2(rng)));
    if (dot(wi, ng) <= 0.0) return vec3(0.0);  // below the true surface: it blocks itself

    // ---- Visibility within the radius ----
    Ray probe = spawn_ray(s, wi);
    probe.tmax = radius > 0.0 ? radius : 1e30;
    return trace_occluded(probe) ? vec3(0.0) : vec3(1.0);
}
