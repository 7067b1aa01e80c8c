// A 2-D convolution of stride STRIDE (output size = input size / STRIDE) plus bias, a fused
// pointwise prologue on each input texel loaded (PROLOGUE, masked to PROLOGUE_CHANNELS) and
// a fused pointwise epilogue on each output.
// Each invocation computes OUT_BLOCK output layers (4 * OUT_BLOCK channels) of PIXELS pixels
// of a row, so every input texel it loads is used up to 4 * OUT_BLOCK * KERNEL_W times and
// every weight PIXELS times. The weights are mat4 blocks in the
// order the loops read them (group, part, input layer, ky, kx, output layer of the group):
// one sequential stream per invocation. The input may come in up to 4 parts (a Concat that
// was never copied): u_part_layers[i] input layers from image part_i. Layer counts are
// uniforms, so one compiled variant serves every conv of a network with the same kernel,
// part count and epilogue (llvmpipe compiles each variant for seconds).
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

uniform ivec2 u_in_size;
uniform int u_out_layers;

#ifndef PROLOGUE
#define PROLOGUE
#define PROLOGUE_CHANNELS 0
#endif

vec4 load_input(vec4 v, int layer) {
    PROLOGUE
    return PROLOGUE_CHANNELS > 0 ? mask_to(v, layer, PROLOGUE_CHANNELS) : v;
}
uniform ivec4 u_part_layers;
uniform int u_weights_per_group;

// ---- accumulate one input part ----
// A row of ROW_TEXELS texels is loaded once per input layer and kernel row; each mat4 of
// weights then serves PIXELS pixels (weight loads are the cost on llvmpipe, where every
// invocation loads them itself).
#define ROW_TEXELS ((PIXELS - 1) * STRIDE + KERNEL_W)
#define CONV_PART(image, layers)                                                    \
    for (int layer = 0; layer < layers; ++layer) {                                  \
        for (int ky = 0; ky < KERNEL_H; ++ky) {                                     \
            int y = pixel.y * STRIDE + ky - PAD_TOP;                                \
            bool row_inside = y >= 0 && y < u_in_size.y;                            \
            vec4 row[ROW_TEXELS];                                                   \
            for (int i = 0; i < ROW_TEXELS; ++i) {                                  \
                int x = pixel.x * STRIDE + i - PAD_LEFT;                            \
                row[i] = (row_inside && x >= 0 && x < u_in_size.x)                  \
                    ? load_input(imageLoad(image, ivec3(x, y, layer)), layer)       \
                    : vec4(0.0);                                                    \
            }                                                                       \
            for (int kx = 0; kx < KERNEL_W; ++kx) {                                 \
                for (int j = 0; j < OUT_BLOCK; ++j) {                               \
                    mat4 weight = weights[w + j];                                   \
                    for (int p = 0; p < PIXELS; ++p)                                \
                        acc[j * PIXELS + p] += weight * row[p * STRIDE + kx];       \
                }                                                                   \
                w += OUT_BLOCK;                                                     \
            }                                                                       \
        }                                                                           \
    }

void main() {
    // this invocation: pixels (x .. x + PIXELS - 1, y), output layers of group z
    ivec2 pixel = ivec2(gl_GlobalInvocationID.x * PIXELS, gl_GlobalInvocationID.y);
    int group = int(gl_WorkGroupID.z);
    if (pixel.x >= u_out_size.x || pixel.y >= u_out_size.y) return;

    vec4 acc[OUT_BLOCK * PIXELS];
    for (int j = 0; j < OUT_BLOCK; ++j)
        for (int p = 0; p < PIXELS; ++p) acc[j * PIXELS + p] = bias[group * OUT_BLOCK + j];
    int w = group * u_weights_per_group;
    CONV_PART(part0, u_part_layers.x)
#if NUM_PARTS > 1
    CONV_PART(part1, u_part_layers.y)
#endif
#if NUM_PARTS > 2
    CONV_PART(part2, u_part_layers.z)
#endif
#if NUM_PARTS > 3
    CONV_PART(part3, u_part_layers.w)
#endif

    // ---- epilogue (fused pointwise ops) and store ----
    for (int j = 0; j < OUT_BLOCK; ++j) {
        int layer = group * OUT_BLOCK + j;
        if (layer >= u_out_layers) break;
        for (int p = 0; p < PIXELS && pixel.x + p < u_out_size.x; ++p) {
            vec4 v = acc[j * PIXELS + p];
            EPILOGUE
            imageStore(dst, ivec3(pixel.x + p, pixel.y, layer), mask_channels(v, layer));
        }
    }
}
