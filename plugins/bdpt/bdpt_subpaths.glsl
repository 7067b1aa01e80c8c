// bdpt_subpaths.glsl: the two random walks. A subpath is extended by BSDF sampling, as pt
// does; each new vertex records the area density of being reached (pdf_fwd) and the MIS sum
// of the vertices before its predecessor (mis_sum, bdpt_mis.glsl), which needs the density of
// each step walked backwards. The light subpath's vertices are stored (store_light_vertex); each camera
// vertex is joined to them when it is made (camera_vertex_joins), then only it and its
// predecessor are kept.

// Extends the subpath whose last vertex is `prev` (vertex 0) along `ray`, whose closest hit is
// `hit`, up to vertex end - 1; returns the number of vertices the subpath has, vertex 0
// included. `beta` is the throughput the ray carries, `pdf_dir` the solid-angle density of its
// direction; `first_pdf_pos` > 0 means the ray came from the environment's disk, so the first
// vertex has the disk's density times |cos| there instead; `mis_sum` is vertex 1's.
// `importance`: a light subpath, stored (store_light_vertex); otherwise a camera subpath, whose
// vertices are joined to the light subpath's first light_vertices vertices and add to L.
int extend_subpath(PathVertex prev, int end, Ray ray, Hit hit, vec3 beta, float pdf_dir, float first_pdf_pos,
                   float mis_sum, bool importance, int light_vertices, inout vec3 L, inout Rng rng) {
    vec3 roulette_weight = vec3(1.0);  // throughput relative to the subpath's start
    float eta_scale = 1.0;  // a camera subpath's refractions' radiance scales so far (pt's)
    for (int i = 1; i < end; ++i) {
        // ---- Escaped: an environment vertex (camera subpaths only) ----
        if (hit.prim == NO_HIT) {
#ifdef HAS_ENVIRONMENT
            if (!importance) {
                PathVertex v = path_vertex(ray.dir, vec3(0.0), vec3(0.0), -ray.dir, beta, pdf_dir,
                                           vertex_tag(0u, VERTEX_ENV));
                v.mis_sum = mis_sum;
                L += camera_vertex_joins(v, prev, 0.0, i + 1, light_vertices, rng);
                return i + 1;
            }
#endif
            return i;
        }

        // ---- A surface vertex ----
        Surface s = surface_at(ray, hit);
        vec3 tint = texture_tint(s.material, s.uv);
        Material m = material_tinted(s.material, tint);  // = material_at(s.material, s.uv)
        vec3 wo = -ray.dir;
        PathVertex v = path_vertex(s.p, s.ng, shading_normal(s, m, wo), wo, beta, 0.0,
                                   vertex_tag(s.material, VERTEX_SURFACE));
#ifdef HAS_TEXTURES
        v.tint = tint;  // for the joins (vertex_bsdf_material)
#endif
        v.pdf_fwd = i == 1 && first_pdf_pos > 0.0 ? first_pdf_pos * abs(dot(ray.dir, s.ng))
                                                  : area_density(pdf_dir, prev.p, v);
        v.mis_sum = mis_sum;

        // ---- BSDF sampling: the next direction (none from the last vertex) ----
        // Sampled before the joins, which must know whether the vertex scattered by a delta lobe.
        Frame frame = frame_from_normal(v.ns);
        vec3 wo_local = to_local(frame, wo);
        BsdfSample bs;
        vec3 wi;
        bool goes_on = i + 1 < end && bsdf_sample(m, wo_local, rng_next3(rng), bs);
        if (goes_on) {
            wi = to_world(frame, bs.wi);
            goes_on = !vertex_blocks(m, v, wo, wi);
        }
        if (goes_on && bs.is_delta) v.tag |= 1u;  // delta: never joined

        if (importance) {
            store_light_vertex(i, v);
        } else {
            L += camera_vertex_joins(v, prev, pdf_light_point(s), i + 1, light_vertices, rng);
        }
        if (!goes_on) return i + 1;

        vec3 weight = bs.weight;
        if (importance) weight *= refraction_eta2(m, wo_local, bs.wi) * adjoint_shading_normal(v, wo, wi);
        // A delta lobe has no density to compare: MIS skips the strategies that would need to
        // join here, and the zero densities cancel out of the ratios.
        float prev_pdf_rev = bs.is_delta ? 0.0 : area_density(bsdf_pdf(m, bs.wi, wo_local), s.p, prev);
        pdf_dir = bs.is_delta ? 0.0 : bs.pdf;
        mis_sum = next_mis_sum(mis_sum, bs.is_delta, vertex_delta(prev), prev_pdf_rev, prev.pdf_fwd);
        beta *= weight;
        roulette_weight *= weight;
        if (!importance) eta_scale *= refraction_eta2(m, wo_local, bs.wi);

        // ---- Russian roulette: end dim subpaths, reweight the survivors ----
        if (i >= rr_depth) {
            // As pt's: judged without the refractions' 1 / etap^2, which the way out undoes
            // (a light subpath's weight carries none: refraction_eta2 took it out).
            vec3 judged = roulette_weight * eta_scale;
            float survive = clamp(max(judged.r, max(judged.g, judged.b)), rr_min_survival, 1.0);
            if (rng_next(rng) >= survive) return i + 1;
            beta /= survive;
            roulette_weight /= survive;
        }
        prev = v;
        ray = spawn_ray(s, wi);
        trace_closest(ray, hit);
    }
    return end;
}

// ---- The light subpath: y0 on a light, chosen as next event estimation would ----
// From a light at infinity, y0 is the direction and y1 is where the ray from the disk lands;
// y1's density is then the disk's times |cos| there (pbrt-v3 does the same).
// Returns the number of light vertices (0: no light to start from).
int light_subpath(int depth, inout Rng rng) {
    EmissionSample es;
    vec3 u_point = rng_next3(rng);
    if (!sample_emission(u_point, rng_next2(rng), es)) return 0;
    LightPoint light = es.light;
    PathVertex y0 = path_vertex(light.p, light.n, light.n, vec3(0.0), light.radiance / light.pdf, light.pdf,
                                vertex_tag(0u, light.delta ? VERTEX_DISTANT
                                               : light.infinite ? VERTEX_ENV : VERTEX_EMITTER));
    store_light_vertex(0, y0);
    // Radiance times the cosine at the light, over the density of the ray (origin and direction).
    float cos_light = light.infinite ? 1.0 : dot(light.n, es.ray.dir);
    vec3 beta = light.radiance * (cos_light / (es.pdf_pos * es.pdf_dir));
    Hit hit;
    trace_closest(es.ray, hit);
    vec3 unused = vec3(0.0);
    // y1's mis_sum: the camera subpath (s = 0) could have hit y0 unless the light is a delta
    return extend_subpath(y0, depth + 1, es.ray, hit, beta, es.pdf_dir, light.infinite ? es.pdf_pos : 0.0,
                          light.delta ? 0.0 : 1.0, true, 0, unused, rng);
}

// ---- The camera subpath: z0 the pinhole, z1 the G-buffer's hit, then BSDF sampling ----
// Each camera vertex is joined to the light subpath's light_vertices vertices as it is made;
// returns the radiance of all those joins (light tracing, t = 1, excepted).
vec3 camera_subpath(Ray ray, Hit hit, int depth, int light_vertices, inout Rng rng) {
    PathVertex z0 = path_vertex(ray.origin, u_cam_forward, u_cam_forward, vec3(0.0), vec3(1.0), 1.0,
                                vertex_tag(0u, VERTEX_CAMERA));
    vec3 L = vec3(0.0);
    // z1's mis_sum is 0: no strategy has the light subpath reach the pinhole
    extend_subpath(z0, depth + 2, ray, hit, vec3(1.0), camera_pdf_dir(ray.dir), 0.0, 0.0, false, light_vertices, L, rng);
    return L;
}
