"""Hostile sizes are refused before anything is allocated, with the limit named.

- the film: each side at most the GL's texture / framebuffer / viewport size, and all of its
  buffers together at most MAX_FILM_BYTES;
- the scene: every shader storage buffer at most GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB on
  llvmpipe, 2 GiB on NVIDIA), checked from the triangle count before the BVH is built and
  again, exactly, after packing. (Splitting big scenes across buffers is a later issue.)
"""
from __future__ import annotations

from dataclasses import dataclass

from .errors import LimitError

# Bytes per film pixel: trace frame and accumulation sum + compensation (RGBA32F each),
# G-buffer visibility (RGBA32UI), normal/depth (RGBA32F), albedo (RGBA16F), depth (32 bit),
# tone-mapped RGBA8.
FILM_BYTES_PER_PIXEL = 16 + 32 + 16 + 16 + 8 + 4 + 4
MAX_FILM_BYTES = 4 << 30  # 4 GiB, so that a typo in --size cannot eat the machine's memory
# Bytes per triangle of the largest per-triangle buffer (three vec4 corners: tri_pos, tri_normal,
# tri_uv) and per BVH node (two vec4); a BVH over T triangles has at most 2T - 1 nodes.
TRIANGLE_BYTES = 48
BVH_NODE_BYTES = 32


@dataclass(frozen=True)
class GlLimits:
    renderer: str
    max_texture_size: int
    max_framebuffer: tuple[int, int]
    max_viewport: tuple[int, int]
    max_ssbo_bytes: int

    @classmethod
    def query(cls, ctx) -> "GlLimits":
        info = ctx.info
        viewport = info.get("GL_MAX_VIEWPORT_DIMS", (1 << 14, 1 << 14))
        return cls(renderer=str(info.get("GL_RENDERER", "?")),
                   max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 1 << 14)),
                   max_framebuffer=(int(info.get("GL_MAX_FRAMEBUFFER_WIDTH", 1 << 14)),
                                    int(info.get("GL_MAX_FRAMEBUFFER_HEIGHT", 1 << 14))),
                   max_viewport=(int(viewport[0]), int(viewport[1])),
                   max_ssbo_bytes=int(info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)))


def _mib(n: int) -> str:
    return f"{n / (1 << 20):,.1f} MiB"


def check_film(size, limits: GlLimits, where=None) -> None:
    """Raise LimitError for a film the GL cannot hold or that would need > MAX_FILM_BYTES."""
    w, h = (int(v) for v in size)
    if w <= 0 or h <= 0:
        raise LimitError(f"film size {w}x{h} must be positive", where)
    side = min(limits.max_texture_size, *limits.max_framebuffer, *limits.max_viewport)
    if w > side or h > side:
        raise LimitError(f"film {w}x{h} is larger than this GL allows: at most {side} pixels a side "
                         f"(GL_MAX_TEXTURE_SIZE {limits.max_texture_size}, GL_MAX_FRAMEBUFFER_WIDTH/HEIGHT "
                         f"{limits.max_framebuffer[0]}x{limits.max_framebuffer[1]}, GL_MAX_VIEWPORT_DIMS "
                         f"{limits.max_viewport[0]}x{limits.max_viewport[1]} on {limits.renderer})", where)
    need = w * h * FILM_BYTES_PER_PIXEL
    if need > MAX_FILM_BYTES:
        raise LimitError(f"film {w}x{h} would need {need / (1 << 30):,.1f} GiB of buffers "
                         f"({FILM_BYTES_PER_PIXEL} bytes a pixel); the limit is lift_gl.limits."
                         f"MAX_FILM_BYTES = {MAX_FILM_BYTES >> 30} GiB", where)


def _ssbo_error(what: str, need: int, limits: GlLimits, where) -> LimitError:
    return LimitError(f"{what} needs {_mib(need)} in one shader storage buffer, more than this GL "
                      f"allows: GL_MAX_SHADER_STORAGE_BLOCK_SIZE = {_mib(limits.max_ssbo_bytes)} on "
                      f"{limits.renderer} (splitting a scene across buffers is not implemented yet)",
                      where)


def check_triangle_count(triangles: int, limits: GlLimits, where=None) -> None:
    """Before packing: the per-triangle buffers grow by TRIANGLE_BYTES a triangle."""
    need = triangles * TRIANGLE_BYTES
    if need > limits.max_ssbo_bytes:
        raise _ssbo_error(f"a scene of {triangles:,} triangles", need, limits, where)


def check_packed(packed, limits: GlLimits, names, where=None) -> None:
    """After packing: every buffer the shaders read, exactly."""
    for name in names:
        need = int(getattr(packed, name).nbytes)
        if need > limits.max_ssbo_bytes:
            raise _ssbo_error(f"the scene's '{name}' buffer", need, limits, where)
