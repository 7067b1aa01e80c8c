// A pointwise op on one tensor (map) or two of the same shape (binary: a OPERATOR b), then
// the fused chain of pointwise ops that followed it. One invocation per pixel and layer.
#include "tensor.glsl"

layout(rgba32f, binding = 0) readonly uniform image2DArray src_a;
#ifdef OPERATOR
layout(rgba32f, binding = 1) readonly uniform image2DArray src_b;
#endif
layout(rgba32f, binding = 7) writeonly uniform image2DArray dst;

void main() {
    ivec3 at = ivec3(gl_GlobalInvocationID);
    if (at.x >= u_out_size.x || at.y >= u_out_size.y) return;
    vec4 v = imageLoad(src_a, at);
#ifdef OPERATOR
    v = v OPERATOR imageLoad(src_b, at);
#endif
    EPILOGUE
    imageStore(dst, at, mask_channels(v, at.z));
}
