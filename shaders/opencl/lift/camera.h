// lift/camera.h: the perspective thin-lens camera of shaders/lift/camera.glsl. Pixel
// positions are in pixels, y up, (0, 0) = the bottom-left corner.
#ifndef LIFT_CL_CAMERA_H
#define LIFT_CL_CAMERA_H
#include "lift/bvh.h"
#include "lift/sampling.h"

typedef struct {
    float3 position;
    float3 right, up, forward;  // unit vectors, world space
    float tan_half_fov;         // tan(vertical fov / 2)
    float2 resolution;          // width, height in pixels
    float lens_radius;          // 0: pinhole
    float focus_distance;
} Camera;

// Direction (unnormalized, forward component 1) through a pixel position.
float3 camera_direction(const Camera* cam, float2 pixel_pos) {
    float2 ndc = pixel_pos / cam->resolution * 2.0f - 1.0f;
    float aspect = cam->resolution.x / cam->resolution.y;
    return cam->forward + ndc.x * cam->tan_half_fov * aspect * cam->right + ndc.y * cam->tan_half_fov * cam->up;
}

// A pinhole ray (the one the raster G-buffer agrees with).
Ray camera_ray(const Camera* cam, float2 pixel_pos) {
    return make_ray(cam->position, normalize(camera_direction(cam, pixel_pos)), 0.0f, 1e30f);
}

// A thin-lens ray through the point of the pinhole ray at the focus distance.
Ray camera_ray_lens(const Camera* cam, float2 pixel_pos, float2 u) {
    float3 d = camera_direction(cam, pixel_pos);
    if (cam->lens_radius <= 0.0f) return make_ray(cam->position, normalize(d), 0.0f, 1e30f);
    float3 focus_point = cam->position + d * cam->focus_distance;
    float2 lens = sample_concentric_disk(u) * cam->lens_radius;
    float3 origin = cam->position + lens.x * cam->right + lens.y * cam->up;
    return make_ray(origin, normalize(focus_point - origin), 0.0f, 1e30f);
}
#endif
