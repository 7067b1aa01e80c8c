// A transposed convolution whose kernel equals its stride STRIDE (a learned depth-to-space):
// output pixel (x, y) is bias + the tap (x % STRIDE, y % STRIDE) of the weights applied to
// input pixel (x / STRIDE, y / STRIDE), then the fused epilogue. Each invocation computes
// OUT_BLOCK output layers of one pixel. The weights are conv.comp's mat4 stream (group,
// part, input layer, ky, kx, output layer of the group), read at this pixel's tap.
#include "tensor.glsl"

layout(std430, binding = LIFT_BINDING_NET_WEIGHTS) readonly buffer Weights { mat4 weights[]; };
layout(std430, binding = LIFT_BINDING_NET_BIAS) readonly buffer Bias { vec4 bias[]; };
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

uniform int u_out_layers;
uniform ivec4 u_part_layers;
uniform int u_weights_per_group;

#define TAPS (STRIDE * STRIDE)
#define CONV_T_PART(image, layers)                                                  \
    for (int layer = 0; layer < layers; ++layer) {                                  \
        vec4 texel = imageLoad(image, ivec3(source, layer));                        \
        for (int j = 0; j < OUT_BLOCK; ++j) acc[j] += weights[w + j] * texel;       \
        w += TAPS * OUT_BLOCK;                                                      \
    }

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    int group = int(gl_WorkGroupID.z);
    if (pixel.x >= u_out_size.x || pixel.y >= u_out_size.y) return;
    ivec2 source = pixel / STRIDE;
    ivec2 tap = pixel % STRIDE;

    vec4 acc[OUT_BLOCK];
    for (int j = 0; j < OUT_BLOCK; ++j) acc[j] = bias[group * OUT_BLOCK + j];
    int w = group * u_weights_per_group + (tap.y * STRIDE + tap.x) * OUT_BLOCK;
    CONV_T_PART(part0, u_part_layers.x)
#if NUM_PARTS > 1
    CONV_T_PART(part1, u_part_layers.y)
#endif
#if NUM_PARTS > 2
    CONV_T_PART(part2, u_part_layers.z)
#endif
#if NUM_PARTS > 3
    CONV_T_PART(part3, u_part_layers.w)
#endif

    for (int j = 0; j < OUT_BLOCK; ++j) {
        int layer = group * OUT_BLOCK + j;
        if (layer >= u_out_layers) break;
        vec4 v = acc[j];
        EPILOGUE
        imageStore(dst, ivec3(pixel, layer), mask_channels(v, layer));
    }
}
