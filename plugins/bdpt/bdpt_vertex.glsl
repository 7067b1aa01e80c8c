// bdpt_vertex.glsl: the vertices of the two subpaths, and what a vertex can tell about a
// direction through it: the BSDF (as radiance or as importance sees it), its density, and the
// conversion of a direction's density into an area density at the next vertex. Multiple
// importance sampling compares strategies by these area densities (Veach 1997, sec. 10.2).

// Only the light subpath is stored: the prepass traces it (bdpt_light_pass, bdpt.glsl) into
// the prepass's storage (lift/prepass.glsl: global buffers, entry-major, so that a warp's lanes
// read each entry side by side), and the trace pass's camera subpath is joined to it vertex by
// vertex as it is traced (bdpt_subpaths.glsl), keeping just its last two vertices in registers.
// The host defines BDPT_MAX_DEPTH as max_depth (`define` in plugin.toml); the storage, sized by
// the manifest's `entries`, holds paths of up to 64 bounces: longer ones are cut there.
#ifndef BDPT_MAX_DEPTH
#define BDPT_MAX_DEPTH 64
#elif BDPT_MAX_DEPTH > 64
#undef BDPT_MAX_DEPTH
#define BDPT_MAX_DEPTH 64
#endif
#define BDPT_LIGHT_VERTICES (BDPT_MAX_DEPTH + 1)    // y0 (on a light) .. y_d

const uint VERTEX_CAMERA = 0u;   // the pinhole
const uint VERTEX_SURFACE = 1u;  // a scattering point on either subpath
const uint VERTEX_EMITTER = 2u;  // y0 on an emitter's surface
const uint VERTEX_ENV = 3u;      // at infinity: the environment
const uint VERTEX_DISTANT = 4u;  // at infinity: a distant light (y0 only; a delta in direction)

struct PathVertex {
    vec3 p;             // world position; at infinity: the unit direction towards the light
    vec3 ng;            // geometric normal (triangle winding, sphere outward); emitter: front normal
    vec3 ns;            // shading normal: shading_normal (lift/surface.glsl), as pt shades
    vec3 wo;            // unit direction towards the previous vertex of the same subpath
    vec3 beta;          // throughput of the subpath up to this vertex, this vertex's BSDF excluded
    float pdf_fwd;      // area density of this vertex, sampled from the previous one
    float mis_sum;      // the MIS ratios of the vertices before the previous one (bdpt_mis.glsl)
    uint tag;           // material << 4 | kind (VERTEX_*) << 1 | delta: one word, not three
#ifdef HAS_TEXTURES
    vec3 tint;          // what the texture multiplies the base colour by (texture_tint), looked up
                        // once when the vertex is made rather than at every join
#endif
};

// A vertex's tag; `delta` (scattered by a delta lobe: mirror, smooth glass; cannot be joined)
// is set when the vertex's BSDF is sampled.
uint vertex_tag(uint material, uint kind) { return material << 4u | kind << 1u; }

PathVertex path_vertex(vec3 p, vec3 ng, vec3 ns, vec3 wo, vec3 beta, float pdf_fwd, uint tag) {
    PathVertex v;
    v.p = p;
    v.ng = ng;
    v.ns = ns;
    v.wo = wo;
    v.beta = beta;
    v.pdf_fwd = pdf_fwd;
    v.mis_sum = 0.0;
    v.tag = tag;
#ifdef HAS_TEXTURES
    v.tint = vec3(1.0);
#endif
    return v;
}

// The stored light subpath of this pixel sample, y0 first. Entry 0 holds the random numbers
// as the light subpath left them (the camera subpath goes on with them: the numbers of one
// sample are one stream, as when both subpaths were traced in one pass), entry 1 the number
// of light vertices, then vertex i in BDPT_STORED_WORDS entries from 2 + i * BDPT_STORED_WORDS,
// its three directions in one word each (lift/octahedral.glsl, about 5e-5 rad): 3 uvec4s a
// vertex, 4 with textures. plugin.toml's `entries` is the room for 65 vertices of 4 words.
#include "lift/octahedral.glsl"
#ifdef HAS_TEXTURES
#define BDPT_STORED_WORDS 4  // uvec4s a vertex: (p, pdf_fwd), (beta, mis_sum), (ng, ns, wo, tag), tint
#else
#define BDPT_STORED_WORDS 3
#endif
const int BDPT_RNG_ENTRY = 0;
const int BDPT_COUNT_ENTRY = 1;
const int BDPT_FIRST_VERTEX_ENTRY = 2;

void store_light_subpath_end(int light_vertices, Rng rng) {
    prepass_store(BDPT_RNG_ENTRY, uvec4(rng.state, rng.sample_index, rng.ld_seed, rng.ld_pair));
    prepass_store(BDPT_COUNT_ENTRY, uvec4(uint(light_vertices), 0u, 0u, 0u));
}

int stored_light_vertices() { return int(prepass_load(BDPT_COUNT_ENTRY).x); }

Rng stored_light_rng() {
    uvec4 words = prepass_load(BDPT_RNG_ENTRY);
    return Rng(words.x, words.y, words.z, words.w);
}

void store_light_vertex(int i, PathVertex v) {
    int k = BDPT_FIRST_VERTEX_ENTRY + i * BDPT_STORED_WORDS;
    prepass_store(k, floatBitsToUint(vec4(v.p, v.pdf_fwd)));
    prepass_store(k + 1, floatBitsToUint(vec4(v.beta, v.mis_sum)));
    prepass_store(k + 2, uvec4(pack_unit_vector(v.ng), pack_unit_vector(v.ns), pack_unit_vector(v.wo), v.tag));
#ifdef HAS_TEXTURES
    prepass_store(k + 3, floatBitsToUint(vec4(v.tint, 0.0)));
#endif
}

PathVertex light_vertex(int i) {
    int k = BDPT_FIRST_VERTEX_ENTRY + i * BDPT_STORED_WORDS;
    vec4 p_pdf = uintBitsToFloat(prepass_load(k));
    vec4 beta_mis = uintBitsToFloat(prepass_load(k + 1));
    uvec4 words = prepass_load(k + 2);
    PathVertex v = path_vertex(p_pdf.xyz, unpack_unit_vector(words.x), unpack_unit_vector(words.y),
                               unpack_unit_vector(words.z), beta_mis.xyz, p_pdf.w, words.w);
    v.mis_sum = beta_mis.w;
#ifdef HAS_TEXTURES
    v.tint = uintBitsToFloat(prepass_load(k + 3)).xyz;
#endif
    return v;
}

uint vertex_kind(PathVertex v) { return v.tag >> 1u & 7u; }
uint vertex_material(PathVertex v) { return v.tag >> 4u; }
bool vertex_delta(PathVertex v) { return (v.tag & 1u) != 0u; }

// The material that scatters at surface vertex v: its texture applied, as pt shades it.
Material vertex_bsdf_material(PathVertex v) {
#ifdef HAS_TEXTURES
    return material_tinted(vertex_material(v), v.tint);
#else
    return materials[vertex_material(v)];
#endif
}

bool vertex_on_surface(PathVertex v) {
    return vertex_kind(v) == VERTEX_SURFACE || vertex_kind(v) == VERTEX_EMITTER;
}

// Whether another vertex can be joined to vertex v with a shadow ray.
bool vertex_connectible(PathVertex v) {
    return vertex_kind(v) == VERTEX_SURFACE && !vertex_delta(v);
}

bool vertex_at_infinity(PathVertex v) {
    return vertex_kind(v) == VERTEX_ENV || vertex_kind(v) == VERTEX_DISTANT;
}

// A solid-angle density at point `from`, towards vertex v, as an area density at v.
// Directions to lights at infinity keep their solid-angle density (pbrt does the same).
float area_density(float pdf_dir, vec3 from, PathVertex v) {
    if (vertex_at_infinity(v)) return pdf_dir;
    vec3 d = v.p - from;
    float dist2 = dot(d, d);
    if (!(dist2 > 0.0)) return 0.0;
    float cos_v = vertex_on_surface(v) ? abs(dot(v.ng, d)) * inversesqrt(dist2) : 1.0;
    return pdf_dir * cos_v / dist2;
}

// Opaque surfaces (m: vertex v's material) pass no light from one side of their geometry to
// the other, whatever the shading normal says.
bool vertex_blocks(Material m, PathVertex v, vec3 wo, vec3 wi) {
    return is_opaque(m) && dot(wi, v.ng) * dot(wo, v.ng) <= 0.0;
}

// Light subpaths carry importance, whose BSDF is the adjoint of radiance's. Two differences:
// refraction compresses radiance by eta^2 but not importance (bsdf.glsl divides transmission
// by etap^2 = (n_wi / n_wo)^2: times refraction_eta2 undoes it), ...

// ... and shading normals make the BSDF non-symmetric: importance is carried with the factor
// |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|) (Veach 1997, sec. 5.3). 1 where ns = ng.
float adjoint_shading_normal(PathVertex v, vec3 wo, vec3 wi) {
    float denominator = abs(dot(wo, v.ng)) * abs(dot(wi, v.ns));
    return denominator > 0.0 ? abs(dot(wo, v.ns)) * abs(dot(wi, v.ng)) / denominator : 0.0;
}

// What a join needs of surface vertex v for world directions wo (towards the previous vertex
// of its own subpath) and wi (towards the vertex it is joined to): the BSDF, and the two
// densities MIS compares. One frame and one material fetch serve all three.
struct VertexScatter {
    vec3 f;         // f(wo, wi) |cos(wi, ns)|; `importance`: the adjoint, for light subpaths
    float pdf_out;  // solid-angle density of bsdf_sample at v picking wi, coming from wo
    float pdf_back; // ... picking wo, coming from wi (the subpath walked the other way)
};

VertexScatter vertex_scatter(PathVertex v, vec3 wi, bool importance) {
    VertexScatter vs = VertexScatter(vec3(0.0), 0.0, 0.0);
    Material m = vertex_bsdf_material(v);
    if (vertex_blocks(m, v, v.wo, wi)) return vs;
    Frame frame = frame_from_normal(v.ns);
    vec3 wo_local = to_local(frame, v.wo), wi_local = to_local(frame, wi);
    vs.f = bsdf_eval_pdf(m, wo_local, wi_local, vs.pdf_out);
    if (importance) vs.f *= refraction_eta2(m, wo_local, wi_local) * adjoint_shading_normal(v, v.wo, wi);
    vs.pdf_back = bsdf_pdf(m, wi_local, wo_local);
    return vs;
}

// Whether nothing lies between vertex v and the point at distance dist along dir (1e30: the
// environment). The ray starts offset off the surface on dir's side, aims from there at the
// end point and stops just short of it (see spawn_shadow_ray in lift/surface.glsl).
bool vertex_sees(PathVertex v, vec3 dir, float dist) {
    vec3 n = dot(dir, v.ng) >= 0.0 ? v.ng : -v.ng;
    Ray r = Ray(offset_ray_origin(v.p, n), dir, 0.0, 1e30);
    if (dist < 1e30) {
        vec3 to_end = v.p + dir * dist - r.origin;
        float len = length(to_end);
        if (len > 0.0) r.dir = to_end / len;
        r.tmax = len * (1.0 - 1e-4);
    }
    return !trace_occluded(r);
}
