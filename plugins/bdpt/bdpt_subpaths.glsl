// bdpt_subpaths.glsl: the two random walks. A subpath is extended by BSDF sampling, as pt
// does; each new vertex records the area density of being reached (pdf_fwd), and its
// predecessor the density of the reverse step (pdf_rev), which MIS needs later.

// Extends the subpath whose last vertex is bdpt_path[last] along `ray`, whose closest hit is
// `hit`; stores vertices up to (not including) index `end` and returns the index after the
// last one stored. `beta` is the throughput the ray carries, `pdf_dir` the solid-angle density
// of its direction; `first_pdf_pos` > 0 means the ray came from the environment's disk, so
// the first vertex has the disk's density times |cos| there instead.
int extend_subpath(int last, int end, Ray ray, Hit hit, vec3 beta, float pdf_dir, float first_pdf_pos,
                   bool importance, inout Rng rng) {
    vec3 roulette_weight = vec3(1.0);  // throughput relative to the subpath's start
    for (int i = last + 1; i < end; ++i) {
        // ---- Escaped: an environment vertex (camera subpaths only) ----
        if (hit.prim == NO_HIT) {
#ifdef HAS_ENVIRONMENT
            if (!importance) {
                bdpt_path[i] = PathVertex(ray.dir, vec3(0.0), vec3(0.0), -ray.dir, beta, pdf_dir, 0.0,
                                          env_light_pdf(ray.dir), vertex_tag(0u, VERTEX_ENV));
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
        bdpt_path[i] = PathVertex(s.p, s.ng, shading_normal(s, m, wo), wo, beta, 0.0, 0.0, pdf_light_point(s),
                                  vertex_tag(s.material, VERTEX_SURFACE));
#ifdef HAS_TEXTURES
        bdpt_tint[i] = tint;  // for the joins (vertex_bsdf_material)
#endif
        bdpt_path[i].pdf_fwd = i == last + 1 && first_pdf_pos > 0.0 ? first_pdf_pos * abs(dot(ray.dir, s.ng))
                                                                     : area_density(pdf_dir, bdpt_path[i - 1].p, i);
        if (i + 1 >= end) return i + 1;

        // ---- BSDF sampling: the next direction ----
        Frame frame = frame_from_normal(bdpt_path[i].ns);
        vec3 wo_local = to_local(frame, wo);
        BsdfSample bs;
        if (!bsdf_sample(m, wo_local, rng_next3(rng), bs)) return i + 1;
        vec3 wi = to_world(frame, bs.wi);
        if (vertex_blocks(m, i, wo, wi)) return i + 1;
        vec3 weight = bs.weight;
        if (importance) weight *= adjoint_refraction(m, wo_local, bs.wi) * adjoint_shading_normal(i, wo, wi);
        if (bs.is_delta) {
            // A delta lobe has no density to compare: MIS skips the strategies that would
            // need to join here, and the zero densities cancel out of the ratios.
            bdpt_path[i].tag |= 1u;  // delta
            pdf_dir = 0.0;
            bdpt_path[i - 1].pdf_rev = 0.0;
        } else {
            pdf_dir = bs.pdf;
            bdpt_path[i - 1].pdf_rev = area_density(bsdf_pdf(m, bs.wi, wo_local), s.p, i - 1);
        }
        beta *= weight;
        roulette_weight *= weight;

        // ---- Russian roulette: end dim subpaths, reweight the survivors ----
        if (i - last >= rr_depth) {
            float survive = clamp(max(roulette_weight.r, max(roulette_weight.g, roulette_weight.b)),
                                  rr_min_survival, 1.0);
            if (rng_next(rng) >= survive) return i + 1;
            beta /= survive;
            roulette_weight /= survive;
        }
        ray = spawn_ray(s, wi);
        trace_closest(ray, hit);
    }
    return end;
}

// ---- The camera subpath: z0 the pinhole, z1 the G-buffer's hit, then BSDF sampling ----
// Returns the number of camera vertices.
int camera_subpath(Ray ray, Hit hit, int depth, inout Rng rng) {
    bdpt_path[0] = PathVertex(ray.origin, u_cam_forward, u_cam_forward, vec3(0.0), vec3(1.0), 1.0, 0.0, 0.0,
                              vertex_tag(0u, VERTEX_CAMERA));
    return extend_subpath(0, depth + 2, ray, hit, vec3(1.0), camera_pdf_dir(ray.dir), 0.0, false, rng);
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
    bdpt_path[BDPT_LIGHT_BASE] = PathVertex(light.p, light.n, light.n, vec3(0.0), light.radiance / light.pdf,
                                            light.pdf, 0.0, light.pdf,
                                            vertex_tag(0u, light.delta ? VERTEX_DISTANT
                                                           : light.infinite ? VERTEX_ENV : VERTEX_EMITTER));
    // Radiance times the cosine at the light, over the density of the ray (origin and direction).
    float cos_light = light.infinite ? 1.0 : dot(light.n, es.ray.dir);
    vec3 beta = light.radiance * (cos_light / (es.pdf_pos * es.pdf_dir));
    Hit hit;
    trace_closest(es.ray, hit);
    int end = extend_subpath(BDPT_LIGHT_BASE, BDPT_LIGHT_BASE + depth + 1, es.ray, hit, beta, es.pdf_dir,
                             light.infinite ? es.pdf_pos : 0.0, true, rng);
    return end - BDPT_LIGHT_BASE;
}
