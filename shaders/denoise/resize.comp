// Resize by a whole factor, nearest or bilinear, with ONNX's coordinate transforms: the input
// coordinate of output pixel x is x * u_coord.x + u_coord.y (per axis: u_coord_x, u_coord_y),
// clamped to the image as onnxruntime does.
#include "tensor.glsl"

layout(TENSOR_FORMAT, binding = 0) readonly uniform image2DArray src;
layout(TENSOR_FORMAT, binding = 7) writeonly uniform image2DArray dst;

uniform ivec2 u_in_size;
uniform vec2 u_coord_x;  // (a, b): in = out * a + b
uniform vec2 u_coord_y;
uniform int u_nearest_mode;  // 0 floor, 1 ceil, 2 round_prefer_floor, 3 round_prefer_ceil

int nearest_index(float x, int size) {
    int i;
    if (u_nearest_mode == 0) i = int(floor(x));
    else if (u_nearest_mode == 1) i = int(ceil(x));
    else if (u_nearest_mode == 2) i = int(ceil(x - 0.5));
    else i = int(floor(x + 0.5));
    return clamp(i, 0, size - 1);
}

void main() {
    ivec3 at = ivec3(gl_GlobalInvocationID);
    if (at.x >= u_out_size.x || at.y >= u_out_size.y) return;
    vec2 coord = vec2(float(at.x) * u_coord_x.x + u_coord_x.y, float(at.y) * u_coord_y.x + u_coord_y.y);
#ifdef LINEAR
    coord = clamp(coord, vec2(0.0), vec2(u_in_size - 1));
    ivec2 lo = ivec2(floor(coord));
    ivec2 hi = min(lo + 1, u_in_size - 1);
    vec2 t = coord - vec2(lo);
    vec4 top = imageLoad(src, ivec3(lo.x, lo.y, at.z)) * (1.0 - t.x) + imageLoad(src, ivec3(hi.x, lo.y, at.z)) * t.x;
    vec4 bottom = imageLoad(src, ivec3(lo.x, hi.y, at.z)) * (1.0 - t.x) + imageLoad(src, ivec3(hi.x, hi.y, at.z)) * t.x;
    vec4 v = top * (1.0 - t.y) + bottom * t.y;
#else
    vec4 v = imageLoad(src, ivec3(nearest_index(coord.x, u_in_size.x), nearest_index(coord.y, u_in_size.y), at.z));
#endif
    imageStore(dst, at, v);
}
