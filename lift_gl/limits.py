"""Hostile sizes are refused before anything is allocated, with the limit named.

- the film: each side at most the GL's texture / framebuffer / viewport size, and all of its
  buffers together at most MAX_FILM_BYTES;
- the scene: every shader storage buffer at most GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB on
  llvmpipe, 2 GiB on NVIDIA). The BVH and per-triangle arrays may be split across up to
  split.MAX_HEAP_CHUNKS buffers (lift_gl/scene/split.py); a scene that needs more is refused,
  from the triangle count before the BVH is built and again, exactly, after packing;
- scene files: Include/Import directives executed (MAX_INCLUDES) and the text they read
  (MAX_INCLUDED_BYTES), counted over the whole scene, so that a file including two others
  twenty levels deep is refused after MAX_INCLUDES reads, not after 2^20; instance
  placements (MAX_INSTANCES, the G-buffer's 16-bit instance id), counted in the file's text
  before it is parsed;
- images: a texture's or environment map's width x height, read from the file's header
  before any pixel is decoded (MAX_TEXTURE_PIXELS), and any other image read
  (MAX_IMAGE_PIXELS: a --ref, a PFM or EXR);
- plugin shaders: each array a plugin's GLSL declares, in scalar components, from its
  source before the GL compiler sees it (MAX_SHADER_ARRAY_COMPONENTS; lift_gl/glsl_arrays.py:
  llvmpipe's compiler needs minutes and gigabytes for 65,536 floats).

The option max_buffer_bytes (lift_gl/options.py; GlLimits.query's argument) lowers the
per-buffer limit below the GL's: tests force a split with it, and it shows on a GPU with 2 GiB
buffers how a scene is split on llvmpipe.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from .errors import LimitError
from .scene.instances import MAX_INSTANCES
from .scene.split import HEAP_ARRAYS, MAX_HEAP_CHUNKS, ROW_BYTES, plan_buffers


# Bytes per film pixel: trace frame and accumulation sum + compensation (RGBA32F each),
# G-buffer visibility (RGBA32UI), normal/depth (RGBA32F), albedo (RGBA16F), depth (32 bit),
# tone-mapped RGBA8.
FILM_BYTES_PER_PIXEL = 16 + 32 + 16 + 16 + 8 + 4 + 4
MAX_FILM_BYTES = 4 << 30  # 4 GiB, so that a typo in --size cannot eat the machine's memory
# Bytes per triangle of the largest per-triangle buffer (three vec4 corners: tri_pos, tri_normal,
# tri_uv) and per BVH node (two vec4); a BVH over T triangles has at most 2T - 1 nodes.
TRIANGLE_BYTES = 48
BVH_NODE_BYTES = 32
# The per-triangle arrays together (tri_pos, tri_normal, tri_uv, tri_info), without the BVH:
# a lower bound on the heap a split scene needs, used before the BVH exists.
TRIANGLE_HEAP_BYTES = 3 * TRIANGLE_BYTES + 8

MAX_INCLUDES = 2048              # Include/Import directives run (a file included twice counts twice)
MAX_INCLUDED_BYTES = 64 << 20    # text read through them (64 MiB; pbrt text parses at about 1 MB/s)
MAX_TEXTURE_PIXELS = 1 << 24     # 4096 x 4096 (64 MiB as RGBA8; the images buffer holds 128 MiB)
MAX_IMAGE_PIXELS = 1 << 26       # 8192 x 8192: any image read (768 MiB as float32 RGB)
MAX_SCENE_TEXT_BYTES = 32 << 20  # a glTF's JSON (Python holds about 10x its size as objects)
MAX_SETTINGS_BYTES = 4 << 20     # a camera path or plugin manifest: text a person writes (TOML parses at ~2 MB/s)
MAX_ENVIRONMENT_SIDE = 1 << 16   # texels of an environment map's side (its sampler's guides are 16-bit)
MAX_SHADER_ARRAY_COMPONENTS = 4096  # scalars of one GLSL array (16 KiB of floats an invocation)


@dataclass(frozen=True)
class GlLimits:
    renderer: str
    max_texture_size: int
    max_framebuffer: tuple[int, int]
    max_viewport: tuple[int, int]
    max_ssbo_bytes: int

    @classmethod
    def query(cls, ctx, max_buffer_bytes: int | None = None) -> "GlLimits":
        """The context's limits; `max_buffer_bytes` lowers the per-buffer one (None: the GL's)."""
        info = ctx.info
        viewport = info.get("GL_MAX_VIEWPORT_DIMS", (1 << 14, 1 << 14))
        return cls(renderer=str(info.get("GL_RENDERER", "?")),
                   max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 1 << 14)),
                   max_framebuffer=(int(info.get("GL_MAX_FRAMEBUFFER_WIDTH", 1 << 14)),
                                    int(info.get("GL_MAX_FRAMEBUFFER_HEIGHT", 1 << 14))),
                   max_viewport=(int(viewport[0]), int(viewport[1])),
                   max_ssbo_bytes=_lowered(int(info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)),
                                           max_buffer_bytes))


def _lowered(gl_max: int, value: int | None) -> int:
    """The GL's per-buffer limit, or `value` where that is lower."""
    if value is None:
        return gl_max
    if int(value) < ROW_BYTES:
        raise LimitError(f"max_buffer_bytes = {value} is below one row ({ROW_BYTES} bytes)")
    return min(gl_max, int(value))


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
                      f"{limits.renderer} (only the BVH and triangle arrays are split across buffers)",
                      where)


def _heap_bytes_allowed(limits: GlLimits) -> int:
    rows = max(limits.max_ssbo_bytes // ROW_BYTES, 1)
    return MAX_HEAP_CHUNKS * (1 << (rows.bit_length() - 1)) * ROW_BYTES


def _heap_error(what: str, need: int, limits: GlLimits, where) -> LimitError:
    allowed = _heap_bytes_allowed(limits)
    return LimitError(f"{what} needs {_mib(need)} of BVH and triangle buffers, more than this GL can "
                      f"hold: at most {MAX_HEAP_CHUNKS} buffers of {_mib(allowed // MAX_HEAP_CHUNKS)} "
                      f"({_mib(allowed)}; GL_MAX_SHADER_STORAGE_BLOCK_SIZE = {_mib(limits.max_ssbo_bytes)} "
                      f"on {limits.renderer})", where)


def check_triangle_count(triangles: int, limits: GlLimits, where=None) -> None:
    """Before packing: the per-triangle arrays alone (the BVH comes on top) must fit in the
    split heap, at TRIANGLE_HEAP_BYTES a triangle."""
    need = triangles * TRIANGLE_HEAP_BYTES
    if need > _heap_bytes_allowed(limits):
        raise _heap_error(f"a scene of {triangles:,} triangles", need, limits, where)


def check_packed(packed, limits: GlLimits, names, where=None):
    """After packing: every buffer the shaders read, exactly. Returns the split plan
    (lift_gl/scene/split.py) the scene needs under these limits."""
    plan = plan_buffers(packed, limits.max_ssbo_bytes)
    if plan.split and plan.chunks > MAX_HEAP_CHUNKS:
        raise _heap_error(f"the scene ({packed.num_triangles:,} triangles)", plan.heap_rows * ROW_BYTES,
                          limits, where)
    for name in names:
        if plan.split and name in HEAP_ARRAYS:
            continue
        array = getattr(packed, name)
        need = 0 if array is None else int(array.nbytes)  # None: instances the scene has not
        if need > limits.max_ssbo_bytes:
            raise _ssbo_error(f"the scene's '{name}' buffer", need, limits, where)
    if packed.motion is not None and packed.motion.nbytes > limits.max_ssbo_bytes:
        raise _ssbo_error("the scene's 'motion' buffer", int(packed.motion.nbytes), limits, where)
    return plan


# ---- input files: each check runs before the thing it bounds is read or allocated ----------

def _over(what: str, name: str, limit: int, where) -> LimitError:
    """`what` states the count; the error adds the limit's name and value."""
    path, line = where if isinstance(where, tuple) else (where, None)
    return LimitError(f"{what}, over the limit lift_gl.limits.{name} = {limit:,}", path, line)


def check_scene_text(size: int, path, *, what: str = "a file") -> None:
    """A glTF's JSON is refused from its size before it is parsed (a 1.5 GB one ran past 1 GiB)."""
    if size > MAX_SCENE_TEXT_BYTES:
        raise _over(f"{what} of {size:,} bytes", "MAX_SCENE_TEXT_BYTES", MAX_SCENE_TEXT_BYTES, path)


def check_settings_file(path) -> None:
    """A camera path or plugin manifest is refused from its size before it is read (a 9 MB one
    of nested arrays took more than 5 s to parse)."""
    size = os.path.getsize(path)
    if size > MAX_SETTINGS_BYTES:
        raise _over(f"a file of {size:,} bytes", "MAX_SETTINGS_BYTES", MAX_SETTINGS_BYTES, path)


class IncludeBudget:
    """Include/Import directives of one scene and the bytes they read, all files together
    (a file included twice counts twice)."""

    def __init__(self):
        self.includes = 0
        self.bytes = 0

    def add(self, path, where=None) -> None:
        """Count one inclusion of `path`, its size taken from the file system before it is read;
        `where` is (file, line) of the directive."""
        self.includes += 1
        if self.includes > MAX_INCLUDES:
            raise _over(f"including {path} makes {self.includes:,} inclusions in this scene", "MAX_INCLUDES",
                        MAX_INCLUDES, where)
        self.bytes += os.path.getsize(path)
        if self.bytes > MAX_INCLUDED_BYTES:
            raise _over(f"including {path} makes {self.bytes:,} bytes of included text", "MAX_INCLUDED_BYTES",
                        MAX_INCLUDED_BYTES, where)


def check_instance_count(count: int, where=None) -> None:
    if count > MAX_INSTANCES:
        raise _over(f"{count:,} instances", "MAX_INSTANCES", MAX_INSTANCES, where)


def check_image_pixels(width: int, height: int, where=None, *, what: str = "an image",
                       limit_name: str = "MAX_IMAGE_PIXELS") -> None:
    """Refuse an image from the size its header claims, before its pixels are decoded;
    textures and environment maps are held to limit_name = "MAX_TEXTURE_PIXELS"."""
    limit = globals()[limit_name]  # looked up when called: tests lower it
    if width <= 0 or height <= 0:  # a header of 0 rows decoded to an array no sampler can index
        path, line = where if isinstance(where, tuple) else (where, None)
        raise LimitError(f"{what} of {width:,}x{height:,} pixels has no pixels", path, line)
    if width * height > limit:
        raise _over(f"{what} of {width:,}x{height:,} pixels ({width * height:,})", limit_name, limit, where)


def image_too_large(pixels: int, where=None, *, what: str = "an image", limit_name: str = "MAX_IMAGE_PIXELS"):
    """The error of check_image_pixels where only the pixel count is known."""
    return _over(f"{what} of {pixels:,} pixels", limit_name, globals()[limit_name], where)


def check_shader_array(components: int, where=None) -> None:
    if components > MAX_SHADER_ARRAY_COMPONENTS:
        raise _over(f"an array of {components:,} scalar components", "MAX_SHADER_ARRAY_COMPONENTS",
                    MAX_SHADER_ARRAY_COMPONENTS, where)
