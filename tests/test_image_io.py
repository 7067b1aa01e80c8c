"""Image files: round trips for each format, PFM orientation, PNG sRGB, reference EXRs."""
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from lift_gl.image_io import ImageError, read_image, write_image
from lift_gl.tonemap import srgb_decode

REFS = Path(__file__).resolve().parent.parent.parent / "shared" / "refs"


def _gradient(h=5, w=7):
    """An image whose every pixel differs, so flips and transposes show up."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.stack([x / w, y / h, 0.25 + x * y], axis=-1).astype(np.float32)


@pytest.mark.parametrize("ext", [".exr", ".pfm", ".npy"])
def test_float_round_trip_is_exact(tmp_path, ext):
    img = _gradient() * 37.5
    img[0, 0] = [0.0, 1e-30, 65504.0 * 4]  # tiny and beyond-half values survive in float32
    path = write_image(tmp_path / f"img{ext}", img)
    back = read_image(path)
    assert back.dtype == np.float32 and back.shape == img.shape
    np.testing.assert_array_equal(back, img)


def test_exr_half_round_trip(tmp_path):
    import OpenEXR

    img = _gradient()
    path = write_image(tmp_path / "half.exr", img, half=True)
    with OpenEXR.File(str(path)) as exr:
        assert exr.channels()["RGB"].pixels.dtype == np.float16
    back = read_image(path)
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, img.astype(np.float16).astype(np.float32))


def test_pfm_is_little_endian_bottom_row_first(tmp_path):
    img = _gradient(h=3, w=2)
    path = write_image(tmp_path / "img.pfm", img)
    data = path.read_bytes()
    header = b"PF\n2 3\n-1.0\n"
    assert data.startswith(header)
    first_row_in_file = np.frombuffer(data, dtype="<f4", count=2 * 3, offset=len(header))
    np.testing.assert_array_equal(first_row_in_file.reshape(2, 3), img[-1])  # bottom row
    assert len(data) == len(header) + 3 * 2 * 3 * 4


def test_pfm_reads_big_endian_and_grey(tmp_path):
    rows_bottom_up = np.array([[1.0, 2.0], [3.0, 4.0]], dtype=">f4")  # grey 'Pf'
    path = tmp_path / "grey.pfm"
    path.write_bytes(b"Pf\n2 2\n1.0\n" + rows_bottom_up.tobytes())
    img = read_image(path)
    assert img.shape == (2, 2, 3)
    np.testing.assert_array_equal(img[..., 0], [[3.0, 4.0], [1.0, 2.0]])  # row 0 = top
    np.testing.assert_array_equal(img[..., 0], img[..., 2])


def test_pfm_truncated_is_a_clear_error(tmp_path):
    path = tmp_path / "short.pfm"
    path.write_bytes(b"PF\n4 4\n-1.0\n" + b"\0" * 10)
    with pytest.raises(ImageError, match="short.pfm.*too short"):
        read_image(path)


def test_png_decodes_srgb_to_linear(tmp_path):
    encoded = np.full((2, 3, 3), 128, dtype=np.uint8)
    encoded[1, 2] = [0, 255, 10]
    path = tmp_path / "known.png"
    Image.fromarray(encoded, mode="RGB").save(path)
    img = read_image(path)
    assert img.dtype == np.float32 and img.shape == (2, 3, 3)
    assert img[0, 0, 0] == pytest.approx(0.215861, abs=1e-5)  # ((128/255 + .055)/1.055)^2.4
    np.testing.assert_allclose(img[1, 2], [0.0, 1.0, 10 / 255 / 12.92], atol=1e-6)


def test_png_write_tone_maps_and_encodes(tmp_path):
    img = _gradient() / 40.0  # within [0, 1]
    path = write_image(tmp_path / "img.png", img, tonemap="clamp")
    with Image.open(path) as png:
        assert png.mode == "RGB" and png.size == (7, 5)
    back = read_image(path)
    # 8-bit quantisation: half a step in the encoded domain.
    from lift_gl.tonemap import srgb_encode

    np.testing.assert_allclose(srgb_encode(back), srgb_encode(img), atol=0.5 / 255 + 1e-6)
    assert back[0, 0, 0] < back[0, -1, 0]  # orientation: x grows to the right
    assert back[0, 0, 1] < back[-1, 0, 1]  # y grows downwards (row 0 = top)


def test_png_exposure_and_default_aces(tmp_path):
    img = np.full((1, 1, 3), 1.0, dtype=np.float32)
    write_image(tmp_path / "a.png", img)
    write_image(tmp_path / "b.png", img, exposure=-1.0)
    a = np.asarray(Image.open(tmp_path / "a.png"))[0, 0, 0]
    b = np.asarray(Image.open(tmp_path / "b.png"))[0, 0, 0]
    # ACES(1) = 2.54 / 3.16 = 0.8038 -> sRGB 0.9082 -> 231.6 -> 232
    assert a == 232 and b < a


def test_grey_and_rgba_inputs_become_rgb(tmp_path):
    grey = np.arange(6, dtype=np.float32).reshape(2, 3)
    back = read_image(write_image(tmp_path / "g.npy", grey))
    assert back.shape == (2, 3, 3)
    np.testing.assert_array_equal(back[..., 1], grey)
    rgba = np.ones((2, 2, 4), dtype=np.float32)
    assert read_image(write_image(tmp_path / "a.exr", rgba)).shape == (2, 2, 3)


def test_unknown_extension_names_the_file(tmp_path):
    with pytest.raises(ImageError, match=r"picture\.tga.*\.png"):
        write_image(tmp_path / "picture.tga", np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ValueError, match=r"noext"):
        read_image(tmp_path / "noext")


def test_missing_file_and_bad_shape(tmp_path):
    with pytest.raises(ImageError, match="missing.exr"):
        read_image(tmp_path / "missing.exr")
    with pytest.raises(ImageError, match="shape"):
        write_image(tmp_path / "x.npy", np.zeros((2, 2, 2), np.float32))


def test_parent_folders_are_created(tmp_path):
    path = write_image(tmp_path / "a" / "b" / "img.pfm", np.zeros((1, 1, 3), np.float32))
    assert path.is_file()


@pytest.mark.skipif(not (REFS / "lift" / "cornell-box.exr").is_file(),
                    reason="shared reference images (../shared/refs) not present")
def test_read_lift_reference_half_exr():
    img = read_image(REFS / "lift" / "cornell-box.exr")
    assert img.shape == (1024, 1024, 3) and img.dtype == np.float32
    assert np.all(np.isfinite(img)) and img.min() >= 0
    # The Cornell box's left wall is red, its right wall green.
    left, right = img[512, 40], img[512, -40]
    assert left[0] > left[1] and right[1] > right[0]


@pytest.mark.skipif(not (REFS / "mitsuba" / "cbox" / "reference.exr").is_file(),
                    reason="shared reference images (../shared/refs) not present")
def test_read_mitsuba_reference_matches_its_npy():
    img = read_image(REFS / "mitsuba" / "cbox" / "reference.exr")
    ref = np.load(REFS / "mitsuba" / "cbox" / "reference.npy")
    assert img.shape == (128, 128, 3)
    np.testing.assert_array_equal(img, ref)
