"""Reading and writing images, chosen by file extension.

Images in lift-gl are numpy float32 arrays of shape H x W x 3, linear RGB, row 0 at the top.

| extension | write                                       | read                          |
| --------- | ------------------------------------------- | ----------------------------- |
| ``.png``  | tone-mapped (``tonemap.py``), 8-bit sRGB    | sRGB decoded to linear        |
| ``.exr``  | linear float32 (or half with ``half=True``) | half or float, to float32     |
| ``.pfm``  | linear float32, little-endian               | either endianness, RGB or grey |
| ``.npy``  | linear float32                              | any float array, to float32   |

EXR goes through the ``OpenEXR`` package (v3 numpy API, PyPI wheels). PFM is written here:
header ``PF\\n<width> <height>\\n<scale>\\n``, a negative scale meaning little-endian, then
the rows from the bottom of the image to the top.

Every file is written under a temporary name and renamed when complete (lift_gl/atomic.py).
A read takes the image's size from its header first and refuses more than
lift_gl.limits.MAX_IMAGE_PIXELS (or the limit named by ``limit_name``) before decoding.
"""
from __future__ import annotations

import os
import sys
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

from .atomic import atomic_path
from .errors import LiftError
from .limits import check_image_pixels
from .tonemap import srgb_decode, to_srgb8

FORMATS = (".png", ".exr", ".pfm", ".npy")


class ImageError(LiftError, ValueError):
    """An image file that cannot be read or written (unknown format, bad contents)."""


# ---- helpers -------------------------------------------------------------------------------

def _extension(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise ImageError(
            f"unknown image format {path.suffix or '(no extension)'!r}; "
            f"use one of {', '.join(FORMATS)}",
            path,
        )
    return ext


def _as_rgb(image, path) -> np.ndarray:
    """H x W, H x W x 1, H x W x 3 or H x W x 4 (alpha dropped) -> contiguous float32 H x W x 3."""
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or arr.shape[2] not in (1, 3, 4) or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ImageError(f"expected an H x W x 3 image, got an array of shape {arr.shape}", path)
    if arr.shape[2] == 1:
        arr = np.repeat(arr, 3, axis=2)
    elif arr.shape[2] == 4:
        arr = arr[:, :, :3]
    return np.ascontiguousarray(arr, dtype=np.float32)


# ---- write ---------------------------------------------------------------------------------

def write_image(path, image, *, exposure: float = 0.0, tonemap: str = "aces",
                half: bool = False) -> Path:
    """Write a linear float RGB image (H x W x 3, row 0 at the top); format by extension.

    ``exposure`` (stops) and ``tonemap`` (``aces``, ``reinhard``, ``clamp``) apply to ``.png``
    only; float formats store the linear values unchanged. ``half=True`` stores ``.exr`` as
    half float. Missing parent folders are created. Returns the path.
    """
    path = Path(path)
    ext = _extension(path)
    rgb = _as_rgb(image, path)
    with atomic_path(path) as tmp:
        if ext == ".png":
            _write_png(tmp, rgb, exposure, tonemap)
        elif ext == ".exr":
            _write_exr(tmp, rgb, half)
        elif ext == ".pfm":
            _write_pfm(tmp, rgb)
        else:
            np.save(tmp, rgb)
    return path


def write_srgb8(path, srgb8: np.ndarray) -> Path:
    """Write an already display-encoded uint8 (H, W, 3) image, e.g. from the tonemap pass."""
    from PIL import Image

    path = Path(path)
    if _extension(path) != ".png":
        raise ImageError("display images are written as .png", path)
    with atomic_path(path) as tmp:
        Image.fromarray(np.ascontiguousarray(srgb8, dtype=np.uint8), mode="RGB").save(tmp)
    return path


def _write_png(path: Path, rgb: np.ndarray, exposure: float, operator: str) -> None:
    from PIL import Image

    Image.fromarray(to_srgb8(rgb, exposure=exposure, operator=operator), mode="RGB").save(path)


def _write_exr(path: Path, rgb: np.ndarray, half: bool) -> None:
    import OpenEXR

    pixels = np.ascontiguousarray(rgb, dtype=np.float16 if half else np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": pixels}) as exr:
        exr.write(str(path))


def _write_pfm(path: Path, rgb: np.ndarray) -> None:
    height, width, _ = rgb.shape
    bottom_to_top = np.ascontiguousarray(rgb[::-1], dtype="<f4")
    with open(path, "wb") as f:
        f.write(f"PF\n{width} {height}\n-1.0\n".encode("ascii"))
        f.write(bottom_to_top.tobytes())


# ---- read ----------------------------------------------------------------------------------

def read_image(path, *, limit_name: str = "MAX_IMAGE_PIXELS") -> np.ndarray:
    """Read an image as linear float32 RGB, H x W x 3, row 0 at the top; format by extension.

    PNG is decoded from sRGB to linear (no inverse tone mapping). Grey images become three
    equal channels; alpha is dropped. An image whose header claims more pixels than the
    limit `limit_name` of lift_gl.limits is refused (LimitError) before it is decoded.
    """
    path = Path(path)
    ext = _extension(path)
    if not path.is_file():
        raise ImageError("no such image file", path)
    try:
        if ext == ".png":
            return _read_png(path, limit_name)
        if ext == ".exr":
            return _read_exr(path, limit_name)
        if ext == ".pfm":
            return _read_pfm(path, limit_name)
        return _as_rgb(_read_npy(path, limit_name), path)
    except LiftError:
        raise
    except Exception as exc:  # a library's own error about a corrupt file
        raise ImageError(f"cannot read image: {exc}", path) from exc


def _read_png(path: Path, limit_name: str) -> np.ndarray:
    import warnings

    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # ours is checked below
        img = Image.open(path)
    with img:
        check_image_pixels(*img.size, path, limit_name=limit_name)
        if img.mode in ("I;16", "I;16B", "I;16L", "I"):
            encoded = np.asarray(img, dtype=np.float32) / 65535.0
        else:
            encoded = np.asarray(img.convert("RGB"), dtype=np.float32) / 255.0
    return srgb_decode(_as_rgb(encoded, path))


def _read_exr(path: Path, limit_name: str) -> np.ndarray:
    import OpenEXR

    # The OpenEXR module prints a corrupt file's problems (to stdout, and the C library to
    # stderr) and may go on with what it could read: what it prints is kept and is the error.
    failure = None
    with _library_output() as output:
        try:
            with OpenEXR.File(str(path), header_only=True) as exr:
                low, high = exr.header()["dataWindow"]
            width, height = int(high[0]) - int(low[0]) + 1, int(high[1]) - int(low[1]) + 1
            check_image_pixels(width, height, path, limit_name=limit_name)
            with OpenEXR.File(str(path)) as exr:
                channels = {name: channel.pixels for name, channel in exr.channels().items()}
        except LiftError:
            raise
        except Exception as exc:  # the library's own error about a corrupt file
            failure = exc
    if failure is not None or output.text:
        raise ImageError(f"not a readable EXR file: {output.text.splitlines()[0] if output.text else failure}",
                         path)
    for name in ("RGB", "RGBA", "Y"):
        if name in channels:
            return _as_rgb(channels[name], path)
    raise ImageError(f"EXR has no RGB, RGBA or Y channels (it has: {', '.join(sorted(channels))})", path)


def _read_pfm(path: Path, limit_name: str) -> np.ndarray:
    data = path.read_bytes()
    # Header: three whitespace-separated tokens after the magic, then exactly one whitespace.
    tokens, pos = [], 0
    while len(tokens) < 4:
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace():
            pos += 1
        if start == pos:
            raise ImageError("truncated PFM header", path)
        tokens.append(data[start:pos].decode("ascii", errors="replace"))
    pos += 1  # the single whitespace character that ends the header
    magic, width_s, height_s, scale_s = tokens
    if magic not in ("PF", "Pf"):
        raise ImageError(f"not a PFM file (magic {magic!r}, expected 'PF' or 'Pf')", path)
    try:
        width, height, scale = int(width_s), int(height_s), float(scale_s)
    except ValueError:
        raise ImageError(f"bad PFM header: {width_s!r} {height_s!r} {scale_s!r}", path) from None
    if width <= 0 or height <= 0 or scale == 0.0:
        raise ImageError(f"bad PFM header: size {width}x{height}, scale {scale}", path)
    check_image_pixels(width, height, path, limit_name=limit_name)
    channels = 3 if magic == "PF" else 1
    dtype = np.dtype("<f4" if scale < 0 else ">f4")
    count = width * height * channels
    if len(data) - pos < count * 4:
        raise ImageError(
            f"PFM data too short: {width}x{height}x{channels} needs {count * 4} bytes, "
            f"file has {len(data) - pos}",
            path,
        )
    pixels = np.frombuffer(data, dtype=dtype, count=count, offset=pos)
    pixels = pixels.reshape(height, width, channels)[::-1]  # stored bottom row first
    return _as_rgb(pixels.astype(np.float32), path)


def _read_npy(path: Path, limit_name: str) -> np.ndarray:
    """An .npy file, mapped first (header read, no data) so that its shape is checked before
    the data is read."""
    mapped = np.load(path, mmap_mode="r", allow_pickle=False)
    if mapped.dtype.kind not in "biuf":  # complex, strings, records: no pixel values
        raise ImageError(f"an .npy of {mapped.dtype} values; an image's are real numbers", path)
    if mapped.ndim >= 2:
        check_image_pixels(int(mapped.shape[1]), int(mapped.shape[0]), path, limit_name=limit_name)
    with np.errstate(over="ignore"):  # float64 beyond float32's range becomes Inf: judged as non-finite later
        return np.array(mapped, dtype=np.float32)


# ---- what a library prints --------------------------------------------------------------

class _Output:
    text = ""  # what was printed, once the capture has ended


@contextmanager
def _library_output():
    """Capture what is printed to stdout and stderr, by Python code and by C code (file
    descriptors 1 and 2), while a library reads a file; the text is in .text afterwards."""
    import io
    import tempfile

    sys.stdout.flush()
    sys.stderr.flush()
    output = _Output()
    python_text = io.StringIO()
    with tempfile.TemporaryFile() as c_text:
        saved = os.dup(1), os.dup(2)
        os.dup2(c_text.fileno(), 1)
        os.dup2(c_text.fileno(), 2)
        try:
            with redirect_stdout(python_text), redirect_stderr(python_text):
                yield output
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            c_text.seek(0)
            output.text = (python_text.getvalue() + c_text.read().decode("utf-8", errors="replace")).strip()
