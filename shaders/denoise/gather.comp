// Channel gather: output channel c is input channel u_start + c * u_step of the input, which
// may come in up to 4 parts (a Concat). Slice and the copy of a Concat into one tensor.
#include "tensor.glsl"

layout(TENSOR_FORMAT, binding = 0) readonly uniform image2DArray part0;
#if NUM_PARTS > 1
layout(TENSOR_FORMAT, binding = 1) readonly uniform image2DArray part1;
#endif
#if NUM_PARTS > 2
layout(TENSOR_FORMAT, binding = 2) readonly uniform image2DArray part2;
#endif
#if NUM_PARTS > 3
layout(TENSOR_FORMAT, binding = 3) readonly uniform image2DArray part3;
#endif
layout(TENSOR_FORMAT, binding = 7) writeonly uniform image2DArray dst;

uniform int u_start;
uniform int u_step;
uniform ivec4 u_part_end;  // channel index one past each part, in the concatenated order

float load_channel(ivec2 pixel, int channel) {
    if (channel < u_part_end.x) return imageLoad(part0, ivec3(pixel, channel / 4))[channel % 4];
#if NUM_PARTS > 1
    channel -= u_part_end.x;
    if (channel < u_part_end.y - u_part_end.x) return imageLoad(part1, ivec3(pixel, channel / 4))[channel % 4];
#endif
#if NUM_PARTS > 2
    channel -= u_part_end.y - u_part_end.x;
    if (channel < u_part_end.z - u_part_end.y) return imageLoad(part2, ivec3(pixel, channel / 4))[channel % 4];
#endif
#if NUM_PARTS > 3
    channel -= u_part_end.z - u_part_end.y;
    if (channel < u_part_end.w - u_part_end.z) return imageLoad(part3, ivec3(pixel, channel / 4))[channel % 4];
#endif
    return 0.0;
}

void main() {
    ivec3 at = ivec3(gl_GlobalInvocationID);
    if (at.x >= u_out_size.x || at.y >= u_out_size.y) return;
    vec4 v = vec4(0.0);
    for (int k = 0; k < 4; ++k) {
        int c = 4 * at.z + k;
        if (c < u_out_channels) v[k] = load_channel(at.xy, u_start + c * u_step);
    }
    imageStore(dst, at, v);
}
