// bdpt_vertex.glsl: the vertices of the two subpaths, and what a vertex can tell about a
// direction through it: the BSDF (as radiance or as importance sees it), its density, and the
// conversion of a direction's density into an area density at the next vertex. Multiple
// importance sampling compares strategies by these area densities (Veach 1997, sec. 10.2).

// Subpaths live in fixed arrays, so the longest path is a compile-time bound. The host defines
// BDPT_MAX_DEPTH as max_depth (`define` in plugin.toml) and recompiles when it changes: arrays
// no longer than the paths keep an invocation's private memory small (scratch memory on a GPU,
// the stack on llvmpipe). Longer paths are cut at 64 bounces.
#ifndef BDPT_MAX_DEPTH
#define BDPT_MAX_DEPTH 64
#elif BDPT_MAX_DEPTH > 64
#undef BDPT_MAX_DEPTH
#define BDPT_MAX_DEPTH 64
#endif
#define BDPT_CAMERA_VERTICES (BDPT_MAX_DEPTH + 2)   // z0 (the pinhole) .. z_{d+1}
#define BDPT_LIGHT_VERTICES (BDPT_MAX_DEPTH + 1)    // y0 (on a light) .. y_d
#define BDPT_LIGHT_BASE BDPT_CAMERA_VERTICES        // light vertex i is bdpt_path[BDPT_LIGHT_BASE + i]

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
    float pdf_rev;      // area density of this vertex, were it sampled from the next one instead
    float emitter_pdf;  // density of sample_light_point choosing this point (0: not an emitter)
    uint tag;           // material << 4 | kind (VERTEX_*) << 1 | delta: one word, not three
};

// A vertex's tag; `delta` (scattered by a delta lobe: mirror, smooth glass; cannot be joined)
// is set later, when the vertex's BSDF is sampled.
uint vertex_tag(uint material, uint kind) { return material << 4u | kind << 1u; }

// Private to each invocation: camera subpath first, then the light subpath.
PathVertex bdpt_path[BDPT_CAMERA_VERTICES + BDPT_LIGHT_VERTICES];
#ifdef HAS_TEXTURES
// What the texture multiplies each surface vertex's base colour by (texture_tint), looked up
// once when the vertex is made rather than at every join. Beside bdpt_path rather than in it:
// only scenes with image textures carry it.
vec3 bdpt_tint[BDPT_CAMERA_VERTICES + BDPT_LIGHT_VERTICES];
#endif

uint vertex_kind(int i) { return bdpt_path[i].tag >> 1u & 7u; }
uint vertex_material(int i) { return bdpt_path[i].tag >> 4u; }
bool vertex_delta(int i) { return (bdpt_path[i].tag & 1u) != 0u; }

// The material that scatters at surface vertex i: its texture applied, as pt shades it.
Material vertex_bsdf_material(int i) {
#ifdef HAS_TEXTURES
    return material_tinted(vertex_material(i), bdpt_tint[i]);
#else
    return materials[vertex_material(i)];
#endif
}

bool vertex_on_surface(int i) {
    return vertex_kind(i) == VERTEX_SURFACE || vertex_kind(i) == VERTEX_EMITTER;
}

// Whether another vertex can be joined to vertex i with a shadow ray.
bool vertex_connectible(int i) {
    return vertex_kind(i) == VERTEX_SURFACE && !vertex_delta(i);
}

bool vertex_at_infinity(int i) {
    return vertex_kind(i) == VERTEX_ENV || vertex_kind(i) == VERTEX_DISTANT;
}

// A solid-angle density at point `from`, towards vertex i, as an area density at vertex i.
// Directions to lights at infinity keep their solid-angle density (pbrt does the same).
float area_density(float pdf_dir, vec3 from, int i) {
    if (vertex_at_infinity(i)) return pdf_dir;
    vec3 d = bdpt_path[i].p - from;
    float dist2 = dot(d, d);
    if (!(dist2 > 0.0)) return 0.0;
    float cos_i = vertex_on_surface(i) ? abs(dot(bdpt_path[i].ng, d)) * inversesqrt(dist2) : 1.0;
    return pdf_dir * cos_i / dist2;
}

// Opaque surfaces (m: vertex i's material) pass no light from one side of their geometry to
// the other, whatever the shading normal says.
bool vertex_blocks(Material m, int i, vec3 wo, vec3 wi) {
    return is_opaque(m) && dot(wi, bdpt_path[i].ng) * dot(wo, bdpt_path[i].ng) <= 0.0;
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
float adjoint_shading_normal(int i, vec3 wo, vec3 wi) {
    vec3 ns = bdpt_path[i].ns, ng = bdpt_path[i].ng;
    float denominator = abs(dot(wo, ng)) * abs(dot(wi, ns));
    return denominator > 0.0 ? abs(dot(wo, ns)) * abs(dot(wi, ng)) / denominator : 0.0;
}

// What a join needs of surface vertex i for world directions wo (towards the previous vertex
// of its own subpath) and wi (towards the vertex it is joined to): the BSDF, and the two
// densities MIS compares. One frame and one material fetch serve all three.
struct VertexScatter {
    vec3 f;         // f(wo, wi) |cos(wi, ns)|; `importance`: the adjoint, for light subpaths
    float pdf_out;  // solid-angle density of bsdf_sample at i picking wi, coming from wo
    float pdf_back; // ... picking wo, coming from wi (the subpath walked the other way)
};

VertexScatter vertex_scatter(int i, vec3 wo, vec3 wi, bool importance) {
    VertexScatter v = VertexScatter(vec3(0.0), 0.0, 0.0);
    Material m = vertex_bsdf_material(i);
    if (vertex_blocks(m, i, wo, wi)) return v;
    Frame frame = frame_from_normal(bdpt_path[i].ns);
    vec3 wo_local = to_local(frame, wo), wi_local = to_local(frame, wi);
    v.f = bsdf_eval(m, wo_local, wi_local);
    if (importance) v.f *= adjoint_refraction(m, wo_local, wi_local) * adjoint_shading_normal(i, wo, wi);
    v.pdf_out = bsdf_pdf(m, wo_local, wi_local);
    v.pdf_back = bsdf_pdf(m, wi_local, wo_local);
    return v;
}

// Whether nothing lies between vertex i and the point at distance dist along dir (1e30: the
// environment). The ray starts offset off the surface on dir's side, aims from there at the
// end point and stops just short of it (see spawn_shadow_ray in lift/surface.glsl).
bool vertex_sees(int i, vec3 dir, float dist) {
    vec3 p = bdpt_path[i].p;
    vec3 n = dot(dir, bdpt_path[i].ng) >= 0.0 ? bdpt_path[i].ng : -bdpt_path[i].ng;
    Ray r = Ray(offset_ray_origin(p, n), dir, 0.0, 1e30);
    if (dist < 1e30) {
        vec3 to_end = p + dir * dist - r.origin;
        float len = length(to_end);
        if (len > 0.0) r.dir = to_end / len;
        r.tmax = len * (1.0 - 1e-4);
    }
    return !trace_occluded(r);
}
