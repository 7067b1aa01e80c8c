// lift/camera.glsl: the perspective thin-lens camera (the raster G-buffer uses the same
// projection, so a camera ray through a pixel position finds the primitive the raster saw).
// Pixel positions are in pixels with y up (OpenGL window convention), (0,0) = bottom-left corner.
#ifndef LIFT_CAMERA_GLSL
#define LIFT_CAMERA_GLSL
#include "lift/trace.glsl"
#include "lift/sampling.glsl"

uniform vec3 u_cam_pos;
uniform vec3 u_cam_right;    // unit vectors, world space
uniform vec3 u_cam_up;
uniform vec3 u_cam_forward;
uniform float u_tan_half_fov;  // tan(vertical fov / 2)
uniform vec2 u_resolution;     // width, height in pixels
uniform float u_lens_radius;   // 0: pinhole
uniform float u_focus_distance;

// Whether a pixel lies in the image (tiles and splats may reach past its edges).
bool pixel_in_image(ivec2 pixel) {
    return all(greaterThanEqual(pixel, ivec2(0))) && all(lessThan(pixel, ivec2(u_resolution)));
}

// Direction (unnormalized, forward component 1) through a pixel position.
vec3 camera_direction(vec2 pixel_pos) {
    vec2 ndc = pixel_pos / u_resolution * 2.0 - 1.0;
    float aspect = u_resolution.x / u_resolution.y;
    return u_cam_forward + ndc.x * u_tan_half_fov * aspect * u_cam_right + ndc.y * u_tan_half_fov * u_cam_up;
}

// A pinhole ray (the one the raster G-buffer agrees with).
Ray camera_ray(vec2 pixel_pos) {
    return Ray(u_cam_pos, normalize(camera_direction(pixel_pos)), 0.0, 1e30);
}

// A thin-lens ray: the lens point comes from u, the ray passes through the point of the
// pinhole ray at the focus distance (measured along forward).
Ray camera_ray_lens(vec2 pixel_pos, vec2 u) {
    vec3 d = camera_direction(pixel_pos);
    if (u_lens_radius <= 0.0) return Ray(u_cam_pos, normalize(d), 0.0, 1e30);
    vec3 focus_point = u_cam_pos + d * u_focus_distance;
    vec2 lens = sample_concentric_disk(u) * u_lens_radius;
    vec3 origin = u_cam_pos + lens.x * u_cam_right + lens.y * u_cam_up;
    return Ray(origin, normalize(focus_point - origin), 0.0, 1e30);
}
#endif
