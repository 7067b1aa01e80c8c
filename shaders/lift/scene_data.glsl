// lift/scene_data.glsl: the scene as the GPU sees it (written by lift_gl/scene/pack.py).
// All positions are world space. Triangles are stored in BVH leaf order, so a triangle id
// is an index into these arrays, and leaf ranges are contiguous.
#ifndef LIFT_SCENE_DATA_GLSL
#define LIFT_SCENE_DATA_GLSL

#define MAT_DIFFUSE 0
#define MAT_CONDUCTOR 1
#define MAT_DIELECTRIC 2
#define MAT_PLASTIC 3

// Two vec4 per node: (bmin.xyz, first), (bmax.xyz, count); first and count are uint bits.
// count == 0: interior node, children are nodes `first` and `first + 1`.
// count > 0: leaf holding triangles first .. first + count - 1.
layout(std430, binding = 0) readonly buffer BvhNodes { vec4 bvh_nodes[]; };
// Three vec4 per triangle: corner positions (xyz); w unused.
layout(std430, binding = 1) readonly buffer TriPositions { vec4 tri_pos[]; };
// Three vec4 per triangle: corner shading normals (xyz); w unused.
layout(std430, binding = 2) readonly buffer TriNormals { vec4 tri_normal[]; };
// Three vec4 per triangle: corner texture coordinates (xy); zw unused.
layout(std430, binding = 3) readonly buffer TriUVs { vec4 tri_uv[]; };
// One uvec2 per triangle: (material id, uint bits of the probability that light sampling
// picks this triangle; 0 for triangles that do not emit).
layout(std430, binding = 4) readonly buffer TriInfo { uvec2 tri_info[]; };

struct Material {
    vec4 color_type;      // rgb: albedo / F0 / transmission tint / conductor tint; w: MAT_* as float
    vec4 emission_alpha;  // rgb: emitted radiance; w: GGX alpha (0 = smooth)
    vec4 eta_ior;         // rgb: conductor eta (all < 0: use Schlick with F0 = colour); w: dielectric IOR
                          // plastic: x internal diffuse reflectance of the coat, y nonlinear (0/1)
    vec4 k_pad;           // rgb: conductor k / plastic specular tint; w: base colour texture + 1 (0: none)
};
layout(std430, binding = 5) readonly buffer Materials { Material materials[]; };

// One vec4 per emissive primitive, in light-sampling order:
// (uint bits of primitive id, cumulative selection probability up to and including this
// one, selection probability, area). Primitive ids >= u_num_triangles are spheres.
layout(std430, binding = 6) readonly buffer Lights { vec4 lights[]; };

// Two vec4 per sphere: (center.xyz, radius), (uint bits of material id, uint bits of
// light selection probability, 0, 0).
layout(std430, binding = 7) readonly buffer Spheres { vec4 spheres[]; };

#ifdef HAS_MOTION
// Motion blur. The arrays above hold every primitive where it is when the shutter opens,
// and bvh_nodes the node boxes at that moment. `motion` holds, first, one vec4 per
// primitive (triangles in BVH order, then spheres): its displacement (xyz, world space)
// from shutter open to shutter close; then, from row u_num_triangles + u_num_spheres, two
// vec4 per BVH node: its box at shutter close (bmin.xyz), (bmax.xyz). Motion is a
// translation, so normals, areas and light selection probabilities do not change.
layout(std430, binding = 16) readonly buffer Motion { vec4 motion[]; };
#endif

// Counters the host reads back: [0] samples dropped as NaN/Inf, [1] splats dropped as NaN/Inf,
// [2..3] rays traced (LIFT_COUNT_RAYS), [4] pixel-frames whose paths the driver's loop limit
// cut short (lift_gl/passes/trace.py).
layout(std430, binding = 8) buffer Stats { uint stats[]; };

#if defined(HAS_TEXTURES) || defined(HAS_ENVIRONMENT_MAP)
// Textures and the environment map as 32-bit words (lift_gl/scene/images.py has the layout;
// lift/textures.glsl and lift/lights.glsl read it).
layout(std430, binding = 9) readonly buffer Images { uint images[]; };
#endif

uniform uint u_num_triangles;
uniform uint u_num_spheres;
uniform uint u_num_lights;
uniform vec3 u_env_radiance;   // constant environment (HAS_ENVIRONMENT)

#endif
