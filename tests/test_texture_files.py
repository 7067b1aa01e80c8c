"""Image files for scenes: the Radiance .hdr reader (flat and run-length encoded scanlines,
written here by an independent encoder), environment maps in other formats, and textures
that are missing or unreadable."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.errors import SceneError
from lift_gl.image_io import write_image
from lift_gl.scene.loader import SceneWarning
from lift_gl.scene.model import Scene
from lift_gl.scene.texture_files import TextureLibrary, read_environment_image


def rgbe_pixels(rgb: np.ndarray) -> np.ndarray:
    """Ward's shared-exponent encoding: mantissas m = v / 2^e * 256, e biased by 128."""
    m = rgb.max(axis=-1)
    mant, exp = np.frexp(m)  # m = mant * 2^exp, mant in [0.5, 1)
    scale = np.where(m > 1e-32, mant * 256.0 / np.where(m > 0, m, 1), 0.0)
    out = np.zeros(rgb.shape[:-1] + (4,), np.uint8)
    out[..., :3] = np.floor(rgb * scale[..., None]).astype(np.uint8)
    out[..., 3] = np.where(m > 1e-32, exp + 128, 0).astype(np.uint8)
    return out


def rle_channel(values: np.ndarray) -> bytes:
    """Runs of 3+ equal bytes as (128 + n, value), the rest as literal dumps (n, bytes...)."""
    out, i, n = bytearray(), 0, len(values)
    while i < n:
        run = 1
        while i + run < n and run < 127 and values[i + run] == values[i]:
            run += 1
        if run >= 3:
            out += bytes([128 + run, values[i]])
            i += run
            continue
        start = i
        while i < n and i - start < 128 and not (i + 2 < n and values[i] == values[i + 1] == values[i + 2]):
            i += 1
        out += bytes([i - start]) + bytes(values[start:i])
    return bytes(out)


def write_hdr(path, rgb: np.ndarray, rle: bool, flip_y: bool = False):
    h, w = rgb.shape[:2]
    px = rgbe_pixels(rgb[::-1] if flip_y else rgb)
    body = bytearray()
    for y in range(h):
        if rle:
            body += bytes([2, 2, w >> 8, w & 255])
            for c in range(4):
                body += rle_channel(px[y, :, c])
        else:
            body += px[y].tobytes()
    res = f"+Y {h} +X {w}" if flip_y else f"-Y {h} +X {w}"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + res.encode() + b"\n" + bytes(body))


@pytest.mark.parametrize("rle", [False, True], ids=["flat", "rle"])
def test_hdr_reader_decodes_rgbe(tmp_path, rle):
    rng = np.random.default_rng(0)
    h, w = 5, 40  # RLE needs 8 <= width < 32768
    rgb = np.exp(rng.normal(0, 3, size=(h, w, 3))).astype(np.float32)
    rgb[1, 5:30] = (2.0, 0.5, 0.25)  # long runs of equal pixels for the encoder
    rgb[2, :] = 0.0
    path = tmp_path / "sky.hdr"
    write_hdr(path, rgb, rle)
    got = read_environment_image(path)
    assert got.shape == (h, w, 3) and got.dtype == np.float32
    # RGBE keeps 8 bits of the largest channel: relative error below 1/256 of it (plus the
    # half-step offset of the decoder).
    tol = rgb.max(axis=-1, keepdims=True) / 128
    assert np.all(np.abs(got - rgb) <= tol)
    assert (got[2] == 0).all()


def test_hdr_bottom_up_rows_and_errors(tmp_path):
    rgb = np.zeros((3, 8, 3), np.float32)
    rgb[0] = 4.0  # the top row
    write_hdr(tmp_path / "up.hdr", rgb, rle=False, flip_y=True)
    np.testing.assert_allclose(read_environment_image(tmp_path / "up.hdr")[0], 4.0, rtol=1 / 128)
    bad = tmp_path / "bad.hdr"
    bad.write_bytes(b"#?RADIANCE\n\n-Z 3 +X 8\n")
    with pytest.raises(SceneError, match="resolution"):
        read_environment_image(bad)
    bad.write_bytes(b"P6 nope")
    with pytest.raises(SceneError, match="RADIANCE"):
        read_environment_image(bad)
    truncated = tmp_path / "short.hdr"
    write_hdr(truncated, rgb, rle=True)
    truncated.write_bytes(truncated.read_bytes()[:-10])
    with pytest.raises(SceneError, match="short.hdr"):
        read_environment_image(truncated)


def test_environment_formats_and_missing_files(tmp_path):
    img = np.linspace(0, 2, 4 * 8 * 3, dtype=np.float32).reshape(4, 8, 3)
    for ext in ("exr", "pfm"):
        write_image(tmp_path / f"e.{ext}", img)
        np.testing.assert_allclose(read_environment_image(tmp_path / f"e.{ext}"), img, rtol=1e-6)
    with pytest.raises(SceneError, match="not found"):
        read_environment_image(tmp_path / "none.exr")
    (tmp_path / "x.tiff2").write_text("?")
    with pytest.raises(SceneError, match="unsupported environment map format"):
        read_environment_image(tmp_path / "x.tiff2")


def test_texture_library_loads_each_file_once_and_reports_bad_ones_once(tmp_path):
    from PIL import Image
    Image.fromarray(np.full((3, 2), 7, np.uint8), mode="L").save(tmp_path / "grey.png")
    (tmp_path / "broken.jpg").write_bytes(b"not a jpeg")
    scene = Scene(camera=None)
    lib = TextureLibrary(scene)
    where = (tmp_path / "scene.x", 12)
    assert lib.load(tmp_path / "grey.png", True, where) == lib.load(tmp_path / "grey.png", True, where) == 0
    np.testing.assert_array_equal(scene.textures[0].pixels, np.dstack([np.full((3, 2), 7)] * 3 + [np.full((3, 2), 255)]))
    with pytest.warns(SceneWarning, match=r"scene\.x:12: cannot read texture .*broken\.jpg") as record:
        assert lib.load(tmp_path / "broken.jpg", True, where) is None
        assert lib.load(tmp_path / "broken.jpg", True, where) is None
    assert len(record) == 1
    with pytest.warns(SceneWarning, match=r"texture file not found: .*gone\.tga"):
        assert lib.load(tmp_path / "gone.tga", True, where) is None
    assert len(scene.textures) == 1
