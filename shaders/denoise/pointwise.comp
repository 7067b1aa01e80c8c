// A pointwise op on one tensor (map) or two of the same shape (binary: a OPERATOR b; one may be a
// single channel, BROADCAST_A or _B), then
// the fused chain of pointwise ops that followed it. One invocation per pixel and layer.
#include "tensor.glsl"

layout(TENSOR_FORMAT, binding = 0) readonly uniform image2DArray src_a;
#ifdef OPERATOR
layout(TENSOR_FORMAT, binding = 1) readonly uniform image2DArray src_b;
#endif
layout(TENSOR_FORMAT, binding = 7) writeonly uniform image2DArray dst;

void main() {
    ivec3 at = ivec3(gl_GlobalInvocationID);
    if (at.x >= u_out_size.x || at.y >= u_out_size.y) return;
    int layer = at.z;  // the epilogue's statements may ask which channels they hold
#ifdef BROADCAST_A  // a one-channel operand: its channel over all of the other's
    vec4 v = imageLoad(src_a, ivec3(at.xy, 0)).xxxx;
#else
    vec4 v = imageLoad(src_a, at);
#endif
#if defined(OPERATOR) && defined(BROADCAST_B)
    v = v OPERATOR imageLoad(src_b, ivec3(at.xy, 0)).xxxx;
#elif defined(OPERATOR)
    v = v OPERATOR imageLoad(src_b, at);
#endif
    EPILOGUE
    imageStore(dst, at, mask_channels(v, at.z));
}
