// lift/host_tiles.glsl: which pixel each lane of the trace pass takes, and what its random
// numbers are keyed on (lift/host_main.comp; the pixel queue, lift/host_pixel_queue.glsl):
//   lift_tile_pixel(group, lane, tile)    the pixel lane `lane` of tile `group` takes
//   lift_tile_groups(resolution, tile)    how many such tiles cover the image
//   lift_rng_key(pixel)                   what the pixel's random numbers are keyed on
// A tile has the work group's shape, so a work group (or the queue's tile) is one tile.
//
// Without LIFT_COHERENT_SAMPLING: tiles in the image's grid, and the pixel itself as the key.
// With it (the option coherent_sampling: lift_gl/options.py), coherent sampling (Sadeghi,
// Chen and Jensen 2009): the pixels of a tile, which run in one warp on a GPU, draw the same
// numbers, so their light samples, bounce directions and Russian roulette agree and the
// warp's rays travel together through the BVH. Each pixel's own numbers are as random as
// before (the estimate is unbiased and its variance per pixel the same); what changes is that
// the noise of a tile's pixels is correlated. Two things spread that correlation out:
// - the grid moves: each frame's is offset by a hash of the frame and the seed, so the
//   accumulated noise keeps no fixed grid;
// - with LIFT_COHERENT_INTERLEAVE k > 1 (the paper's interleaved sampling), a tile's pixels
//   are every k-th pixel of a block k times its size, and the block's k x k tiles draw
//   different numbers: neighbouring pixels are independent, and a pixel's noise is
//   correlated with pixels k apart.
// Off, none of this is compiled (no cost).
#ifndef LIFT_HOST_TILES_GLSL
#define LIFT_HOST_TILES_GLSL
#ifdef LIFT_COHERENT_SAMPLING
#ifndef LIFT_COHERENT_INTERLEAVE
#define LIFT_COHERENT_INTERLEAVE 1
#endif
const uint lift_interleave = uint(LIFT_COHERENT_INTERLEAVE);
ivec2 lift_tile_offset(uvec2 tile) {  // this frame's offset of the grid of blocks (k x k tiles)
    uvec2 block = lift_interleave * tile;
    uint bits = pcg_hash(u_frame ^ pcg_hash(u_seed + 0x2545f491u));
    return ivec2(int(bits % block.x), int((bits / block.x) % block.y));
}
uvec2 lift_tile_groups(ivec2 resolution, uvec2 tile) {  // whole blocks over the moved image
    uvec2 block = lift_interleave * tile;
    return (uvec2(resolution + lift_tile_offset(tile)) + block - 1u) / block * lift_interleave;
}
ivec2 lift_tile_pixel(uvec2 group, uvec2 lane, uvec2 tile) {
    uvec2 block = group / lift_interleave, phase = group % lift_interleave;
    return ivec2(block * lift_interleave * tile + phase + lift_interleave * lane) - lift_tile_offset(tile);
}
uvec2 lift_rng_key(uvec2 pixel) {  // its tile: its block and its phase in the block
    const uvec2 tile = gl_WorkGroupSize.xy;
    uvec2 p = pixel + uvec2(lift_tile_offset(tile));
    return p / (lift_interleave * tile) * lift_interleave + p % lift_interleave;
}
#else
uvec2 lift_tile_groups(ivec2 resolution, uvec2 tile) { return (uvec2(resolution) + tile - 1u) / tile; }
ivec2 lift_tile_pixel(uvec2 group, uvec2 lane, uvec2 tile) { return ivec2(group * tile + lane); }
uvec2 lift_rng_key(uvec2 pixel) { return pixel; }
#endif
#endif
