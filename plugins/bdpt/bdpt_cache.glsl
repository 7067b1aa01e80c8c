// bdpt_cache.glsl: joins through a light vertex cache (Davidovic et al. 2014), with
// cache_connections = M > 0. Rather than to every vertex of its own pixel sample's light
// subpath, each camera vertex is joined to M light vertices drawn uniformly from the cache: all
// the connectible light vertices (y_i, i >= 1) of every light subpath of the frame, which the
// prepass lists as it stores them. With N_v vertices in the cache and N_p light subpaths,
// (N_v / M) times the sum of the M joins estimates the sum of the joins to all N_v vertices,
// the sum over N_p light subpaths: divided by N_p, it estimates what the joins to one light
// subpath do. Unbiased: each join keeps its strategy's MIS weight, and the weights of a path's
// strategies still sum to one. The other strategies (s = 0, s = 1, t = 1) are the sample's own.
//
// The list lives after the stored vertices (bdpt_vertex.glsl): cached vertex k is the pair
// (pixel sample, i) in words 2 (k % 2), 2 (k % 2) + 1 of uvec4 k / 2 of the region, which has
// (BDPT_MAX_DEPTH + 2) / 2 entries a pixel sample (plugin.toml's `entries`); its length is the
// prepass's counter 0.
const int BDPT_CACHE_FIRST_ENTRY = BDPT_FIRST_VERTEX_ENTRY + 4 * BDPT_LIGHT_VERTICES;
const int BDPT_CACHE_COUNTER = 0;

// The prepass: light vertex i of this pixel sample goes into the cache.
void cache_light_vertex(int i) {
    uint k = prepass_count_add(BDPT_CACHE_COUNTER, 1u);
    uint q = k / 2u;
    int entry = BDPT_CACHE_FIRST_ENTRY + int(q / u_prepass_stride);
    uint component = 2u * (k % 2u);
    prepass_store_word_at(entry, q % u_prepass_stride, component, lift_prepass_sample);
    prepass_store_word_at(entry, q % u_prepass_stride, component + 1u, uint(i));
}

// Cached vertex k: (pixel sample, i).
uvec2 cached_light_vertex(uint k) {
    uint q = k / 2u;
    uvec4 words = prepass_load_at(BDPT_CACHE_FIRST_ENTRY + int(q / u_prepass_stride), q % u_prepass_stride);
    return k % 2u == 0u ? words.xy : words.zw;
}

// Uniform in [0, n): 48 random bits scaled in double precision, so that every vertex of a
// cache of up to 2^24 and more has its chance (a 24-bit float would leave most out), equal to
// 1 part in 2^48 / n.
uint uniform_index(uint n, inout Rng rng) {
    double u = (double(uint(rng_next(rng) * 16777216.0)) + double(rng_next(rng))) / 16777216.0LF;
    return min(uint(u * double(n)), n - 1u);
}

// Camera vertex z = z_{t-1} joined to M cached light vertices y = y_{s-1} (s from the vertex).
vec3 cache_joins(PathVertex z, PathVertex z_prev, int t, inout Rng rng) {
    uint cached = prepass_count(BDPT_CACHE_COUNTER);
    if (cached == 0u || !vertex_connectible(z)) return vec3(0.0);
    float light_paths = float(u_resolution.x) * float(u_resolution.y) * float(u_samples);
    vec3 L = vec3(0.0);
    for (int m = 0; m < cache_connections; ++m) {
        uvec2 picked = cached_light_vertex(uniform_index(cached, rng));
        int s = int(picked.y) + 1;
        if (s + t - 2 > bdpt_depth_limit() || !strategy_kept(s, t)) continue;
        PathVertex y = light_vertex_at(picked.x, int(picked.y));
        PathVertex y_prev = light_vertex_at(picked.x, int(picked.y) - 1);
        Join join = strategy_connect(y, y_prev, z, z_prev);
        if (join.dist > 0.0 && vertex_sees(z, join.dir, join.dist)) L += join.contribution;
    }
    return L * (float(cached) / (float(cache_connections) * light_paths));
}
