// Splat resolve: add this frame's splats (lift/splat.glsl) to the frame's radiance sums and
// clear the splat buffer for the next frame. The sample count (alpha) is left alone: splats
// are averaged over the pixel's own samples, one light subpath having been traced per sample.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform image2D u_frame;
layout(std430, binding = LIFT_BINDING_SPLATS) buffer LiftSplats { float lift_splats[]; };

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_frame);
    if (any(greaterThanEqual(p, size))) return;
    uint index = 3u * (uint(p.y) * uint(size.x) + uint(p.x));
    vec3 splatted = vec3(lift_splats[index], lift_splats[index + 1u], lift_splats[index + 2u]);
    vec4 frame = imageLoad(u_frame, p);
    imageStore(u_frame, p, vec4(frame.rgb + splatted, frame.a));
    lift_splats[index] = 0.0;
    lift_splats[index + 1u] = 0.0;
    lift_splats[index + 2u] = 0.0;
}
