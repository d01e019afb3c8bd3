"""Image I/O round trips, the sRGB curves, and every reader's errors."""
import os

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from patchlight.errors import PatchlightError
from patchlight.imaging.color import linear_to_srgb, srgb_to_linear
from patchlight.imaging.io import (ORIENTATION, ORIENTATION_KEY, atomic_path, decode_image, encode_png,
                                   read_environment, read_exr, read_hdr, read_image, write_exr, write_hdr,
                                   write_png)


def asymmetric_rgb(h=6, w=10, scale=5.0) -> np.ndarray:
    """Smooth but orientation-revealing test image: red grows down, green grows right."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.stack([y / h * scale, x / w * scale, np.full_like(x, 0.25)], axis=-1)


# ----------------------------------------------------------------------------- sRGB

def test_srgb_curve_known_values_and_inverse():
    assert srgb_to_linear(np.float32(1.0)) == pytest.approx(1.0)
    assert srgb_to_linear(0.5) == pytest.approx(0.21404114, rel=1e-7)
    assert srgb_to_linear(0.04045) == pytest.approx(0.04045 / 12.92)
    assert linear_to_srgb(0.0031308) == pytest.approx(0.0031308 * 12.92)
    assert linear_to_srgb(0.18) == pytest.approx(0.4613561, rel=1e-6)
    c = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(c)), c, atol=1e-12)
    assert srgb_to_linear(np.ones(3, np.float32)).dtype == np.float32
    assert linear_to_srgb([0.5]).dtype == np.float64


def test_srgb_curve_is_continuous_at_the_knee():
    below, above = srgb_to_linear(0.04045 - 1e-9), srgb_to_linear(0.04045 + 1e-9)
    assert abs(above - below) < 1e-7


# ----------------------------------------------------------------------------- atomic writes

def test_atomic_path_replaces_on_success(tmp_path):
    target = tmp_path / "out.png"
    target.write_bytes(b"old")
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".png" and tmp != target
        tmp.write_bytes(b"new")
        assert target.read_bytes() == b"old"
    assert target.read_bytes() == b"new"
    assert os.listdir(tmp_path) == ["out.png"]


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_atomic_path_leaves_nothing_when_the_body_raises(tmp_path, error):
    target = tmp_path / "out.exr"
    with pytest.raises(error):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"half written")
            raise error("stop")
    assert os.listdir(tmp_path) == []


def test_atomic_path_keeps_the_old_file_when_the_body_raises(tmp_path):
    target = tmp_path / "out.hdr"
    target.write_bytes(b"old")
    with pytest.raises(ValueError):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"new")
            raise ValueError
    assert target.read_bytes() == b"old" and os.listdir(tmp_path) == ["out.hdr"]


def test_atomic_path_refuses_a_missing_directory(tmp_path):
    with pytest.raises(PatchlightError, match="does not exist"):
        with atomic_path(tmp_path / "nowhere" / "x.png"):
            pass


# ----------------------------------------------------------------------------- EXR

def test_exr_round_trip_is_exact_and_row_zero_is_the_top(tmp_path):
    rgb = asymmetric_rgb()
    rgb[0, 0] = [1e-30, 65504.0, 3e5]  # beyond half range: stays float32
    path = tmp_path / "lightmap.exr"
    write_exr(path, rgb, metadata={"exposure": "1.5"})
    back = read_exr(path)
    assert back.dtype == np.float32 and back.shape == rgb.shape
    np.testing.assert_array_equal(back, rgb)
    header = OpenEXR.File(str(path), header_only=True).header()
    assert header[ORIENTATION_KEY] == ORIENTATION == "row 0 is v=0 (glTF UV convention)"
    assert header["exposure"] == "1.5"
    # Row 0 of the file is the first scanline (dataWindow starts at y = 0, increasing y).
    assert header["lineOrder"] == OpenEXR.INCREASING_Y
    assert os.listdir(tmp_path) == ["lightmap.exr"]


def test_exr_reader_takes_half_and_luminance_files(tmp_path):
    half = asymmetric_rgb().astype(np.float16)
    OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": half}).write(str(tmp_path / "half.exr"))
    np.testing.assert_array_equal(read_exr(tmp_path / "half.exr"), half.astype(np.float32))
    grey = np.arange(12, dtype=np.float32).reshape(3, 4)
    OpenEXR.File({"type": OpenEXR.scanlineimage}, {"Y": grey}).write(str(tmp_path / "grey.exr"))
    np.testing.assert_array_equal(read_exr(tmp_path / "grey.exr"), np.repeat(grey[..., None], 3, axis=2))


# ----------------------------------------------------------------------------- PNG / JPEG

def test_png_round_trip_rgb_and_rgba(tmp_path):
    rng = np.random.default_rng(1)
    for channels in (3, 4):
        pixels = rng.integers(0, 256, (5, 7, channels), dtype=np.uint8)
        path = tmp_path / f"img{channels}.png"
        write_png(path, pixels)
        np.testing.assert_array_equal(np.asarray(Image.open(path)), pixels)
        back = read_image(path)
        assert back.dtype == np.float32 and back.shape == pixels.shape
        np.testing.assert_array_equal(np.round(back * 255).astype(np.uint8), pixels)
    assert sorted(os.listdir(tmp_path)) == ["img3.png", "img4.png"]


def test_read_image_jpeg_palette_and_sixteen_bit(tmp_path):
    Image.new("RGB", (4, 3), (200, 100, 50)).save(tmp_path / "flat.jpg", quality=95)
    np.testing.assert_allclose(read_image(tmp_path / "flat.jpg")[1, 1], np.array([200, 100, 50]) / 255, atol=3 / 255)
    palette = Image.new("P", (2, 2))
    palette.putpalette([10, 20, 30] * 256)
    palette.save(tmp_path / "pal.png")
    np.testing.assert_allclose(read_image(tmp_path / "pal.png")[0, 0], np.array([10, 20, 30]) / 255, atol=1e-7)
    deep = Image.fromarray(np.array([[0, 65535]], np.uint16))
    deep.save(tmp_path / "deep.png")
    np.testing.assert_allclose(read_image(tmp_path / "deep.png")[0, :, 0], [0.0, 1.0])


def test_encode_png_refuses_float_pixels():
    with pytest.raises(ValueError):
        encode_png(np.zeros((2, 2, 3), np.float32))


# ----------------------------------------------------------------------------- Radiance .hdr

@pytest.mark.parametrize("rle", [True, False])
def test_hdr_round_trip_within_rgbe_precision(tmp_path, rle):
    rgb = asymmetric_rgb(7, 40, scale=1000.0) + 1e-3
    rgb[3, 5:30] = [2.0, 0.5, 0.125]  # a long run for the run-length coder
    path = tmp_path / "sky.hdr"
    write_hdr(path, rgb, rle=rle)
    back = read_hdr(path)
    assert back.shape == rgb.shape and back.dtype == np.float32
    peak = rgb.max(axis=-1, keepdims=True)
    assert np.max(np.abs(back - rgb) / peak) <= 1 / 256
    assert np.all(back[3, 5:30] == back[3, 5])  # the run decodes to one colour
    assert back[6, 0, 0] > back[0, 0, 0] and back[0, 39, 1] > back[0, 0, 1]  # row 0 top, column 0 left


def test_hdr_run_length_coding_shrinks_flat_images(tmp_path):
    flat = np.full((4, 640, 3), 0.5, np.float32)
    write_hdr(tmp_path / "rle.hdr", flat)
    write_hdr(tmp_path / "flat.hdr", flat, rle=False)
    assert (tmp_path / "rle.hdr").stat().st_size < (tmp_path / "flat.hdr").stat().st_size / 10
    np.testing.assert_array_equal(read_hdr(tmp_path / "rle.hdr"), read_hdr(tmp_path / "flat.hdr"))


def hdr_file(path, resolution: bytes, body: bytes) -> None:
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n" + resolution + b"\n" + body)


def test_hdr_reader_decodes_hand_made_scanlines(tmp_path):
    """Bytes written by hand, independent of our writer: one RLE scanline, one flat file."""
    # 1 x 8, new-style RLE: R = run of 8 x 128; G = 8 literals; B = run 0; E = run 129.
    body = bytes([2, 2, 0, 8, 128 + 8, 128, 8, 0, 16, 32, 64, 128, 160, 192, 255, 128 + 8, 0, 128 + 8, 129])
    hdr_file(tmp_path / "rle.hdr", b"-Y 1 +X 8", body)
    img = read_hdr(tmp_path / "rle.hdr")
    scale = 2.0 ** (129 - 136)
    np.testing.assert_array_equal(img[0, :, 0], np.full(8, 128.5 * scale, np.float32))
    np.testing.assert_array_equal(img[0, :, 1], (np.array([0, 16, 32, 64, 128, 160, 192, 255]) + 0.5) * scale)
    np.testing.assert_array_equal(img[0, :, 2], np.full(8, 0.5 * scale, np.float32))
    # 2 x 2 flat (too narrow for RLE) with "+Y": bottom-to-top rows; exponent 0 is black.
    flat = bytes([128, 0, 0, 129, 0, 128, 0, 129, 0, 0, 128, 129, 9, 9, 9, 0])
    hdr_file(tmp_path / "flat.hdr", b"+Y 2 +X 2", flat)
    img = read_hdr(tmp_path / "flat.hdr")
    one = 128.5 * scale
    np.testing.assert_array_equal(img[1, 0], [one, 0.5 * scale, 0.5 * scale])  # first stored row is the bottom
    np.testing.assert_array_equal(img[0, 1], [0, 0, 0])


def test_hdr_reader_expands_old_style_runs(tmp_path):
    pixel = bytes([128, 64, 32, 130])
    hdr_file(tmp_path / "old.hdr", b"-Y 1 +X 5", pixel + bytes([1, 1, 1, 4]))
    img = read_hdr(tmp_path / "old.hdr")
    np.testing.assert_array_equal(img, np.broadcast_to(img[0, 0], (1, 5, 3)))


@pytest.mark.parametrize("content, message", [
    (b"\x89PNG not an hdr", "not a Radiance .hdr"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0", "unsupported .hdr format"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+X 1 -Y 1\n\0\0\0\0", "resolution line"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", "truncated .hdr header"),
    (b"#?RADIANCE\n\n-Y 4 +X 16\n" + bytes([2, 2, 0, 16, 128 + 16]), "truncated pixel data"),
    (b"#?RADIANCE\n\n-Y 1 +X 16\n" + bytes([2, 2, 0, 15]) + bytes(64), "scanline length mismatch"),
    (b"#?RADIANCE\n\n-Y 1 +X 8\n" + bytes([2, 2, 0, 8, 128 + 9, 1]) + bytes(64), "corrupt run-length"),
])
def test_hdr_reader_errors_name_the_file(tmp_path, content, message):
    path = tmp_path / "bad.hdr"
    path.write_bytes(content)
    with pytest.raises(PatchlightError, match=message) as info:
        read_hdr(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


# ----------------------------------------------------------------------------- environments and errors

def test_read_environment_by_suffix(tmp_path):
    rgb = asymmetric_rgb(4, 8)
    write_exr(tmp_path / "env.exr", rgb)
    write_hdr(tmp_path / "env.hdr", rgb)
    np.testing.assert_array_equal(read_environment(tmp_path / "env.exr"), rgb)
    from_hdr = read_environment(tmp_path / "env.hdr")
    assert np.max(np.abs(from_hdr - rgb) / rgb.max(axis=-1, keepdims=True)) <= 1 / 256
    (tmp_path / "env.png").write_bytes(encode_png(np.zeros((2, 2, 3), np.uint8)))
    with pytest.raises(PatchlightError, match=r"env\.png: environment maps must be \.exr or \.hdr"):
        read_environment(tmp_path / "env.png")


def test_read_environment_refuses_nan_and_clamps_negatives(tmp_path):
    rgb = asymmetric_rgb(2, 2)
    rgb[0, 0, 0] = -0.5
    write_exr(tmp_path / "neg.exr", rgb)
    assert read_environment(tmp_path / "neg.exr").min() == 0.0
    rgb[1, 1, 1] = np.nan
    with pytest.raises(PatchlightError, match="NaN"):  # patchlight writes none
        write_exr(tmp_path / "nan.exr", rgb)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": rgb}).write(str(tmp_path / "nan.exr"))
    with pytest.raises(PatchlightError, match="NaN"):
        read_environment(tmp_path / "nan.exr")


@pytest.mark.parametrize("reader, name", [(read_exr, "x.exr"), (read_hdr, "x.hdr"), (read_image, "x.png"),
                                          (read_environment, "x.exr")])
def test_readers_report_missing_and_corrupt_files(tmp_path, reader, name):
    path = tmp_path / name
    with pytest.raises(PatchlightError, match="file not found") as info:
        reader(path)
    assert str(info.value).startswith(str(path))
    path.write_bytes(np.random.default_rng(0).bytes(300))
    with pytest.raises(PatchlightError) as info:
        reader(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)
    with pytest.raises(PatchlightError, match="is a directory"):
        reader(tmp_path)


def test_truncated_exr_and_png(tmp_path):
    write_exr(tmp_path / "a.exr", asymmetric_rgb(32, 32))
    data = (tmp_path / "a.exr").read_bytes()
    (tmp_path / "cut.exr").write_bytes(data[: len(data) // 3])
    with pytest.raises(PatchlightError, match="cut.exr"):
        read_exr(tmp_path / "cut.exr")
    png = encode_png(np.zeros((16, 16, 3), np.uint8))
    with pytest.raises(PatchlightError, match="where: not a readable PNG/JPEG"):
        decode_image(png[: len(png) // 2], "where")
