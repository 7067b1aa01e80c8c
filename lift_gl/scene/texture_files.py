"""Image files for materials and environments, as loaders read them.

`TextureLibrary` turns image files (PNG, JPEG, TGA, BMP through pillow) into Scene.textures,
each file once. A file that is missing or unreadable is reported once, naming the scene file
and line that asked for it, and the caller falls back to the material's constant colour:
a scene with a lost texture still renders.

`read_environment_image` reads a latitude-longitude map: EXR and PFM through
lift_gl.image_io, Radiance .hdr (RGBE) here, anything pillow reads as 8-bit sRGB.

Every image's size is read from its header and held to lift_gl.limits.MAX_TEXTURE_PIXELS
before a pixel is decoded (a 300 KB PNG may claim 10000 x 10000 pixels): a JPEG over it is
decoded at 1/2, 1/4 or 1/8 of its size, with a warning; any other image is refused.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import LimitError, SceneError
from ..limits import check_image_pixels, image_too_large
from .loader import warn_at
from .model import Scene, Texture

IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tga", ".bmp", ".tif", ".tiff", ".gif")
FLOAT_EXTENSIONS = (".exr", ".pfm", ".hdr")


class TextureLibrary:
    def __init__(self, scene: Scene):
        self.scene = scene
        self.index: dict[tuple, int | None] = {}

    def load(self, path, srgb: bool = True, where: tuple = (None, None)) -> int | None:
        """Index into scene.textures, or None (already warned) when the file can't be used."""
        path = Path(path)
        key = (str(path.resolve()) if path.exists() else str(path), bool(srgb))
        if key in self.index:
            return self.index[key]
        texture = None
        try:
            texture = Texture(path.stem, _read_rgba8(path, srgb, where), srgb=srgb, source=str(path))
        except FileNotFoundError:
            warn_at(*where, f"texture file not found: {path}; using the material's constant colour")
        except _Unreadable as e:
            warn_at(*where, f"cannot read texture {path} ({e}); using the material's constant colour")
        index = None
        if texture is not None:
            self.scene.textures.append(texture)
            index = len(self.scene.textures) - 1
        self.index[key] = index
        return index


class _Unreadable(Exception):
    pass


def _read_rgba8(path: Path, srgb: bool, where: tuple = (None, None)) -> np.ndarray:
    if not path.is_file():
        raise FileNotFoundError(path)
    ext = path.suffix.lower()
    if ext in FLOAT_EXTENSIONS:
        # A float texture: store it 8-bit, sRGB-encoded when the material wants sRGB
        # decoding (colour), linear otherwise.
        from ..tonemap import srgb_encode
        try:
            rgb = read_environment_image(path)
        except SceneError as e:  # unreadable, or over MAX_TEXTURE_PIXELS
            raise _Unreadable(e.message) from None
        rgb = np.clip(rgb, 0.0, 1.0)
        rgb = srgb_encode(rgb) if srgb else rgb
        rgba = np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), np.float32)], axis=2)
        return np.round(rgba * 255).astype(np.uint8)
    from PIL import Image, UnidentifiedImageError
    try:
        with _open_bounded(path, where) as img:
            img.load()
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):
                grey = (np.asarray(img, dtype=np.float64) / 65535.0 * 255).round().astype(np.uint8)
                return np.dstack([grey, grey, grey, np.full_like(grey, 255)])
            return np.asarray(img.convert("RGBA"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, ValueError) as e:
        raise _Unreadable(str(e)) from None
    except LimitError as e:
        raise _Unreadable(e.message) from None


def _open_bounded(path: Path, where: tuple):
    """pillow's lazy image (header read, no pixel decoded) within MAX_TEXTURE_PIXELS: a JPEG
    over it set to decode at 1/2, 1/4 or 1/8 (warned at `where`); any other image over it is
    a LimitError."""
    import warnings

    from PIL import Image

    from .. import limits

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # ours is the lower limit
        try:
            img = Image.open(path)
        except Image.DecompressionBombError as e:  # over pillow's own limit, 10x ours
            claimed = re.search(r"\((\d+) pixels\)", str(e))
            raise image_too_large(int(claimed.group(1)) if claimed else 0, what="a texture",
                                  limit_name="MAX_TEXTURE_PIXELS") from None
    width, height = img.size
    if img.format == "JPEG" and width * height > limits.MAX_TEXTURE_PIXELS:
        for scale in (2, 4, 8):  # the JPEG decoder's own reductions
            reduced = (-(-width // scale), -(-height // scale))
            if reduced[0] * reduced[1] <= limits.MAX_TEXTURE_PIXELS:
                img.draft(img.mode, reduced)
                warn_at(*(where if where[0] is not None else (path, None)),
                        f"texture {path} is {width}x{height} pixels, more than lift_gl.limits.MAX_TEXTURE_PIXELS"
                        f" = {limits.MAX_TEXTURE_PIXELS:,}; decoded at {img.size[0]}x{img.size[1]}")
                break
    try:
        check_image_pixels(*img.size, what="a texture", limit_name="MAX_TEXTURE_PIXELS")
    except LimitError:
        img.close()
        raise
    return img


def read_environment_image(path) -> np.ndarray:
    """Linear float32 RGB (H, W, 3), row 0 = top. Errors are SceneErrors naming the file."""
    path = Path(path)
    if not path.is_file():
        raise SceneError("environment map not found", path)
    ext = path.suffix.lower()
    if ext == ".hdr":
        try:
            return _read_rgbe(path)
        except LimitError as e:
            raise SceneError(f"cannot read environment map: {e.message}", path) from None
    if ext in (".exr", ".pfm"):
        from ..image_io import ImageError, read_image
        try:
            return read_image(path, limit_name="MAX_TEXTURE_PIXELS")
        except (ImageError, LimitError) as e:
            raise SceneError(f"cannot read environment map: {e.message}", path) from None
    if ext in IMAGE_EXTENSIONS:
        from ..tonemap import srgb_decode
        try:
            return srgb_decode(_read_rgba8(path, True)[..., :3].astype(np.float32) / 255.0).astype(np.float32)
        except _Unreadable as e:
            raise SceneError(f"cannot read environment map ({e})", path) from None
    raise SceneError(f"unsupported environment map format '{ext}' (use .exr, .pfm or .hdr)", path)


_RESOLUTION = re.compile(rb"^([-+])Y\s+(\d+)\s+([-+])X\s+(\d+)\s*$")


def _read_rgbe(path: Path) -> np.ndarray:
    """Radiance RGBE (.hdr / .pic): flat or new-style run-length encoded scanlines."""
    data = path.read_bytes()

    def bad(msg):
        return SceneError(f"not a readable Radiance .hdr file: {msg}", path)

    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise bad("missing '#?RADIANCE' header")
    pos = data.find(b"\n\n")
    if pos < 0:
        raise bad("no blank line after the header")
    header = data[:pos].split(b"\n")
    if any(line.startswith(b"FORMAT=") and b"32-bit_rle_rgbe" not in line for line in header):
        raise bad("only FORMAT=32-bit_rle_rgbe is supported")
    end = data.find(b"\n", pos + 2)
    m = _RESOLUTION.match(data[pos + 2:end])
    if m is None:
        raise bad("unsupported resolution line (expected '-Y H +X W')")
    height, width = int(m.group(2)), int(m.group(4))
    check_image_pixels(width, height, what="an environment map", limit_name="MAX_TEXTURE_PIXELS")
    flip_y, flip_x = m.group(1) == b"+", m.group(3) == b"-"
    buf = np.frombuffer(data, np.uint8, offset=end + 1)
    out = np.zeros((height, width, 4), np.uint8)
    i = 0
    try:
        for y in range(height):
            if 8 <= width < 32768 and buf[i] == 2 and buf[i + 1] == 2 and (int(buf[i + 2]) << 8 | int(buf[i + 3])) == width:
                i += 4
                for c in range(4):  # each channel run-length encoded separately
                    x = 0
                    while x < width:
                        count = int(buf[i])
                        i += 1
                        if count == 0 or x + (count - 128 if count > 128 else count) > width:
                            raise bad("corrupt run-length data")
                        if count > 128:
                            count -= 128
                            out[y, x:x + count, c] = buf[i]
                            i += 1
                        else:
                            out[y, x:x + count, c] = buf[i:i + count]
                            i += count
                        x += count
            else:  # flat scanline
                out[y] = buf[i:i + 4 * width].reshape(width, 4)
                i += 4 * width
    except (IndexError, ValueError):
        raise bad("truncated pixel data") from None
    e = out[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    rgb = (out[..., :3].astype(np.float64) + 0.5 * (e[..., None] > 0)) * scale[..., None]
    if flip_y:
        rgb = rgb[::-1]
    if flip_x:
        rgb = rgb[:, ::-1]
    return np.ascontiguousarray(rgb, dtype=np.float32)
