// lift/scene_data.glsl: the scene as the GPU sees it (written by lift_gl/scene/pack.py).
// All positions are world space. Triangles are stored in BVH leaf order, so a triangle id
// is an index into these arrays, and leaf ranges are contiguous.
// On a CPU rasterizer the host may hand any of the arrays below in a uniform block instead
// (LIFT_UBO_<ARRAY> defined to its length; lift_gl/passes/common.py): Mesa's llvmpipe loads a
// storage buffer one SIMD lane at a time, with a branch per lane and word, but gathers from a
// uniform block. Same names, same data (std140 rounds uvec2 array elements up to 16 bytes),
// so the code that reads them is the same.
#ifndef LIFT_SCENE_DATA_GLSL
#define LIFT_SCENE_DATA_GLSL

// Material types (Material.color_type.w, bsdf_type).
#define MAT_DIFFUSE 0     // Lambert
#define MAT_CONDUCTOR 1   // metal: a mirror, or rough (GGX or Beckmann)
#define MAT_DIELECTRIC 2  // glass: smooth or rough (GGX)
#define MAT_PLASTIC 3     // a diffuse base under a dielectric coat

// Two vec4 per node: (bmin.xyz, first), (bmax.xyz, count); first and count are uint bits.
// count == 0: interior node, children are nodes `first` and `first + 1`.
// count > 0: leaf holding triangles first .. first + count - 1.
// Three vec4 per triangle in tri_pos (corner positions, xyz), tri_normal (corner shading
// normals, xyz) and tri_uv (corner texture coordinates, xy); one uvec2 per triangle in
// tri_info: (material id, uint bits of the probability that light sampling picks this
// triangle; 0 for triangles that do not emit).
// Read them through the accessors below (bvh_node_row, tri_pos_row, tri_normal_row,
// tri_uv_row, tri_info_at), never the arrays: a scene too big for one buffer a kind keeps
// them all in a heap of several buffers (LIFT_SPLIT_SCENE, lift_gl/scene/split.py).
#ifndef LIFT_SPLIT_SCENE
#ifdef LIFT_UBO_BVH_NODES
layout(std140, binding = LIFT_BINDING_BVH_NODES) uniform BvhNodes { vec4 bvh_nodes[LIFT_UBO_BVH_NODES]; };
#else
layout(std430, binding = LIFT_BINDING_BVH_NODES) readonly buffer BvhNodes { vec4 bvh_nodes[]; };
#endif
// Three vec4 per triangle: corner positions (xyz); w unused.
#ifdef LIFT_UBO_TRI_POS
layout(std140, binding = LIFT_BINDING_TRI_POS) uniform TriPositions { vec4 tri_pos[LIFT_UBO_TRI_POS]; };
#else
layout(std430, binding = LIFT_BINDING_TRI_POS) readonly buffer TriPositions { vec4 tri_pos[]; };
#endif
// Three vec4 per triangle: corner shading normals (xyz); w unused.
#ifdef LIFT_UBO_TRI_NORMAL
layout(std140, binding = LIFT_BINDING_TRI_NORMAL) uniform TriNormals { vec4 tri_normal[LIFT_UBO_TRI_NORMAL]; };
#else
layout(std430, binding = LIFT_BINDING_TRI_NORMAL) readonly buffer TriNormals { vec4 tri_normal[]; };
#endif
// Three vec4 per triangle: corner texture coordinates (xy); zw unused.
#ifdef LIFT_UBO_TRI_UV
layout(std140, binding = LIFT_BINDING_TRI_UV) uniform TriUVs { vec4 tri_uv[LIFT_UBO_TRI_UV]; };
#else
layout(std430, binding = LIFT_BINDING_TRI_UV) readonly buffer TriUVs { vec4 tri_uv[]; };
#endif
// One uvec2 per triangle: (material id, uint bits of the probability that light sampling
// picks this triangle; 0 for triangles that do not emit).
#ifdef LIFT_UBO_TRI_INFO
layout(std140, binding = LIFT_BINDING_TRI_INFO) uniform TriInfo { uvec2 tri_info[LIFT_UBO_TRI_INFO]; };
#else
layout(std430, binding = LIFT_BINDING_TRI_INFO) readonly buffer TriInfo { uvec2 tri_info[]; };
#endif
// Row r of each array (see above), wherever the host put it.
vec4 bvh_node_row(uint r) { return bvh_nodes[r]; }
vec4 tri_pos_row(uint r) { return tri_pos[r]; }
vec4 tri_normal_row(uint r) { return tri_normal[r]; }
vec4 tri_uv_row(uint r) { return tri_uv[r]; }
uvec2 tri_info_at(uint t) { return tri_info[t]; }
#else
// The heap: vec4 rows, LIFT_HEAP_CHUNKS buffers of 2^LIFT_HEAP_SHIFT rows from LIFT_BINDING_HEAP0 on
// (lift_gl/scene/split.py HEAP_FIRST_BINDING); each array starts at the row in its uniform.
layout(std430, binding = LIFT_BINDING_HEAP0) readonly buffer Heap0 { vec4 heap0[]; };
#if LIFT_HEAP_CHUNKS > 1
layout(std430, binding = LIFT_BINDING_HEAP1) readonly buffer Heap1 { vec4 heap1[]; };
#endif
#if LIFT_HEAP_CHUNKS > 2
layout(std430, binding = LIFT_BINDING_HEAP2) readonly buffer Heap2 { vec4 heap2[]; };
#endif
#if LIFT_HEAP_CHUNKS > 3
layout(std430, binding = LIFT_BINDING_HEAP3) readonly buffer Heap3 { vec4 heap3[]; };
#endif
#if LIFT_HEAP_CHUNKS > 4
layout(std430, binding = LIFT_BINDING_HEAP4) readonly buffer Heap4 { vec4 heap4[]; };
#endif
#if LIFT_HEAP_CHUNKS > 5
layout(std430, binding = LIFT_BINDING_HEAP5) readonly buffer Heap5 { vec4 heap5[]; };
#endif
#if LIFT_HEAP_CHUNKS > 6
layout(std430, binding = LIFT_BINDING_HEAP6) readonly buffer Heap6 { vec4 heap6[]; };
#endif
#if LIFT_HEAP_CHUNKS > 7
layout(std430, binding = LIFT_BINDING_HEAP7) readonly buffer Heap7 { vec4 heap7[]; };
#endif
uniform uint u_heap_nodes;
uniform uint u_heap_pos;
uniform uint u_heap_normal;
uniform uint u_heap_uv;
uniform uint u_heap_info;
// Separate blocks, not an array of blocks: indexing one with a non-uniform index is not
// allowed in GLSL 4.30, and rays of one work group read different chunks. lo and hi are the
// first and last chunk the array spans, compile-time constants: the tests of chunks outside
// them fold away, and an array in one chunk is a single load.
vec4 heap_row(uint r, const uint lo, const uint hi) {
    uint i = r & ((1u << LIFT_HEAP_SHIFT) - 1u);
    uint c = r >> LIFT_HEAP_SHIFT;
    if (0u >= lo && 0u < hi && c == 0u) return heap0[i];
#if LIFT_HEAP_CHUNKS > 1
    if (1u >= lo && 1u < hi && c == 1u) return heap1[i];
#endif
#if LIFT_HEAP_CHUNKS > 2
    if (2u >= lo && 2u < hi && c == 2u) return heap2[i];
#endif
#if LIFT_HEAP_CHUNKS > 3
    if (3u >= lo && 3u < hi && c == 3u) return heap3[i];
#endif
#if LIFT_HEAP_CHUNKS > 4
    if (4u >= lo && 4u < hi && c == 4u) return heap4[i];
#endif
#if LIFT_HEAP_CHUNKS > 5
    if (5u >= lo && 5u < hi && c == 5u) return heap5[i];
#endif
#if LIFT_HEAP_CHUNKS > 6
    if (6u >= lo && 6u < hi && c == 6u) return heap6[i];
#endif
    // the span's last chunk: no test of c
    if (hi == 0u) return heap0[i];
#if LIFT_HEAP_CHUNKS > 1
    if (hi == 1u) return heap1[i];
#endif
#if LIFT_HEAP_CHUNKS > 2
    if (hi == 2u) return heap2[i];
#endif
#if LIFT_HEAP_CHUNKS > 3
    if (hi == 3u) return heap3[i];
#endif
#if LIFT_HEAP_CHUNKS > 4
    if (hi == 4u) return heap4[i];
#endif
#if LIFT_HEAP_CHUNKS > 5
    if (hi == 5u) return heap5[i];
#endif
#if LIFT_HEAP_CHUNKS > 6
    if (hi == 6u) return heap6[i];
#endif
#if LIFT_HEAP_CHUNKS > 7
    if (hi == 7u) return heap7[i];
#endif
    return vec4(0.0);
}
vec4 bvh_node_row(uint r) { return heap_row(u_heap_nodes + r, LIFT_HEAP_NODES_LO, LIFT_HEAP_NODES_HI); }
vec4 tri_pos_row(uint r) { return heap_row(u_heap_pos + r, LIFT_HEAP_POS_LO, LIFT_HEAP_POS_HI); }
vec4 tri_normal_row(uint r) { return heap_row(u_heap_normal + r, LIFT_HEAP_NORMAL_LO, LIFT_HEAP_NORMAL_HI); }
vec4 tri_uv_row(uint r) { return heap_row(u_heap_uv + r, LIFT_HEAP_UV_LO, LIFT_HEAP_UV_HI); }
uvec2 tri_info_at(uint t) {
    vec4 row = heap_row(u_heap_info + (t >> 1u), LIFT_HEAP_INFO_LO, LIFT_HEAP_INFO_HI);
    return floatBitsToUint((t & 1u) == 0u ? row.xy : row.zw);
}
#endif

// A material as the BSDFs read it (lift/bsdf.glsl's header says which field means what for
// each type): four vec4, packed by lift_gl/scene/pack.py. Read it with material_at(id, uv),
// which applies the material's texture; materials[id] is the untextured one.
struct Material {
    vec4 color_type;      // rgb: albedo / F0 / transmission tint / conductor tint; w: MAT_* as float
    vec4 emission_alpha;  // rgb: emitted radiance; w: GGX alpha (0 = smooth)
    vec4 eta_ior;         // rgb: conductor eta (all < 0: use Schlick with F0 = colour); w: dielectric IOR
                          // plastic: x internal diffuse reflectance of the coat, y nonlinear (0/1)
    vec4 k_pad;           // rgb: conductor k / plastic specular tint; w: base colour texture + 1 (0: none)
};
#ifdef LIFT_UBO_MATERIALS
layout(std140, binding = LIFT_BINDING_MATERIALS) uniform Materials { Material materials[LIFT_UBO_MATERIALS]; };
#else
layout(std430, binding = LIFT_BINDING_MATERIALS) readonly buffer Materials { Material materials[]; };
#endif

// One vec4 per emissive primitive, in light-sampling order:
// (uint bits of primitive id, cumulative selection probability up to and including this
// one, selection probability, area). Primitive ids >= u_num_triangles are spheres.
#ifdef LIFT_UBO_LIGHTS
layout(std140, binding = LIFT_BINDING_LIGHTS) uniform Lights { vec4 lights[LIFT_UBO_LIGHTS]; };
#else
layout(std430, binding = LIFT_BINDING_LIGHTS) readonly buffer Lights { vec4 lights[]; };
#endif

// Two vec4 per sphere: (center.xyz, radius), (uint bits of material id, uint bits of
// light selection probability, 0, 0).
#ifdef LIFT_UBO_SPHERES
layout(std140, binding = LIFT_BINDING_SPHERES) uniform Spheres { vec4 spheres[LIFT_UBO_SPHERES]; };
#else
layout(std430, binding = LIFT_BINDING_SPHERES) readonly buffer Spheres { vec4 spheres[]; };
#endif

#ifdef HAS_INSTANCES
// Instances (lift_gl/scene/instances.py): meshes placed by transforms. Rows 0 ..
// u_instance_records - 1 hold the TLAS, the tree over the instances' world boxes, two rows a
// node as bvh_nodes (a leaf holds instance records first .. first + count - 1); then
// INSTANCE_ROWS rows per instance record: rows 0-2 the object -> world transform and rows 3-5
// the world -> object transform (rows of 3x4 matrices), row 6 uint bits (root node of the
// instance's BLAS in bvh_nodes, material or NO_MATERIAL for the mesh's own, prototype,
// 1 if the transform mirrors (negative determinant), else 0).
// Each BLAS's nodes and object-space triangles follow the world geometry's in bvh_nodes and
// the triangle arrays; the world BVH (node 0) holds triangles 0 .. u_world_triangles - 1.
#ifdef LIFT_UBO_INSTANCES
layout(std140, binding = LIFT_BINDING_INSTANCES) uniform Instances { vec4 instances[LIFT_UBO_INSTANCES]; };
#else
layout(std430, binding = LIFT_BINDING_INSTANCES) readonly buffer Instances { vec4 instances[]; };
#endif
#define INSTANCE_ROWS 7u            // rows of one instance record
#define NO_INSTANCE 0xffffffffu     // Hit.instance, Surface.instance of world geometry
#define NO_MATERIAL 0xffffffffu     // an instance that keeps its mesh's materials
uniform uint u_world_triangles;
uniform uint u_num_instances;
uniform uint u_instance_records;   // row of the first instance record

// Row r of instance record k.
vec4 instance_row(uint k, uint r) { return instances[u_instance_records + INSTANCE_ROWS * k + r]; }
// Object -> world of a point, and of a direction.
vec3 instance_point_to_world(uint k, vec3 p) {
    vec4 p1 = vec4(p, 1.0);
    return vec3(dot(instance_row(k, 0u), p1), dot(instance_row(k, 1u), p1), dot(instance_row(k, 2u), p1));
}
// World -> object of a point, and of a direction (not renormalised).
vec3 instance_point_to_object(uint k, vec3 p) {
    vec4 p1 = vec4(p, 1.0);
    return vec3(dot(instance_row(k, 3u), p1), dot(instance_row(k, 4u), p1), dot(instance_row(k, 5u), p1));
}
vec3 instance_dir_to_object(uint k, vec3 d) {
    return vec3(dot(instance_row(k, 3u).xyz, d), dot(instance_row(k, 4u).xyz, d), dot(instance_row(k, 5u).xyz, d));
}
// A normal to world space: the inverse transpose of object -> world, i.e. the transpose of
// world -> object (not normalised).
vec3 instance_normal_to_world(uint k, vec3 n) {
    return n.x * instance_row(k, 3u).xyz + n.y * instance_row(k, 4u).xyz + n.z * instance_row(k, 5u).xyz;
}
// Row 6 of instance record k: (BLAS root, material or NO_MATERIAL, prototype, mirrors).
uvec4 instance_info(uint k) { return floatBitsToUint(instance_row(k, 6u)); }
// The material of instanced triangle `tri` in instance k: the instance's, else the mesh's.
uint instance_material(uint k, uint tri) {
    uint m = instance_info(k).y;
    return m != NO_MATERIAL ? m : tri_info_at(tri).x;
}
#endif

#ifdef HAS_MOTION
// Motion blur. The arrays above hold every primitive where it is when the shutter opens,
// and bvh_nodes the node boxes at that moment. `motion` holds, first, one vec4 per
// primitive (triangles in BVH order, then spheres): its displacement (xyz, world space)
// from shutter open to shutter close; then, from row u_num_triangles + u_num_spheres, two
// vec4 per BVH node: its box at shutter close (bmin.xyz), (bmax.xyz). Motion is a
// translation, so normals, areas and light selection probabilities do not change.
layout(std430, binding = LIFT_BINDING_MOTION) readonly buffer Motion { vec4 motion[]; };
#endif

// Counters the host reads back: [0] samples dropped as NaN/Inf, [1] splats dropped as NaN/Inf,
// [2..3] rays traced (LIFT_COUNT_RAYS), [4] pixel-frames whose paths the driver's loop limit
// cut short (lift_gl/passes/trace.py).
layout(std430, binding = LIFT_BINDING_STATS) buffer Stats { uint stats[]; };

#if defined(HAS_TEXTURES) || defined(HAS_ENVIRONMENT_MAP)
// Textures and the environment map as 32-bit words (lift_gl/scene/images.py has the layout;
// lift/textures.glsl and lift/lights.glsl read it).
layout(std430, binding = LIFT_BINDING_IMAGES) readonly buffer Images { uint images[]; };
#endif
#ifdef HAS_ENVIRONMENT_MAP
// The same buffer read 16 bytes at a time: the environment map's RGBA float texels.
layout(std430, binding = LIFT_BINDING_IMAGES) readonly buffer Images4 { uvec4 images4[]; };
#endif

// The G-buffer visibility texel's material, and its instance record (NO_INSTANCE: world
// geometry): with instances w holds the material in 16 bits and the instance + 1 above.
#ifdef HAS_INSTANCES
uint visibility_material(uvec4 v) { return v.w & 0xffffu; }
uint visibility_instance(uvec4 v) { return (v.w >> 16u) - 1u; }
#else
uint visibility_material(uvec4 v) { return v.w; }
#endif

uniform uint u_num_triangles;
uniform uint u_num_spheres;
uniform uint u_num_lights;
uniform vec3 u_env_radiance;   // constant environment (HAS_ENVIRONMENT)

#endif
