// bdpt_strategies.glsl: the four kinds of strategy (s light vertices, t camera vertices). A
// camera vertex z = z_{t-1} comes with its predecessor z_prev = z_{t-2}; light vertices are
// read from the stored light subpath (light_vertex, bdpt_vertex.glsl).

int bdpt_depth_limit() { return min(max_depth, BDPT_MAX_DEPTH); }

// Whether strategy (s, t) runs: the study parameters only_s and only_depth can single some out.
bool strategy_kept(int s, int t) {
    int depth = s + t - 2;  // bounces of the full path
    return (only_depth < 0 || depth == only_depth) && (only_s < 0 || s == only_s);
}

// ---- s = 0: camera vertex z is on a light (emitter_pdf: sample_light_point's density there) ----
vec3 strategy_emitted(PathVertex z, PathVertex z_prev, float emitter_pdf, int t) {
    vec3 emitted;
    float pt_rev;              // density of the light subpath starting at z_{t-1}
    float pt_minus_rev = 0.0;  // ... and reaching z_{t-2} from there
    if (vertex_kind(z) == VERTEX_ENV) {
        emitted = env_radiance(z.p);
        pt_rev = env_light_pdf(z.p);
        if (t > 2) pt_minus_rev = pdf_env_emission_pos() * abs(dot(z_prev.ng, z.p));
    } else if (vertex_kind(z) == VERTEX_SURFACE && emitter_pdf > 0.0 && dot(z.wo, z.ng) > 0.0) {
        emitted = materials[vertex_material(z)].emission_alpha.rgb;  // emitters emit from the front
        pt_rev = emitter_pdf;
        if (t > 2) pt_minus_rev = area_density(pdf_emission_dir(z.ng, z.wo), z.p, z_prev);
    } else {
        return vec3(0.0);
    }
    if (all(equal(emitted, vec3(0.0)))) return vec3(0.0);
    if (t == 2) return z.beta * emitted;  // an emitter seen directly: only the camera subpath makes it
    float camera_side = mis_side(pt_rev, z.pdf_fwd, z.mis_sum, vertex_delta(z_prev), pt_minus_rev, z_prev.pdf_fwd);
    return z.beta * emitted * mis_weight(camera_side, 0.0);
}

// A join of camera vertex z by a shadow ray (s >= 1): its MIS-weighted contribution if z sees
// the point at distance `dist` along `dir`. The caller traces that ray, one call site for both
// kinds of join (a traversal inlined once less; on a GPU the program's size matters).
struct Join {
    vec3 contribution;
    vec3 dir;
    float dist;
};

const Join NO_JOIN = Join(vec3(0.0), vec3(0.0, 0.0, 1.0), 0.0);

// ---- s = 1: a light point sampled afresh, joined to camera vertex z ----
Join strategy_light_sample(PathVertex z, PathVertex z_prev, inout Rng rng) {
    if (!vertex_connectible(z)) return NO_JOIN;
    LightPoint light;
    if (!sample_light_point(rng_next3(rng), light)) return NO_JOIN;
    vec3 wi;                     // from z towards the light
    float dist = 1e30;
    float cos_light_over_d2 = 1.0;  // the light's half of the geometry term (1: at infinity)
    if (light.infinite) {
        wi = light.p;
    } else {
        vec3 d = light.p - z.p;
        float dist2 = dot(d, d);
        if (!(dist2 > 0.0)) return NO_JOIN;
        dist = sqrt(dist2);
        wi = d / dist;
        cos_light_over_d2 = dot(light.n, -wi) / dist2;
        if (cos_light_over_d2 <= 0.0) return NO_JOIN;  // the back of a one-sided emitter
    }
    VertexScatter at_z = vertex_scatter(z, wi, false);
    vec3 contribution = z.beta * at_z.f * light.radiance * (cos_light_over_d2 / light.pdf);
    if (all(equal(contribution, vec3(0.0)))) return NO_JOIN;

    float qs_rev = at_z.pdf_out * cos_light_over_d2;  // the camera subpath going on to the light
    float cos_z = abs(dot(z.ng, wi));
    float pt_rev = light.infinite ? pdf_env_emission_pos() * cos_z
                                : pdf_emission_dir(light.n, -wi) * cos_z / (dist * dist);
    float pt_minus_rev = area_density(at_z.pdf_back, z.p, z_prev);
    float camera_side = mis_side(pt_rev, z.pdf_fwd, z.mis_sum, vertex_delta(z_prev), pt_minus_rev, z_prev.pdf_fwd);
    float light_side = mis_side(qs_rev, light.pdf, 0.0, light.delta, 0.0, 1.0);
    return Join(contribution * mis_weight(camera_side, light_side), wi, dist);
}

// ---- t = 1: light vertex y = y_{s-1} (predecessor y_prev) seen by the pinhole, splatted to its pixel ----
void strategy_light_tracing(PathVertex y, PathVertex y_prev) {
    if (!vertex_connectible(y)) return;
    vec2 pixel_pos;
    if (!camera_project(y.p, pixel_pos)) return;
    vec3 to_camera = u_cam_pos - y.p;
    float dist2 = dot(to_camera, to_camera);
    float dist = sqrt(dist2);
    vec3 wi = to_camera / dist;
    VertexScatter at_y = vertex_scatter(y, wi, true);
    // W_e cos / d^2: the camera's importance and its half of the geometry term.
    float importance = camera_importance(-wi) * dot(-wi, u_cam_forward) / dist2;
    vec3 contribution = y.beta * at_y.f * importance;
    if (all(equal(contribution, vec3(0.0))) || !vertex_sees(y, wi, dist)) return;

    float qs_rev = camera_pdf_dir(-wi) * abs(dot(y.ng, wi)) / dist2;  // a camera ray reaching y
    float qs_minus_rev = area_density(at_y.pdf_back, y.p, y_prev);
    float light_side = mis_side(qs_rev, y.pdf_fwd, y.mis_sum, vertex_delta(y_prev), qs_minus_rev, y_prev.pdf_fwd);
    splat(pixel_pos, contribution * mis_weight(0.0, light_side));
}

// ---- s >= 2, t >= 2: light vertex y = y_{s-1} (predecessor y_prev) and camera vertex z joined by a shadow ray ----
Join strategy_connect(PathVertex y, PathVertex y_prev, PathVertex z, PathVertex z_prev) {
    if (!vertex_connectible(y) || !vertex_connectible(z)) return NO_JOIN;
    vec3 d = y.p - z.p;
    float dist2 = dot(d, d);
    if (!(dist2 > 0.0)) return NO_JOIN;
    float dist = sqrt(dist2);
    vec3 wi = d / dist;  // from z towards y
    VertexScatter at_z = vertex_scatter(z, wi, false);
    VertexScatter at_y = vertex_scatter(y, -wi, true);
    vec3 contribution = z.beta * at_z.f * at_y.f * y.beta / dist2;
    if (all(equal(contribution, vec3(0.0)))) return NO_JOIN;

    float pt_rev = area_density(at_y.pdf_out, y.p, z);
    float pt_minus_rev = area_density(at_z.pdf_back, z.p, z_prev);
    float qs_rev = area_density(at_z.pdf_out, z.p, y);
    float qs_minus_rev = area_density(at_y.pdf_back, y.p, y_prev);
    float camera_side = mis_side(pt_rev, z.pdf_fwd, z.mis_sum, vertex_delta(z_prev), pt_minus_rev, z_prev.pdf_fwd);
    float light_side = mis_side(qs_rev, y.pdf_fwd, y.mis_sum, vertex_delta(y_prev), qs_minus_rev, y_prev.pdf_fwd);
    return Join(contribution * mis_weight(camera_side, light_side), wi, dist);
}

// ---- Camera vertex z = z_{t-1} joined to every light prefix whose path has at most depth_limit bounces ----
vec3 camera_vertex_joins(PathVertex z, PathVertex z_prev, float emitter_pdf, int t, int light_vertices,
                         inout Rng rng) {
    vec3 L = vec3(0.0);
    int last_s = min(max(light_vertices, 1), bdpt_depth_limit() + 2 - t);
    PathVertex y_prev;  // y_{s-2}: the vertex the join before read (each join reads one stored vertex)
    for (int s = 0; s <= last_s; ++s) {
        if (s == 0) {
            if (strategy_kept(s, t)) L += strategy_emitted(z, z_prev, emitter_pdf, t);
            continue;
        }
        Join join = NO_JOIN;
        if (s == 1) {
            if (strategy_kept(s, t)) join = strategy_light_sample(z, z_prev, rng);
        } else {
            if (s == 2) y_prev = light_vertex(0);
            PathVertex y = light_vertex(s - 1);
            if (strategy_kept(s, t)) join = strategy_connect(y, y_prev, z, z_prev);
            y_prev = y;
        }
        // Joins whose contribution is zero (MIS weight aside) trace no ray, as before.
        if (join.dist > 0.0 && vertex_sees(z, join.dir, join.dist)) L += join.contribution;
    }
    return L;
}
