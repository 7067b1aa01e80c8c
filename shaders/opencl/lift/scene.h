// lift/scene.h: the scene as an OpenCL plugin sees it: the same arrays the GLSL passes read
// (lift_gl/scene/pack.py; layouts in shaders/lift/scene_data.glsl), passed as buffers.
// All positions are world space; a triangle id indexes the arrays in BVH leaf order.
#ifndef LIFT_CL_SCENE_H
#define LIFT_CL_SCENE_H

#define MAT_DIFFUSE 0
#define MAT_CONDUCTOR 1
#define MAT_DIELECTRIC 2

typedef struct {
    float4 color_type;      // rgb: albedo / F0 / transmission tint; w: MAT_* as float
    float4 emission_alpha;  // rgb: emitted radiance; w: GGX alpha (0 = smooth)
    float4 eta_ior;         // rgb: conductor eta (all < 0: Schlick with F0 = colour); w: dielectric IOR
    float4 k_pad;           // rgb: conductor k
} Material;

typedef struct {
    __global const float4* bvh_nodes;    // 2 per node: (bmin, first bits), (bmax, count bits)
    __global const float4* tri_pos;      // 3 per triangle: corner positions
    __global const float4* tri_normal;   // 3 per triangle: corner shading normals
    __global const float4* tri_uv;       // 3 per triangle: corner texture coordinates (xy)
    __global const uint2* tri_info;      // per triangle: material id, light selection pdf bits
    __global const Material* materials;
    __global const float4* lights;       // per emitter: prim bits, cdf, selection pdf, area
    __global const float4* spheres;      // 2 per sphere: (centre, radius), (material bits, pdf bits, 0, 0)
    uint num_triangles;
    uint num_spheres;
    uint num_lights;
    float3 env_radiance;                 // constant environment (HAS_ENVIRONMENT)
} Scene;

#endif
