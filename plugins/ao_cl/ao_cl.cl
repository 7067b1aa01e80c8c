// ao_cl: ambient occlusion in OpenCL C, line for line the estimator of plugins/ao/ao.glsl:
//
//   AO(p) = 1/pi * integral over the hemisphere of V(p, w) cos(theta) dw
//
// One cosine-distributed direction per sample; each sample is exactly 0 or 1.
// The library (shaders/opencl/lift/*.h) mirrors the GLSL one; the differences a reader meets:
// functions take the scene (`scene`) explicitly, the random number generator by pointer
// (`rng`), and the parameters arrive as the fields of `params`.

float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params) {
    if (hit.prim == NO_HIT) return (float3)(0.0f);
    Surface s = surface_at(scene, ray, hit);

    // ---- The hemisphere on the side the camera sees ----
    bool front = dot(s.ng, ray.dir) < 0.0f;
    float3 ng = front ? s.ng : -s.ng;
    float3 ns = front ? s.ns : -s.ns;  // surface_at keeps ns on ng's side

    // ---- One cosine-distributed direction around the shading normal ----
    float3 wi = to_world(frame_from_normal(ns), sample_cosine_hemisphere(rng_next2(rng)));
    if (dot(wi, ng) <= 0.0f) return (float3)(0.0f);  // below the true surface: it blocks itself

    // ---- Visibility within the radius ----
    Ray probe = spawn_ray(s, wi);
    probe.tmax = params->radius > 0.0f ? params->radius : 1e30f;
    return trace_occluded(scene, probe) ? (float3)(0.0f) : (float3)(1.0f);
}
