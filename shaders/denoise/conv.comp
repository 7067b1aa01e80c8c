// A 2-D convolution (stride 1, the image size kept) plus bias and a fused pointwise epilogue.
// Each invocation computes OUT_BLOCK output layers (4 * OUT_BLOCK channels) of one pixel, so
// every input texel it loads is used 4 * OUT_BLOCK times. The weights are mat4 blocks in the
// order the loops read them (group, part, input layer, ky, kx, output layer of the group):
// one sequential stream per invocation. The input may come in up to 4 parts (a Concat that
// was never copied): u_part_layers[i] input layers from image part_i. Layer counts are
// uniforms, so one compiled variant serves every conv of a network with the same kernel,
// part count and epilogue (llvmpipe compiles each variant for seconds).
#include "tensor.glsl"

layout(std430, binding = 0) readonly buffer Weights { mat4 weights[]; };
layout(std430, binding = 1) readonly buffer Bias { vec4 bias[]; };
layout(rgba32f, binding = 0) readonly uniform image2DArray part0;
#if NUM_PARTS > 1
layout(rgba32f, binding = 1) readonly uniform image2DArray part1;
#endif
#if NUM_PARTS > 2
layout(rgba32f, binding = 2) readonly uniform image2DArray part2;
#endif
#if NUM_PARTS > 3
layout(rgba32f, binding = 3) readonly uniform image2DArray part3;
#endif
layout(rgba32f, binding = 7) writeonly uniform image2DArray dst;

uniform int u_out_layers;
uniform ivec4 u_part_layers;
uniform int u_weights_per_group;

// ---- accumulate one input part ----
#define CONV_PART(image, layers)                                                    \
    for (int layer = 0; layer < layers; ++layer) {                                  \
        for (int ky = 0; ky < KERNEL_H; ++ky) {                                     \
            int y = pixel.y + ky - PAD_TOP;                                         \
            bool row_inside = y >= 0 && y < u_out_size.y;                           \
            for (int kx = 0; kx < KERNEL_W; ++kx) {                                 \
                int x = pixel.x + kx - PAD_LEFT;                                    \
                vec4 texel = (row_inside && x >= 0 && x < u_out_size.x)             \
                    ? imageLoad(image, ivec3(x, y, layer)) : vec4(0.0);             \
                for (int j = 0; j < OUT_BLOCK; ++j) acc[j] += weights[w + j] * texel; \
                w += OUT_BLOCK;                                                     \
            }                                                                       \
        }                                                                           \
    }

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    int group = int(gl_GlobalInvocationID.z);
    if (pixel.x >= u_out_size.x || pixel.y >= u_out_size.y) return;

    vec4 acc[OUT_BLOCK];
    for (int j = 0; j < OUT_BLOCK; ++j) acc[j] = bias[group * OUT_BLOCK + j];
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
        vec4 v = acc[j];
        EPILOGUE
        imageStore(dst, ivec3(pixel, layer), mask_channels(v, layer));
    }
}
