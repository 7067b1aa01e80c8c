// A region of pointwise steps (maps, binaries, channel slices within one layer) computed per
// pixel in registers (lift_gl/denoise/onnx_graph.py, Plan._fuse_pointwise_tails): BODY loads
// the texels it needs from src0 .. src3, computes each value as a vec4 masked to its channels,
// and leaves the last in `v`. The output has at most 4 channels: one layer.
#include "tensor.glsl"

layout(TENSOR_FORMAT, binding = 0) readonly uniform image2DArray src0;
#if NUM_INPUTS > 1
layout(TENSOR_FORMAT, binding = 1) readonly uniform image2DArray src1;
#endif
#if NUM_INPUTS > 2
layout(TENSOR_FORMAT, binding = 2) readonly uniform image2DArray src2;
#endif
#if NUM_INPUTS > 3
layout(TENSOR_FORMAT, binding = 3) readonly uniform image2DArray src3;
#endif
layout(TENSOR_FORMAT, binding = 7) writeonly uniform image2DArray dst;

void main() {
    ivec3 at = ivec3(gl_GlobalInvocationID);
    if (at.x >= u_out_size.x || at.y >= u_out_size.y) return;
    int layer = 0;  // what a map's statements ask (channels_in)
    vec4 v;
    BODY
    imageStore(dst, ivec3(at.xy, 0), mask_channels(v, 0));
}
