// Max or average pooling, kernel = stride = POOL_SIZE, no padding (sizes are multiples).
#include "tensor.glsl"

layout(TENSOR_FORMAT, binding = 0) readonly uniform image2DArray src;
layout(TENSOR_FORMAT, binding = 7) writeonly uniform image2DArray dst;

void main() {
    ivec3 at = ivec3(gl_GlobalInvocationID);
    if (at.x >= u_out_size.x || at.y >= u_out_size.y) return;
    ivec2 corner = at.xy * POOL_SIZE;
#ifdef POOL_MAX
    vec4 v = imageLoad(src, ivec3(corner, at.z));
#else
    vec4 v = vec4(0.0);
#endif
    for (int dy = 0; dy < POOL_SIZE; ++dy)
        for (int dx = 0; dx < POOL_SIZE; ++dx) {
            vec4 texel = imageLoad(src, ivec3(corner + ivec2(dx, dy), at.z));
#ifdef POOL_MAX
            v = max(v, texel);
#else
            v += texel;
#endif
        }
#ifndef POOL_MAX
    v /= float(POOL_SIZE * POOL_SIZE);
#endif
    imageStore(dst, at, v);
}
