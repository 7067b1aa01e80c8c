// model_io.autoexposure on the GPU, first step: one work group a 16x16 block of the
// demodulated mean (blocks counted from the top-left of the picture, as numpy's row 0 is the
// top; the rows and columns past the last whole block are left out), its mean luminance as a
// sum over the group, stored as log(mean), or as UNLIT where the mean is 1e-8 or less.
// net_exposure.comp then takes the log-average. Every block in a group of its own: one work
// group over the whole picture read 2 million pixels alone (milliseconds at 1080p).
layout(local_size_x = 16, local_size_y = 16) in;
#include "passes/net_input.glsl"
layout(std430, binding = LIFT_BINDING_NET_EXPOSURE) writeonly buffer Blocks { float u_block_log[]; };
uniform ivec2 u_size;        // the picture
uniform ivec2 u_block;       // block size (16, or the picture's side when smaller)
uniform ivec2 u_block_count;
shared float s_sum[256];

void main() {
    ivec2 block = ivec2(gl_WorkGroupID.xy);  // (column, numpy row)
    ivec2 offset = ivec2(gl_LocalInvocationID.xy);
    uint index = gl_LocalInvocationIndex;
    const vec3 LUMINANCE = vec3(0.2126, 0.7152, 0.0722);
    float value = 0.0;
    if (all(lessThan(offset, u_block))) {
        ivec2 q = block * u_block + offset;
        ivec2 p = ivec2(q.x, u_size.y - 1 - q.y);
        value = dot(net_demodulated(p, net_albedo(p)), LUMINANCE);
    }
    s_sum[index] = value;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1) {
        if (index < stride) s_sum[index] += s_sum[index + stride];
        barrier();
    }
    if (index == 0u) {
        float mean = s_sum[0] / float(u_block.x * u_block.y);
        u_block_log[1 + block.y * u_block_count.x + block.x] = mean > 1e-8 ? log(mean) : -1e30;  // log(1e-8) = -18.4: far above
    }
}
