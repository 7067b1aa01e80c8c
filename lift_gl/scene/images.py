"""Pack a scene's images (base colour textures and the environment map) into one buffer of
32-bit words, the `images` SSBO of shaders/lift/scene_data.glsl, plus the uniforms that
locate the environment map in it. (llvmpipe has no bindless textures, and a texture array
would force every image to one size; a buffer keeps each image at its own resolution.)

Layout, in words:
- texture descriptors, 4 words per texture t at 4t: first texel word, width, height, flags
  (bit 0: sRGB-encoded);
- texels of every texture, RGBA8 packed in one word (R in the low byte), rows from the top;
- environment map: texels as float32 RGBA (A unused: one 16-byte read a texel, the block
  starting at a multiple of 4 words; rows from the top); the marginal density (H), cdf (H + 1)
  and search guide (H); the conditional densities (H x W); the conditional cdfs (H x (W + 1))
  and search guides (H x W) (envmap.py).
"""
from __future__ import annotations

import warnings

import numpy as np

from .envmap import build_distribution, search_guides
from .model import Scene, Texture

# llvmpipe's GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB), the smallest seen (FACTS.md).
MAX_BUFFER_BYTES = 128 << 20
FLAG_SRGB = 1


def _texel_words(t: Texture) -> np.ndarray:
    rgba = t.pixels
    if rgba.ndim == 2:
        rgba = rgba[:, :, None]
    if rgba.shape[2] == 1:
        rgba = np.repeat(rgba, 3, axis=2)
    if rgba.shape[2] == 3:
        rgba = np.concatenate([rgba, np.full(rgba.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return np.ascontiguousarray(rgba[:, :, :4], dtype=np.uint8).reshape(-1).view("<u4")


def _fit(textures: list[Texture], budget_words: int) -> list[Texture]:
    """Halve the largest textures until all fit in the buffer, with one warning."""
    from PIL import Image

    textures = list(textures)
    halved = set()
    while sum(t.pixels.shape[0] * t.pixels.shape[1] for t in textures) > budget_words:
        i = max(range(len(textures)), key=lambda k: textures[k].pixels.size)
        t = textures[i]
        h, w = t.pixels.shape[:2]
        if h < 2 or w < 2:
            break
        img = Image.fromarray(t.pixels).resize((w // 2, h // 2), Image.BOX)
        textures[i] = Texture(t.name, np.asarray(img), t.srgb, t.source)
        halved.add(t.name)
    if halved:
        warnings.warn(f"textures too large for one {MAX_BUFFER_BYTES >> 20} MiB buffer; "
                      f"downsampled: {', '.join(sorted(halved))}", stacklevel=3)
    return textures


def pack_images(scene: Scene, max_bytes: int = MAX_BUFFER_BYTES) -> tuple[np.ndarray, dict]:
    """(uint32 words, uniforms). One zero word when the scene has no images (GL needs a
    non-empty buffer)."""
    env = scene.environment
    env_image = env.image if env is not None and env.image is not None else None
    env_words = 0
    if env_image is not None:
        h, w = env_image.shape[:2]
        env_words = 3 + h * w * 4 + (3 * h + 1) + h * w + h * (w + 1) + h * w
    textures = _fit(scene.textures, max_bytes // 4 - env_words - 4 * len(scene.textures))

    parts: list[np.ndarray] = []
    offset = 4 * len(textures)
    descriptors = np.zeros((len(textures), 4), np.uint32)
    texel_parts = []
    for i, t in enumerate(textures):
        words = _texel_words(t)
        descriptors[i] = (offset, t.pixels.shape[1], t.pixels.shape[0], FLAG_SRGB if t.srgb else 0)
        texel_parts.append(words)
        offset += len(words)
    parts.append(descriptors.reshape(-1))
    parts += texel_parts

    uniforms = {"u_env_map_size": (0, 0), "u_env_map_offsets": (0, 0, 0, 0),
                "u_env_to_world": np.eye(3, dtype=np.float32), "u_env_from_world": np.eye(3, dtype=np.float32)}
    if env_image is not None:
        h, w = env_image.shape[:2]
        dist = build_distribution(env_image)
        pad = -offset % 4   # the texels start at a multiple of 4 words (images4 in scene_data.glsl)
        parts.append(np.zeros(pad, np.uint32))
        offset += pad
        texels = np.zeros((h, w, 4), np.float32)
        texels[:, :, :3] = env_image[:, :, :3]
        marginal_cdf = dist.marginal_cdf.astype(np.float32)
        conditional_cdf = dist.conditional_cdf.astype(np.float32)
        def words(a):
            return np.ascontiguousarray(a).view(np.uint32).reshape(-1)

        blocks = [words(texels),
                  np.concatenate([words(dist.marginal_pdf.astype(np.float32)), words(marginal_cdf),
                                  search_guides(marginal_cdf)]),
                  words(dist.conditional_pdf.astype(np.float32)),
                  np.concatenate([words(conditional_cdf), search_guides(conditional_cdf).reshape(-1)])]
        starts = []
        for block in blocks:
            starts.append(offset)
            parts.append(block)
            offset += len(block)
        to_world = _orthonormal(env.to_world)
        uniforms.update({
            "u_env_map_size": (w, h),
            "u_env_map_offsets": tuple(starts),
            # GLSL reads a mat3 column by column: numpy's transpose, row-major bytes.
            "u_env_to_world": to_world.T.astype(np.float32),
            "u_env_from_world": np.linalg.inv(to_world).T.astype(np.float32),
        })
    heap = np.concatenate(parts) if offset else np.zeros(1, np.uint32)
    return heap.astype(np.uint32), uniforms


def _orthonormal(m: np.ndarray) -> np.ndarray:
    """The orthogonal part of a linear map (polar decomposition): environment maps rotate
    (or mirror) but never stretch, so directions keep unit length and pdfs their measure."""
    u, _, vt = np.linalg.svd(np.asarray(m, dtype=np.float64))
    return u @ vt
