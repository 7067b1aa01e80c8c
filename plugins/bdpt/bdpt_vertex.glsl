// bdpt_vertex.glsl: the vertices of the two subpaths, and what a vertex can tell about a
// direction through it: the BSDF (as radiance or as importance sees it), its density, and the
// conversion of a direction's density into an area density at the next vertex. Multiple
// importance sampling compares strategies by these area densities (Veach 1997, sec. 10.2).

// Only the light subpath is stored: the camera subpath is joined to it vertex by vertex as it
// is traced (bdpt_subpaths.glsl), keeping just its last two vertices in registers. The light
// subpath lives in a fixed array, so the longest path is a compile-time bound. The host defines
// BDPT_MAX_DEPTH as max_depth (`define` in plugin.toml) and recompiles when it changes: an array
// no longer than the paths keeps an invocation's private memory small (local memory on a GPU,
// the stack on llvmpipe). Longer paths are cut at 64 bounces.
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

// Private to each invocation: the light subpath, y0 first. Stored with its three directions
// in one word each (lift/octahedral.glsl, about 5e-5 rad), 12 words a vertex rather than 18,
// since on a GPU this array is local memory, read by every join. The words are laid out as
// uvec4s by hand: NVIDIA's compiler gives each member of a struct in a local array a 16-byte
// slot of its own (the program binary's `TEMP lmem0[264]` for 33 vertices of 8 members, 4,224
// bytes an invocation), where 3 uvec4s (4 with textures) a vertex take 1,584 (docs/gpu.md).
// BDPT_PACK_NORMALS 0 keeps the directions as floats, in a struct (benchmarks/gpu_pt_variants.py
// times both).
#ifndef BDPT_PACK_NORMALS
#define BDPT_PACK_NORMALS 1
#endif
#if BDPT_PACK_NORMALS
#include "lift/octahedral.glsl"
#ifdef HAS_TEXTURES
#define BDPT_STORED_WORDS 4  // uvec4s a vertex: (p, pdf_fwd), (beta, mis_sum), (ng, ns, wo, tag), tint
#else
#define BDPT_STORED_WORDS 3
#endif

// With BDPT_SHARED_VERTICES n > 0, on GPUs (where the host defines LIFT_BVH_SHARED_STACK to
// the work group's size, one warp) the first n vertices live in shared memory, one column per
// invocation as the BVH stack does (lift/bvh.glsl), and only the rest in the local array: most
// light subpaths are short (3.8 vertices on average on Lift's cornell-box, y0 included). Off by
// default: not yet timed on a GPU (docs/bdpt.md, benchmarks/bdpt_gpu_final.sh times it).
#ifndef BDPT_SHARED_VERTICES
#define BDPT_SHARED_VERTICES 0
#endif
#if !defined(LIFT_BVH_SHARED_STACK) || BDPT_SHARED_VERTICES <= 0
#define BDPT_SHARED_WORDS 0
#elif BDPT_SHARED_VERTICES >= BDPT_LIGHT_VERTICES
#define BDPT_SHARED_WORDS (BDPT_LIGHT_VERTICES * BDPT_STORED_WORDS)
#else
#define BDPT_SHARED_WORDS (BDPT_SHARED_VERTICES * BDPT_STORED_WORDS)
#endif
#define BDPT_LOCAL_WORDS (BDPT_LIGHT_VERTICES * BDPT_STORED_WORDS - BDPT_SHARED_WORDS)
#if BDPT_SHARED_WORDS > 0
shared uvec4 bdpt_light_shared[BDPT_SHARED_WORDS * LIFT_BVH_SHARED_STACK];
#endif
#if BDPT_LOCAL_WORDS > 0
uvec4 bdpt_light[BDPT_LOCAL_WORDS];
#endif

// Word k of the stored subpath (vertex k / BDPT_STORED_WORDS). k is the same in every lane of
// a warp (the joins loop over s in step), so the branch does not diverge. The local index is
// clamped at 0: NVIDIA's compiler rejects a constant index out of bounds even in a branch that
// cannot run (light_vertex(0) inlined: error C1068).
void store_light_word(int k, uvec4 word) {
#if BDPT_SHARED_WORDS > 0
    if (k < BDPT_SHARED_WORDS) {
        bdpt_light_shared[uint(k) * uint(LIFT_BVH_SHARED_STACK) + gl_LocalInvocationIndex] = word;
        return;
    }
#endif
#if BDPT_LOCAL_WORDS > 0
    bdpt_light[max(k - BDPT_SHARED_WORDS, 0)] = word;
#endif
}

uvec4 light_word(int k) {
#if BDPT_SHARED_WORDS > 0
    if (k < BDPT_SHARED_WORDS) return bdpt_light_shared[uint(k) * uint(LIFT_BVH_SHARED_STACK) + gl_LocalInvocationIndex];
#endif
#if BDPT_LOCAL_WORDS > 0
    return bdpt_light[max(k - BDPT_SHARED_WORDS, 0)];
#else
    return uvec4(0u);
#endif
}

void store_light_vertex(int i, PathVertex v) {
    int k = i * BDPT_STORED_WORDS;
    store_light_word(k, floatBitsToUint(vec4(v.p, v.pdf_fwd)));
    store_light_word(k + 1, floatBitsToUint(vec4(v.beta, v.mis_sum)));
    store_light_word(k + 2, uvec4(pack_unit_vector(v.ng), pack_unit_vector(v.ns), pack_unit_vector(v.wo), v.tag));
#ifdef HAS_TEXTURES
    store_light_word(k + 3, floatBitsToUint(vec4(v.tint, 0.0)));
#endif
}

PathVertex light_vertex(int i) {
    int k = i * BDPT_STORED_WORDS;
    vec4 p_pdf = uintBitsToFloat(light_word(k));
    vec4 beta_mis = uintBitsToFloat(light_word(k + 1));
    uvec4 words = light_word(k + 2);
    PathVertex v = path_vertex(p_pdf.xyz, unpack_unit_vector(words.x), unpack_unit_vector(words.y),
                               unpack_unit_vector(words.z), beta_mis.xyz, p_pdf.w, words.w);
    v.mis_sum = beta_mis.w;
#ifdef HAS_TEXTURES
    v.tint = uintBitsToFloat(light_word(k + 3)).xyz;
#endif
    return v;
}
#else
PathVertex bdpt_light[BDPT_LIGHT_VERTICES];
void store_light_vertex(int i, PathVertex v) { bdpt_light[i] = v; }
PathVertex light_vertex(int i) { return bdpt_light[i]; }
#endif

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
// by etap^2 = (n_wi / n_wo)^2: undo it), ...
float adjoint_refraction(Material m, vec3 wo_local, vec3 wi_local) {
    if (bsdf_type(m) != MAT_DIELECTRIC || wo_local.z * wi_local.z >= 0.0) return 1.0;
    float etap = wo_local.z > 0.0 ? m.eta_ior.w : 1.0 / m.eta_ior.w;
    return etap * etap;
}

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
    if (importance) vs.f *= adjoint_refraction(m, wo_local, wi_local) * adjoint_shading_normal(v, v.wo, wi);
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
