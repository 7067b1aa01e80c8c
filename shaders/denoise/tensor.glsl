// Activations of the GLSL denoiser: one rgba32f image2DArray per tensor, channel c in layer
// c / 4, component c % 4, row 0 = the top of the picture (numpy order). Channels past the
// tensor's count are written as zero, so that the next convolution's zero weights never
// meet an Inf or a NaN there.
#ifndef DENOISE_TENSOR_GLSL
#define DENOISE_TENSOR_GLSL

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

uniform ivec2 u_out_size;   // width, height of the output
uniform int u_out_channels; // real channels of the output

// Zero the channels of layer `layer` past the tensor's count (a select, so NaN cannot leak).
vec4 mask_channels(vec4 v, int layer) {
    ivec4 channel = ivec4(4 * layer) + ivec4(0, 1, 2, 3);
    return mix(vec4(0.0), v, lessThan(channel, ivec4(u_out_channels)));
}

#endif
