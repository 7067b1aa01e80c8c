// model_io.autoexposure on the GPU, second step: one work group takes the log-average of the
// blocks' log mean luminances (net_exposure_blocks.comp wrote them after word 0; -1e30: a
// block at 1e-8 or less, left out) and stores 0.18 / key, clipped, in word 0.
layout(local_size_x = 256) in;
layout(std430, binding = LIFT_BINDING_NET_EXPOSURE) buffer Exposure { float u_exposure; float u_block_log[]; };
uniform ivec2 u_block_count;
uniform float u_key;
uniform vec2 u_range;
shared float s_log[256];
shared float s_lit[256];

void main() {
    uint index = gl_LocalInvocationIndex;
    int count = u_block_count.x * u_block_count.y;
    float log_sum = 0.0, lit = 0.0;
    for (int b = int(index); b < count; b += 256) {
        float value = u_block_log[b];
        if (value > -1e29) {
            log_sum += value;
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
