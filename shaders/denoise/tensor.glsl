// Activations of the GLSL denoiser: one image2DArray per tensor, channel c in layer c / 4,
// component c % 4, row 0 = the top of the picture (numpy order); TENSOR_FORMAT is the tensors'
// image format, rgba32f. Channels past the tensor's count are written as zero, so that the
// next convolution's zero weights never meet an Inf or a NaN there.
#ifndef DENOISE_TENSOR_GLSL
#define DENOISE_TENSOR_GLSL

#ifndef TENSOR_FORMAT
#define TENSOR_FORMAT rgba32f
#endif

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

uniform ivec2 u_out_size;   // width, height of the output
uniform int u_out_channels; // real channels of the output

// Zero the components of layer `layer` past `channels` (a select, so NaN cannot leak).
vec4 mask_to(vec4 v, int layer, int channels) {
    ivec4 channel = ivec4(4 * layer) + ivec4(0, 1, 2, 3);
    return mix(vec4(0.0), v, lessThan(channel, ivec4(channels)));
}

vec4 mask_channels(vec4 v, int layer) { return mask_to(v, layer, u_out_channels); }

// Which components of layer `layer` hold channels first .. end - 1 (a map over channel ranges).
bvec4 channels_in(int layer, int first, int end) {
    ivec4 channel = ivec4(4 * layer) + ivec4(0, 1, 2, 3);
    return bvec4(uvec4(greaterThanEqual(channel, ivec4(first))) & uvec4(lessThan(channel, ivec4(end))));
}

#endif
