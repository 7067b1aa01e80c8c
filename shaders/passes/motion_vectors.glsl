// Motion vectors for temporal reprojection (lift_gl/passes/reproject.py), compiled into the
// G-buffer only with LIFT_MOTION_VECTORS.
//
// prev_positions: rows 0 .. 3T-1 hold each triangle corner (BVH order, as tri_pos) where the
// previous frame saw it, in this frame's GPU coordinates; row 3T + i holds sphere i's
// displacement from this frame back to the previous one, then from row 3T + S three rows per
// instance record: its object -> world transform in the previous frame (lift_gl/temporal.py). A still
// object's rows equal its current position (or zero displacement).
#ifndef LIFT_MOTION_VECTORS_GLSL
#define LIFT_MOTION_VECTORS_GLSL
layout(std430, binding = LIFT_BINDING_PREV_POSITIONS) readonly buffer PrevPositions { vec4 prev_positions[]; };
#ifndef LIFT_VERTEX_STAGE  // the vertex shader reads prev_positions only
uniform mat4 u_cur_view_proj;   // this frame's camera, without the subpixel jitter
uniform mat4 u_prev_view_proj;  // the previous frame's camera, without jitter
uniform vec3 u_prev_cam_pos;
uniform vec3 u_prev_cam_forward;
#ifndef LIFT_CAMERA_GLSL  // the ray-cast G-buffer has it from lift/camera.glsl
uniform vec2 u_resolution;
#endif

// Pixel position (pixels, y up, pixel p's centre at p + 0.5) of a point seen through `vp`.
vec2 pixel_position(mat4 vp, vec3 world) {
    vec4 clip = vp * vec4(world, 1.0);
    return (clip.xy / clip.w * 0.5 + 0.5) * u_resolution;
}

// (previous pixel position - current pixel position, the point's view depth in the previous
// camera, how much view depth changes from one pixel to the next here: `gradient`, the
// raster's fwidth(view depth) or the ray-cast G-buffer's own estimate). Jitter is left out of
// both positions, so a still point has motion exactly 0. A point that was behind the
// previous camera gets a motion far off screen: it has no history.
vec4 motion_vector(vec3 world, vec3 prev_world, float gradient) {
    float prev_depth = dot(prev_world - u_prev_cam_pos, u_prev_cam_forward);
    vec2 motion = prev_depth > 0.0
        ? pixel_position(u_prev_view_proj, prev_world) - pixel_position(u_cur_view_proj, world)
        : vec2(1e9);
    return vec4(motion, prev_depth, isinf(gradient) || isnan(gradient) ? 0.0 : gradient);
}
#endif
#endif
