// bdpt_subpaths.glsl: the two random walks. A subpath is extended by BSDF sampling, as pt
// does; each new vertex records the area density of being reached (pdf_fwd) and the MIS sum
// of the vertices before its predecessor (mis_sum, bdpt_mis.glsl), which needs the density of
// each step walked backwards. The light subpath's vertices are stored (bdpt_light) and each is
// joined to the pinhole as it is stored (t = 1); each camera vertex is joined to them when it
// is made (camera_vertex_joins), then only it and its predecessor are kept.
//
// Both subpaths are walked by one loop, a vertex per iteration (walk_step), the light subpath
// first: a lane whose light subpath has ended starts its camera subpath in the next iteration,
// while the other lanes of its warp still extend theirs, in the same code (one traversal, one
// surface and BSDF-sampling site). Nested loops (the light walk, then the camera walk) made a
// warp wait for its longest light subpath before any camera work, and compiled the walk twice.

// Where a subpath starts (light_subpath_start, camera_subpath_start).
struct SubpathStart {
    PathVertex vertex;   // vertex 0 (y0 or z0)
    Ray ray;             // the ray towards vertex 1
    vec3 beta;           // the throughput it carries
    float pdf_dir;       // the solid-angle density of its direction
    float first_pdf_pos; // > 0: from the environment's disk (the disk's density)
    float mis_sum;       // vertex 1's
};

// One subpath being walked: the state between two vertices.
struct Walk {
    PathVertex prev;       // the last vertex made (vertex i - 1)
    PathVertex stored_prev;// light subpaths: the last vertex read back from bdpt_light
    Ray ray;               // towards vertex i (traced at the step's start, except the camera's first)
    Hit hit;
    vec3 beta;             // the throughput the ray carries
    vec3 roulette_weight;  // throughput relative to the subpath's start
    float pdf_dir;         // the solid-angle density of the ray's direction
    float first_pdf_pos;   // > 0: vertex 1 of a ray from the environment's disk (the disk's density)
    float mis_sum;         // vertex i's
    int i;                 // the vertex this step makes
    int end;               // vertices are made up to end - 1
    bool importance;       // a light subpath (stored, joined to the pinhole); else a camera subpath
};

// The walk that starts at `start.vertex` (vertex 0) along start.ray; `hit` is that ray's first
// hit for the camera subpath (the G-buffer's), traced by the first step for a light subpath.
Walk walk_start(SubpathStart start, Hit hit, int end, bool importance) {
    return Walk(start.vertex, start.vertex, start.ray, hit, start.beta, vec3(1.0), start.pdf_dir, start.first_pdf_pos,
                start.mis_sum, 1, end, importance);
}

// Makes vertex w.i (stored, or joined to the light subpath's first light_vertices vertices,
// adding to L) and samples the next direction. Returns 0 while the subpath goes on, else the
// number of vertices it has, vertex 0 included.
int walk_step(inout Walk w, int light_vertices, inout vec3 L, inout Rng rng) {
    int i = w.i;
    if (i >= w.end) return w.end;  // path length 0: the light subpath is y0 alone
    if (w.importance || i > 1) trace_closest(w.ray, w.hit);
    // ---- Escaped: an environment vertex (camera subpaths only) ----
    if (w.hit.prim == NO_HIT) {
#ifdef HAS_ENVIRONMENT
        if (!w.importance) {
            PathVertex v = path_vertex(w.ray.dir, vec3(0.0), vec3(0.0), -w.ray.dir, w.beta, w.pdf_dir,
                                       vertex_tag(0u, VERTEX_ENV));
            v.mis_sum = w.mis_sum;
            L += camera_vertex_joins(v, w.prev, 0.0, i + 1, light_vertices, rng);
            return i + 1;
        }
#endif
        return i;
    }

    // ---- A surface vertex ----
    Surface s = surface_at(w.ray, w.hit);
    vec3 tint = texture_tint(s.material, s.uv);
    Material m = material_tinted(s.material, tint);  // = material_at(s.material, s.uv)
    vec3 wo = -w.ray.dir;
    PathVertex v = path_vertex(s.p, s.ng, shading_normal(s, m, wo), wo, w.beta, 0.0,
                               vertex_tag(s.material, VERTEX_SURFACE));
#ifdef HAS_TEXTURES
    v.tint = tint;  // for the joins (vertex_bsdf_material)
#endif
    v.pdf_fwd = i == 1 && w.first_pdf_pos > 0.0 ? w.first_pdf_pos * abs(dot(w.ray.dir, s.ng))
                                                : area_density(w.pdf_dir, w.prev.p, v);
    v.mis_sum = w.mis_sum;

    // ---- BSDF sampling: the next direction (none from the last vertex) ----
    // Sampled before the joins, which must know whether the vertex scattered by a delta lobe.
    Frame frame = frame_from_normal(v.ns);
    vec3 wo_local = to_local(frame, wo);
    BsdfSample bs;
    vec3 wi;
    bool goes_on = i + 1 < w.end && bsdf_sample(m, wo_local, rng_next3(rng), bs);
    if (goes_on) {
        wi = to_world(frame, bs.wi);
        goes_on = !vertex_blocks(m, v, wo, wi);
    }
    if (goes_on && bs.is_delta) v.tag |= 1u;  // delta: never joined

    if (w.importance) {
        // y_i joined to the pinhole (t = 1, s = i + 1), as stored (its directions packed)
        store_light_vertex(i, v);
        PathVertex y = light_vertex(i);
        if (strategy_kept(i + 1, 1)) strategy_light_tracing(y, w.stored_prev);
        w.stored_prev = y;
    } else {
        L += camera_vertex_joins(v, w.prev, pdf_light_point(s), i + 1, light_vertices, rng);
    }
    if (!goes_on) return i + 1;

    vec3 weight = bs.weight;
    if (w.importance) weight *= adjoint_refraction(m, wo_local, bs.wi) * adjoint_shading_normal(v, wo, wi);
    // A delta lobe has no density to compare: MIS skips the strategies that would need to
    // join here, and the zero densities cancel out of the ratios.
    float prev_pdf_rev = bs.is_delta ? 0.0 : area_density(bsdf_pdf(m, bs.wi, wo_local), s.p, w.prev);
    w.pdf_dir = bs.is_delta ? 0.0 : bs.pdf;
    w.mis_sum = next_mis_sum(w.mis_sum, bs.is_delta, vertex_delta(w.prev), prev_pdf_rev, w.prev.pdf_fwd);
    w.beta *= weight;
    w.roulette_weight *= weight;

    // ---- Russian roulette: end dim subpaths, reweight the survivors ----
    if (i >= rr_depth) {
        float survive = clamp(max(w.roulette_weight.r, max(w.roulette_weight.g, w.roulette_weight.b)),
                              rr_min_survival, 1.0);
        if (rng_next(rng) >= survive) return i + 1;
        w.beta /= survive;
        w.roulette_weight /= survive;
    }
    w.prev = v;
    w.ray = spawn_ray(s, wi);
    w.i = i + 1;
    return i + 1 < w.end ? 0 : w.end;
}

// ---- The light subpath's start: y0 on a light, chosen as next event estimation would ----
// From a light at infinity, y0 is the direction and y1 is where the ray from the disk lands;
// y1's density is then the disk's times |cos| there (pbrt-v3 does the same).
// Returns false if there is no light to start from (then the subpath has no vertex).

bool light_subpath_start(inout Rng rng, out SubpathStart start) {
    EmissionSample es;
    vec3 u_point = rng_next3(rng);
    if (!sample_emission(u_point, rng_next2(rng), es)) return false;
    LightPoint light = es.light;
    start.vertex = path_vertex(light.p, light.n, light.n, vec3(0.0), light.radiance / light.pdf, light.pdf,
                               vertex_tag(0u, light.delta ? VERTEX_DISTANT
                                                : light.infinite ? VERTEX_ENV : VERTEX_EMITTER));
    start.ray = es.ray;
    // Radiance times the cosine at the light, over the density of the ray (origin and direction).
    float cos_light = light.infinite ? 1.0 : dot(light.n, es.ray.dir);
    start.beta = light.radiance * (cos_light / (es.pdf_pos * es.pdf_dir));
    start.pdf_dir = es.pdf_dir;
    start.first_pdf_pos = light.infinite ? es.pdf_pos : 0.0;
    // y1's mis_sum: the camera subpath (s = 0) could have hit y0 unless the light is a delta
    start.mis_sum = light.delta ? 0.0 : 1.0;
    return true;
}

// ---- The camera subpath's start: z0 the pinhole, z1 the G-buffer's hit (not traced again) ----
SubpathStart camera_subpath_start(Ray ray) {
    // z1's mis_sum is 0: no strategy has the light subpath reach the pinhole
    return SubpathStart(path_vertex(ray.origin, u_cam_forward, u_cam_forward, vec3(0.0), vec3(1.0), 1.0,
                                    vertex_tag(0u, VERTEX_CAMERA)),
                        ray, vec3(1.0), camera_pdf_dir(ray.dir), 0.0, 0.0);
}
