// model_io.autoexposure on the GPU: the mean luminance of each block of the demodulated
// mean (blocks counted from the top-left of the picture, as numpy's row 0 is the top; the
// rows and columns past the last whole block are left out), then one work group takes the
// log-average of the blocks above 1e-8 and stores 0.18 / key, clipped, in u_exposure.
layout(local_size_x = 256) in;
#include "passes/net_input.glsl"
layout(std430, binding = LIFT_BINDING_NET_EXPOSURE) writeonly buffer Exposure { float u_exposure; };
uniform ivec2 u_size;        // the picture
uniform ivec2 u_block;       // block size (16, or the picture's side when smaller)
uniform ivec2 u_block_count;
uniform float u_key;
uniform vec2 u_range;
shared float s_log[256];
shared float s_lit[256];

void main() {
    uint index = gl_LocalInvocationIndex;
    int count = u_block_count.x * u_block_count.y;
    float log_sum = 0.0, lit = 0.0;
    const vec3 LUMINANCE = vec3(0.2126, 0.7152, 0.0722);
    for (int b = int(index); b < count; b += 256) {
        ivec2 origin = ivec2(b % u_block_count.x, b / u_block_count.x) * u_block;  // (column, numpy row)
        float total = 0.0;
        for (int y = 0; y < u_block.y; ++y) {
            for (int x = 0; x < u_block.x; ++x) {
                ivec2 p = ivec2(origin.x + x, u_size.y - 1 - (origin.y + y));
                total += dot(net_demodulated(p, net_albedo(p)), LUMINANCE);
            }
        }
        float mean = total / float(u_block.x * u_block.y);
        if (mean > 1e-8) {
            log_sum += log(mean);
            lit += 1.0;
        }
    }
    s_log[index] = log_sum;
    s_lit[index] = lit;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1) {
        if (index < stride) {
            s_log[index] += s_log[index + stride];
            s_lit[index] += s_lit[index + stride];
        }
        barrier();
    }
    if (index == 0u) {
        u_exposure = s_lit[0] > 0.0 ? clamp(u_key / exp(s_log[0] / s_lit[0]), u_range.x, u_range.y) : 1.0;
    }
}
