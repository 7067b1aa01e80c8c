// lift/camera_importance.glsl: the pinhole camera seen from the scene, for light tracing and
// bidirectional methods: where a point lands on the image, the camera's importance W_e, and
// the density with which camera rays take a direction. The thin lens is not modelled here:
// these are the pinhole's (the camera that a G-buffer primary hit implies).
#ifndef LIFT_CAMERA_IMPORTANCE_GLSL
#define LIFT_CAMERA_IMPORTANCE_GLSL
#include "lift/camera.glsl"

// Area of the image rectangle on the plane at distance 1 in front of the pinhole.
float camera_image_area() {
    float aspect = u_resolution.x / u_resolution.y;
    return 4.0 * u_tan_half_fov * u_tan_half_fov * aspect;
}

// The pixel position (pixels, y up, as camera_ray takes it) where world point p appears;
// false when p is behind the camera or outside the image. Inverse of camera_direction.
bool camera_project(vec3 p, out vec2 pixel_pos) {
    pixel_pos = vec2(-1.0);
    vec3 d = p - u_cam_pos;
    float depth = dot(d, u_cam_forward);
    if (!(depth > 0.0)) return false;
    float aspect = u_resolution.x / u_resolution.y;
    vec2 ndc = vec2(dot(d, u_cam_right) / (depth * u_tan_half_fov * aspect),
                    dot(d, u_cam_up) / (depth * u_tan_half_fov));
    pixel_pos = (ndc * 0.5 + 0.5) * u_resolution;
    return all(greaterThanEqual(pixel_pos, vec2(0.0))) && all(lessThan(pixel_pos, u_resolution));
}

// Solid-angle density of the direction of camera_ray at a pixel position uniform over the
// image: 1 / (A cos^3), A the image area at distance 1 (dA = dw / cos^3 on that plane).
// Zero behind the camera; the caller checks that dir is inside the image (camera_project).
float camera_pdf_dir(vec3 dir) {
    float c = dot(dir, u_cam_forward);
    if (c <= 0.0) return 0.0;
    return 1.0 / (camera_image_area() * c * c * c);
}

// Importance W_e of the ray leaving the pinhole along unit dir, for the whole image:
// W_e = 1 / (A cos^4), so that the integral of W_e cos over the image's directions is 1.
// A pixel's own importance is width x height times W_e inside it; hence one light subpath
// per pixel sample, splatted with W_e, gives the pixel's value once divided by its samples.
float camera_importance(vec3 dir) {
    float c = dot(dir, u_cam_forward);
    if (c <= 0.0) return 0.0;
    return 1.0 / (camera_image_area() * c * c * c * c);
}
#endif
