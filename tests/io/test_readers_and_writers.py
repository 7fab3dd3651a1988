"""liff.io readers and writers: views folders, ESLF, mosaics, .npy/.npz, read_light_field."""

from __future__ import annotations

import os
import re
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

import liff
from lfhelpers import zero_png
from liff import io

COTTON = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "hci" / "cotton"


def coded_lf(shape, dtype=np.uint8, seed=0):
    """Random light field (T, S, V, U[, C]) whose pixel (0, 0) of view (t, s) is t * S + s,
    so a view put in the wrong place shows."""
    info = np.iinfo(dtype)
    lf = np.random.default_rng(seed).integers(info.min, info.max, shape, dtype=dtype, endpoint=True)
    T, S = shape[:2]
    lf[:, :, 0, 0] = (np.arange(T * S).reshape(T, S) if len(shape) == 4 else
                      np.arange(T * S).reshape(T, S, 1))
    return lf


def raises_naming(path, expected, call, *args, **kwargs):
    """Asserts ``call`` raises a ValueError whose message names ``path`` and matches
    ``expected`` (a regex for the expectation it states); returns the message."""
    with pytest.raises(ValueError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert str(path) in message, message
    assert re.search(expected, message), message
    return message


def write_grey_alpha_png(path: Path, image: np.ndarray) -> None:
    """PNG of colour type 4 (grey + alpha, 8 bit), which cv2.imwrite cannot write."""
    height, width = image.shape[:2]
    raw = b"".join(b"\x00" + image[row].tobytes() for row in range(height))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", width, height, 8, 4, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


# ---------------------------------------------------------------- folders of views

@pytest.mark.parametrize("dtype, channels", [(np.uint8, ()), (np.uint8, (3,)), (np.uint8, (4,)),
                                             (np.uint16, ()), (np.uint16, (3,))])
def test_views_round_trip(tmp_path, dtype, channels):
    lf = coded_lf((2, 3, 6, 7) + channels, dtype)
    paths = io.write_views(tmp_path / "v", lf)
    assert [Path(p).name for p in paths[:2]] == ["view_00_00.png", "view_00_01.png"]
    result = io.read_views(tmp_path / "v")
    assert result.format == "views" and result.source == str(tmp_path / "v")
    assert result.light_field.dtype == dtype
    np.testing.assert_array_equal(result.light_field, lf)
    assert result.metadata["grid"] == (2, 3) and result.metadata["first_index"] == (0, 0)
    assert result.metadata["missing"] == [] and result.metadata["added_alpha"] is False
    assert result.metadata["files"][1][2] == "view_01_02.png"


def test_views_one_based_unpadded_names(tmp_path):
    """1-based, not zero-padded, 11 columns: 'scene_1_10' must not sort before 'scene_1_2'."""
    lf = coded_lf((2, 11, 4, 5))
    io.write_views(tmp_path, lf, pattern="scene_{t}_{s}.png")  # 0-based, unpadded
    for path in sorted(tmp_path.iterdir(), reverse=True):  # rename to 1-based
        t, s = map(int, re.findall(r"\d+", path.name))
        path.rename(tmp_path / f"tmp_{t + 1}_{s + 1}.png")
    result = io.read_views(tmp_path)
    assert result.metadata["first_index"] == (1, 1)
    np.testing.assert_array_equal(result.light_field, lf)


def test_views_stanford_gantry_and_tif_names(tmp_path):
    lf = coded_lf((3, 2, 5, 5, 3), np.uint16)
    rng = np.random.default_rng(1)
    for t in range(3):
        for s in range(2):
            x, y = rng.normal(scale=900, size=2)
            cv2.imwrite(str(tmp_path / f"out_{t:02d}_{s:02d}_{x:.6f}_{y:.6f}.png"), lf[t, s])
    (tmp_path / "README.txt").write_text("not a view")
    cv2.imwrite(str(tmp_path / "thumbnail.png"), lf[0, 0])  # no indices: ignored
    np.testing.assert_array_equal(io.read_views(tmp_path).light_field, lf)

    tif = tmp_path / "tif"
    io.write_views(tif, lf, pattern="{t}_{s}.tif")
    result = io.read_light_field(tif)
    assert result.format == "views" and result.light_field.dtype == np.uint16
    np.testing.assert_array_equal(result.light_field, lf)


def test_views_grid_override(tmp_path):
    lf = coded_lf((2, 2, 4, 4))
    io.write_views(tmp_path, lf)
    np.testing.assert_array_equal(io.read_views(tmp_path, grid=(2, 2)).light_field, lf)
    with pytest.warns(liff.MissingViewsWarning, match=r"2 of 6 views missing from the 3x2 grid "
                      r"\(numbered from t=0, s=0\): \(t=2, s=0\), \(t=2, s=1\); read with alpha 0"):
        assert io.read_views(tmp_path, grid=(3, 2)).metadata["missing"] == [(2, 0), (2, 1)]
    raises_naming(tmp_path, r"up to a 2x2 grid.*expected grid=\(2, 1\)",
                  io.read_views, tmp_path, grid=(2, 1))
    raises_naming(tmp_path, r"expected two view counts", io.read_views, tmp_path, grid=(2,))
    raises_naming(tmp_path, r"expected positive", io.read_views, tmp_path, grid=(0, 2))


def test_views_pattern_override(tmp_path):
    """Column-first names read through named groups, and a row-major running index."""
    lf = coded_lf((2, 3, 4, 4, 3))
    io.write_views(tmp_path / "cols", lf, pattern="cam_{s}_{t}.png")
    result = io.read_views(tmp_path / "cols", pattern=r"cam_(?P<s>\d+)_(?P<t>\d+)\.png")
    np.testing.assert_array_equal(result.light_field, lf)

    for t in range(2):
        for s in range(3):
            cv2.imwrite(str(tmp_path / f"input_{t * 3 + s:03d}.png"), lf[t, s])
    result = io.read_views(tmp_path, grid=(2, 3), pattern=r"input_(?P<index>\d+)\.png")
    np.testing.assert_array_equal(result.light_field, lf)
    raises_naming(tmp_path, r"expected grid=\(T, S\)",
                  io.read_views, tmp_path, pattern=r"input_(?P<index>\d+)\.png")
    raises_naming(tmp_path, r"expected named groups \(\?P<t>",
                  io.read_views, tmp_path, pattern=r"input_(\d+)\.png")
    raises_naming(tmp_path, r"not a regular expression", io.read_views, tmp_path, pattern="(")
    raises_naming(tmp_path, r"no views found; expected file names matching",
                  io.read_views, tmp_path, pattern=r"nothing_(?P<t>\d)_(?P<s>\d)")


def test_views_folder_errors(tmp_path):
    lf = coded_lf((2, 2, 4, 6, 3))
    raises_naming(tmp_path / "absent", "not a folder", io.read_views, tmp_path / "absent")
    raises_naming(tmp_path, r"no views found; expected images", io.read_views, tmp_path)

    folder = tmp_path / "missing"
    io.write_views(folder, lf)
    (folder / "view_01_00.png").unlink()
    with pytest.warns(liff.MissingViewsWarning, match=re.escape(
            f"{folder}: 1 of 4 views missing from the 2x2 grid (numbered from t=0, s=0): "
            "(t=1, s=0); read with alpha 0 there, so LiFF uses the 3 views present")):
        assert io.read_views(folder).light_field.shape == (2, 2, 4, 6, 4)

    folder = tmp_path / "twice"
    io.write_views(folder, lf)
    cv2.imwrite(str(folder / "other_00_01.png"), lf[0, 1])
    raises_naming(folder, r"both view \(0, 1\); expected one file per view", io.read_views, folder)

    folder = tmp_path / "from2"
    io.write_views(folder, lf, pattern="v_{t}_{s}.png")
    for path in sorted(folder.iterdir(), reverse=True):  # numbered from 2
        t, s = map(int, re.findall(r"\d+", path.name))
        path.rename(folder / f"v_{t + 2}_{s + 2}.png")
    result = io.read_views(folder)  # any contiguous block (tests/io/test_real_captures.py)
    assert result.metadata["first_index"] == (2, 2)
    np.testing.assert_array_equal(result.light_field, lf)


@pytest.mark.parametrize("odd_view, expected", [
    # a larger view is refused from its header, before it is decoded
    (np.zeros((5, 6, 3), np.uint8), r"6x5 \(its header\); expected 6x4, 3 channel\(s\), uint8"),
    (np.zeros((3, 6, 3), np.uint8), r"6x3, 3 channel\(s\), uint8; expected 6x4, 3 channel\(s\)"),
    (np.zeros((4, 6), np.uint8), r"1 channel\(s\).*expected 6x4, 3 channel\(s\)"),
    (np.zeros((4, 6, 4), np.uint8), r"4 channel\(s\).*expected 6x4, 3 channel\(s\)"),
    (np.zeros((4, 6, 3), np.uint16), r"uint16; expected 6x4, 3 channel\(s\), uint8"),
])
def test_views_that_disagree_name_the_file(tmp_path, odd_view, expected):
    io.write_views(tmp_path, coded_lf((2, 2, 4, 6, 3)))
    cv2.imwrite(str(tmp_path / "view_01_01.png"), odd_view)
    message = raises_naming(tmp_path / "view_01_01.png", expected, io.read_views, tmp_path)
    assert "view_00_00.png" in message


def test_views_unreadable_image(tmp_path):
    io.write_views(tmp_path, coded_lf((1, 2, 4, 4)))
    (tmp_path / "view_00_01.png").write_bytes(b"not a png")
    raises_naming(tmp_path / "view_00_01.png", "unreadable image; expected a format",
                  io.read_views, tmp_path)


def test_view_writer_refuses_what_images_cannot_hold(tmp_path):
    lf = coded_lf((1, 2, 4, 4))
    raises_naming(tmp_path, r"dtype float32; expected uint8 or uint16 .*scale floats",
                  io.write_views, tmp_path, lf.astype(np.float32))
    raises_naming(tmp_path, r"dtype uint16; expected uint8 for \.jpg",
                  io.write_views, tmp_path, lf.astype(np.uint16), pattern="v_{t}_{s}.jpg")
    raises_naming(tmp_path, r"2 channels \(grey \+ alpha\); expected 1, 3 or 4",
                  io.write_views, tmp_path, np.stack([lf, lf], -1))
    raises_naming(tmp_path, r"same file name; expected a pattern with both \{t\} and \{s\}",
                  io.write_views, tmp_path, lf, pattern="v_{t}.png")
    raises_naming(tmp_path, r"expected a light field", io.write_views, tmp_path, lf[0])
    assert not list(tmp_path.iterdir())  # refused before writing anything


# ---------------------------------------------------------------- ESLF

def test_eslf_view_is_every_nth_pixel(tmp_path):
    """View (t, s) is image[t::n, s::n]; rows and columns past the last lenslet are cropped."""
    n, V, U = 5, 4, 6
    image = np.random.default_rng(2).integers(0, 256, (V * n + 3, U * n + 4, 3), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "a.eslf.png"), image)
    result = io.read_light_field(tmp_path / "a.eslf.png", n=n)
    assert result.format == "eslf"
    assert result.light_field.shape == (n, n, V, U, 3)
    for t, s in [(0, 0), (1, 3), (4, 4)]:
        np.testing.assert_array_equal(result.light_field[t, s], image[t:V * n:n, s:U * n:n])
    assert result.metadata["cropped"] == (3, 4)
    assert result.metadata["image_size"] == (V * n + 3, U * n + 4)
    assert result.metadata["has_alpha"] is False


@pytest.mark.parametrize("channels", [(), (3,), (4,)])
def test_eslf_round_trip(tmp_path, channels):
    lf = coded_lf((4, 4, 5, 6) + channels, np.uint16)
    io.write_eslf(tmp_path / "lf.png", lf)
    result = io.read_eslf(tmp_path / "lf.png", n=4)
    np.testing.assert_array_equal(result.light_field, lf)
    assert result.metadata["has_alpha"] == (channels == (4,))


def test_eslf_trimming_keeps_the_centre_views(tmp_path):
    """14 -> 11 keeps views 1..11 (the extra dropped view is at the bottom / right)."""
    n = 14
    codes = np.arange(n * n, dtype=np.uint8).reshape(n, n)
    image = np.tile(codes, (3, 2))  # 3x2 lenslets, lenslet pixel (t, s) holds t * 14 + s
    cv2.imwrite(str(tmp_path / "lytro.eslf.png"), image)
    result = io.read_light_field(tmp_path / "lytro.eslf.png", n=14, keep=11)
    assert result.light_field.shape == (11, 11, 3, 2)
    np.testing.assert_array_equal(result.light_field[:, :, 0, 0], codes[1:12, 1:12])
    assert result.metadata["first_view"] == (1, 1)
    result = io.read_eslf(tmp_path / "lytro.eslf.png", n=14, keep=(2, 5))
    np.testing.assert_array_equal(result.light_field[:, :, 2, 1], codes[6:8, 4:9])
    raises_naming(tmp_path / "lytro.eslf.png", r"keep 15x15 views of a 14x14 grid; expected at most",
                  io.read_eslf, tmp_path / "lytro.eslf.png", n=14, keep=15)


def test_eslf_writer_pads_a_trimmed_light_field(tmp_path):
    lf = coded_lf((3, 3, 4, 5, 4))
    io.write_eslf(tmp_path / "lf.png", lf, n=6)
    full = io.read_eslf(tmp_path / "lf.png", n=6).light_field
    assert full.shape == (6, 6, 4, 5, 4)
    np.testing.assert_array_equal(full[1:4, 1:4], lf)
    assert not full[0].any() and not full[4:].any()  # padding: zero, alpha 0 (invalid)
    np.testing.assert_array_equal(io.read_eslf(tmp_path / "lf.png", n=6, keep=3).light_field, lf)
    raises_naming(tmp_path / "x.png", r"n = 2; expected an integer >= 3",
                  io.write_eslf, tmp_path / "x.png", lf, n=2)


def test_eslf_alpha_is_kept_as_the_last_channel(tmp_path):
    n = 4
    bgra = np.random.default_rng(3).integers(0, 256, (3 * n, 2 * n, 4), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "c.eslf.png"), bgra)
    lf = io.read_eslf(tmp_path / "c.eslf.png", n=n).light_field
    assert lf.shape == (n, n, 3, 2, 4)
    np.testing.assert_array_equal(lf[1, 2, ..., 3], bgra[1::n, 2::n, 3])

    grey_alpha = bgra[:, :, [0, 3]].copy()
    write_grey_alpha_png(tmp_path / "g.eslf.png", grey_alpha)
    lf = io.read_eslf(tmp_path / "g.eslf.png", n=n).light_field
    assert lf.shape == (n, n, 3, 2, 2)
    np.testing.assert_array_equal(lf[3, 0], grey_alpha[3::n, 0::n])


def test_eslf_errors(tmp_path):
    cv2.imwrite(str(tmp_path / "small.png"), np.zeros((10, 20), np.uint8))
    raises_naming(tmp_path / "small.png", r"20x10; expected at least one 14x14 lenslet",
                  io.read_eslf, tmp_path / "small.png", n=14)
    raises_naming(tmp_path / "small.png", r"cannot tell the lenslet size from the image \(20x10; "
                  r".*expected an ESLF image whose lenslets show .* or the size given \(n=N\)",
                  io.read_eslf, tmp_path / "small.png")
    raises_naming(tmp_path / "small.png", r"n = 0; expected a whole number of pixels >= 2",
                  io.read_eslf, tmp_path / "small.png", n=0)
    raises_naming(tmp_path / "small.png", r"n = 1; expected a whole number of pixels >= 2 "
                  r"\(each lenslet holds n x n views; n = 1 is an ordinary image\)",
                  io.read_eslf, tmp_path / "small.png", n=1)
    raises_naming(tmp_path / "small.png", r"n = '14'; expected a whole number of pixels >= 2",
                  io.read_eslf, tmp_path / "small.png", n="14")
    raises_naming(tmp_path / "absent.png", r"no such file; expected an image",
                  io.read_eslf, tmp_path / "absent.png")


# ---------------------------------------------------------------- mosaics

@pytest.mark.parametrize("channels", [(), (3,), (4,)])
def test_mosaic_round_trip(tmp_path, channels):
    lf = coded_lf((2, 3, 5, 4) + channels)
    io.write_mosaic(tmp_path / "m.png", lf)
    image = cv2.imread(str(tmp_path / "m.png"), cv2.IMREAD_UNCHANGED)
    assert image.shape[:2] == (2 * 5, 3 * 4)
    np.testing.assert_array_equal(image[5:10, 8:12], lf[1, 2])  # tile (1, 2)
    result = io.read_light_field(tmp_path / "m.png", format="mosaic", grid=(2, 3))
    assert result.format == "mosaic" and result.metadata["tile_size"] == (5, 4)
    np.testing.assert_array_equal(result.light_field, lf)


def test_mosaic_errors(tmp_path):
    io.write_mosaic(tmp_path / "m.png", coded_lf((2, 3, 5, 4)))
    raises_naming(tmp_path / "m.png", r"12x10 \(width x height\); expected a width divisible by "
                  r"S = 5 and a height divisible by T = 3", io.read_mosaic, tmp_path / "m.png", (3, 5))
    raises_naming(tmp_path / "m.png", r"no grid given for a mosaic; expected grid=\(T, S\)",
                  io.read_light_field, tmp_path / "m.png", format="mosaic")


# ---------------------------------------------------------------- .npy / .npz

@pytest.mark.parametrize("shape, dtype", [((2, 3, 4, 5), np.float32), ((2, 2, 3, 3, 2), np.uint8),
                                          ((1, 2, 3, 3, 4), np.float64), ((2, 1, 3, 3, 1), np.uint16)])
def test_numpy_round_trips(tmp_path, shape, dtype):
    lf = np.random.default_rng(4).random(shape).astype(dtype)
    np.save(tmp_path / "a.npy", lf)
    result = io.read_light_field(tmp_path / "a.npy")
    assert result.format == "npy" and result.light_field.dtype == dtype
    np.testing.assert_array_equal(result.light_field, lf)

    disparity = np.random.default_rng(5).random(shape[2:4])
    np.savez_compressed(tmp_path / "b.npz", light_field=lf, gt_disparity=disparity, other=lf[0])
    result = io.read_light_field(tmp_path / "b.npz")
    assert result.format == "npz" and result.metadata["key"] == "light_field"
    np.testing.assert_array_equal(result.light_field, lf)
    assert result.gt_disparity.dtype == np.float32
    np.testing.assert_allclose(result.gt_disparity, disparity, rtol=1e-6)


def test_npz_picks_the_only_array_or_the_key(tmp_path):
    lf = coded_lf((2, 2, 3, 3))
    np.savez(tmp_path / "one.npz", views=lf)
    np.testing.assert_array_equal(io.read_numpy(tmp_path / "one.npz").light_field, lf)
    np.savez(tmp_path / "two.npz", a=lf, b=lf[::-1])
    raises_naming(tmp_path / "two.npz", r"arrays \['a', 'b'\]; expected one named 'light_field'",
                  io.read_numpy, tmp_path / "two.npz")
    np.testing.assert_array_equal(io.read_numpy(tmp_path / "two.npz", key="b").light_field, lf[::-1])
    raises_naming(tmp_path / "two.npz", r"no array 'c'; expected one of \['a', 'b'\]",
                  io.read_numpy, tmp_path / "two.npz", key="c")


@pytest.mark.parametrize("array, expected", [
    (np.zeros((4, 5, 3)), r"shape \(4, 5, 3\); expected a light field \(T, S, V, U\)"),
    (np.zeros((2, 2, 3, 3, 5)), r"5 channels .*expected C in 1, 2, 3, 4"),
    (np.zeros((2, 0, 3, 3)), r"expected no empty axis"),
    (np.zeros((2, 2, 3, 3), np.int32), r"dtype int32; expected uint8, uint16, float32 or float64"),
    (np.zeros((2, 2, 3, 3), bool), r"dtype bool; expected uint8"),
])
def test_numpy_arrays_that_are_not_light_fields(tmp_path, array, expected):
    np.save(tmp_path / "a.npy", array)
    raises_naming(tmp_path / "a.npy", expected, io.read_light_field, tmp_path / "a.npy")
    np.savez(tmp_path / "b.npz", light_field=array)
    raises_naming(tmp_path / "b.npz", expected, io.read_light_field, tmp_path / "b.npz")


def test_numpy_refuses_pickles_and_bad_files(tmp_path):
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    raises_naming(tmp_path / "objects.npy", r"unreadable .*expected a \.npy or \.npz",
                  io.read_numpy, tmp_path / "objects.npy")
    (tmp_path / "junk.npz").write_bytes(b"junk")
    raises_naming(tmp_path / "junk.npz", r"unreadable", io.read_numpy, tmp_path / "junk.npz")
    np.savez(tmp_path / "d.npz", light_field=np.zeros((2, 2, 3, 3)), gt_disparity=np.zeros((3, 4)))
    raises_naming(tmp_path / "d.npz", r"shape \(3, 4\); expected the views' \(V, U\) = \(3, 3\)",
                  io.read_numpy, tmp_path / "d.npz")


# ---------------------------------------------------------------- read_light_field

def test_read_light_field_recognises_hci_folders(tmp_path):
    views = coded_lf((2, 2, 4, 4, 3))
    for index in range(4):
        cv2.imwrite(str(tmp_path / f"input_Cam{index:03d}.png"), views[index // 2, index % 2])
    assert io.guess_format(tmp_path) == "hci"
    result = io.read_light_field(tmp_path)
    assert result.format == "hci" and result.gt_disparity is None
    np.testing.assert_array_equal(result.light_field, views)


def test_read_light_field_errors_list_the_formats(tmp_path):
    cv2.imwrite(str(tmp_path / "picture.png"), np.zeros((4, 4), np.uint8))
    message = raises_naming(tmp_path / "picture.png", r"cannot tell .* expected one of",
                            io.read_light_field, tmp_path / "picture.png")
    for name in io.FORMATS:
        assert name in message
    assert "format='mosaic'" in message and "*.eslf.png" in message
    raises_naming(tmp_path / "picture.png", r"unknown format 'lytro'; expected one of: hci",
                  io.read_light_field, tmp_path / "picture.png", format="lytro")
    raises_naming(tmp_path / "absent", r"no such file or folder; expected a light field",
                  io.read_light_field, tmp_path / "absent")
    np.save(tmp_path / "a.npy", np.zeros((1, 1, 2, 2)))
    raises_naming(tmp_path / "a.npy", r"option\(s\) grid, n do not apply to format 'npy'; "
                  r"expected bit_depth \(grid: views, mosaic; n: eslf\)", io.read_light_field,
                  tmp_path / "a.npy", n=3, grid=(1, 1))


def test_centre_views_is_shared_by_every_format():
    lf = coded_lf((17, 17, 2, 2))
    centre = io.centre_views(lf, 9)
    assert centre.shape == (9, 9, 2, 2)
    assert centre[0, 0, 0, 0] == lf[4, 4, 0, 0] and np.shares_memory(centre, lf)
    assert io.centre_views(lf[:4], (2, 3)).shape == (2, 3, 2, 2)  # rows 1..2, columns 7..9


def test_cotton_through_read_light_field():
    if not COTTON.is_dir():
        pytest.skip(f"HCI 'cotton' light field not found at {COTTON}")
    result = io.read_light_field(COTTON)
    assert result.format == "hci" and result.light_field.shape == (9, 9, 512, 512, 3)
    assert (result.metadata["disp_min"], result.metadata["disp_max"]) == (-1.6, 1.5)
    assert result.gt_disparity.shape == (512, 512)


# ---------------------------------------------------------------- review findings

@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32])
def test_images_of_signed_dtypes_are_refused_naming_the_file(tmp_path, dtype):
    """OpenCV reads some TIFFs as int8/16/32, which liff does not accept."""
    image = (np.arange(8 * 8).reshape(8, 8) - 20).astype(dtype)
    for name in ("v_0_0.tif", "v_0_1.tif"):
        assert cv2.imwrite(str(tmp_path / name), image)
    assert cv2.imread(str(tmp_path / "v_0_0.tif"), cv2.IMREAD_UNCHANGED).dtype == dtype
    expected = rf"dtype {np.dtype(dtype)}; expected uint8, uint16, float32 or float64"
    raises_naming(tmp_path / "v_0_0.tif", expected, io.read_views, tmp_path)
    raises_naming(tmp_path / "v_0_0.tif", expected, io.read_mosaic, tmp_path / "v_0_0.tif", (2, 2))
    raises_naming(tmp_path / "v_0_0.tif", expected, io.read_eslf, tmp_path / "v_0_0.tif", n=2)


def test_float64_images_are_still_read(tmp_path):
    image = np.linspace(0, 1, 8 * 8).reshape(8, 8)
    cv2.imwrite(str(tmp_path / "m.tif"), image)
    result = io.read_mosaic(tmp_path / "m.tif", grid=(2, 2))
    assert result.light_field.dtype == np.float64
    np.testing.assert_array_equal(result.light_field[1, 0], image[4:, :4])


@pytest.mark.parametrize("grid, expected", [
    ((2.9, 2), r"grid \(2\.9, 2\): T = 2\.9; expected positive whole view counts"),
    ((2, 0.5), r"S = 0\.5; expected positive whole view counts"),
    ((2, float("inf")), r"S = inf; expected positive whole view counts"),
    ((float("nan"), 2), r"T = nan; expected positive whole view counts"),
    ((True, 2), r"T = True; expected positive whole view counts"),
    (("2", 2), r"T = '2'; expected positive whole view counts"),
    ((2, -1), r"S = -1; expected positive whole view counts"),
])
def test_grid_must_be_whole_numbers(tmp_path, grid, expected):
    lf = coded_lf((2, 2, 4, 4))
    io.write_mosaic(tmp_path / "m.png", lf)
    raises_naming(tmp_path / "m.png", expected, io.read_mosaic, tmp_path / "m.png", grid)
    io.write_views(tmp_path / "v", lf)
    raises_naming(tmp_path / "v", expected, io.read_views, tmp_path / "v", grid=grid)
    # whole numbers of any type are fine
    for whole in [(2.0, 2), (np.int64(2), np.float32(2)), np.array([2, 2])]:
        np.testing.assert_array_equal(io.read_mosaic(tmp_path / "m.png", whole).light_field, lf)
        np.testing.assert_array_equal(io.read_views(tmp_path / "v", grid=whole).light_field, lf)


@pytest.mark.parametrize("keep, expected", [
    (2.5, r"keep \(2\.5, 2\.5\): T = 2\.5; expected positive whole view counts"),
    (float("inf"), r"keep \(inf, inf\): T = inf; expected positive"),
    ((3, float("nan")), r"keep \(3, nan\): S = nan; expected positive"),
    (0, r"keep \(0, 0\): T = 0; expected positive"),
    ((3,), r"keep \(3,\); expected two view counts"),
])
def test_keep_must_be_whole_numbers(tmp_path, keep, expected):
    lf = coded_lf((5, 5, 2, 2))
    with pytest.raises(ValueError, match=r"^centre_views: " + expected):
        io.centre_views(lf, keep)
    io.write_eslf(tmp_path / "e.png", lf)
    raises_naming(tmp_path / "e.png", expected, io.read_eslf, tmp_path / "e.png", n=5, keep=keep)
    np.testing.assert_array_equal(io.centre_views(lf, 3.0), lf[1:4, 1:4])
    np.testing.assert_array_equal(io.read_eslf(tmp_path / "e.png", n=5, keep=(3.0, np.int8(2))).light_field,
                                  lf[1:4, 1:3])


def test_lenslet_size_follows_the_same_rule(tmp_path):
    lf = coded_lf((3, 3, 4, 5, 3))
    for bad in (2.5, float("inf"), float("nan"), True, "4"):
        raises_naming(tmp_path / "e.png", rf"lenslet size n = {re.escape(repr(bad))}; expected a "
                      r"whole number of pixels >= 2", io.read_eslf, tmp_path / "e.png", n=bad)
    raises_naming(tmp_path / "x.png", r"n = 2\.0; expected an integer >= 3",
                  io.write_eslf, tmp_path / "x.png", lf, n=2.0)
    raises_naming(tmp_path / "x.png", r"n = 4\.5; expected an integer >= 3",
                  io.write_eslf, tmp_path / "x.png", lf, n=4.5)
    io.write_eslf(tmp_path / "e.png", lf, n=4.0)  # a whole float is fine
    result = io.read_eslf(tmp_path / "e.png", n=np.float64(4), keep=3)
    assert result.metadata["lenslet_size"] == 4 and type(result.metadata["lenslet_size"]) is int
    np.testing.assert_array_equal(result.light_field, lf)


def test_positive_int_helper():
    from liff.io._shared import positive_int

    assert positive_int(3, "n", "src") == 3 and type(positive_int(3.0, "n", "src")) is int
    assert positive_int(np.uint8(5), "n", "src", 5) == 5
    assert positive_int(10 ** 30, "n", "src") == 10 ** 30
    for bad in (4, 5.5, float("-inf"), np.nan, np.True_, "7", [7], 1j):
        with pytest.raises(ValueError, match=r"^src: n = .*; expected an integer >= 5$"):
            positive_int(bad, "n", "src", 5)


def write_hci(folder: Path, shape=(2, 2, 4, 5)):
    T, S, V, U = shape
    folder.mkdir()
    for index in range(T * S):
        cv2.imwrite(str(folder / f"input_Cam{index:03d}.png"), np.full((V, U, 3), index, np.uint8))
    (folder / "parameters.cfg").write_text(f"[extrinsics]\nnum_cams_x = {S}\nnum_cams_y = {T}\n")


def test_hci_colour_disparity_is_named_as_such(tmp_path):
    write_hci(tmp_path / "s")
    io.write_pfm(tmp_path / "s" / "gt_disp_lowres.pfm", np.zeros((4, 5, 3), np.float32))
    message = raises_naming(tmp_path / "s" / "gt_disp_lowres.pfm",
                            r"colour \(PF\) PFM of shape \(4, 5, 3\); expected a grey Pf disparity "
                            r"map of the views' size 5x4", io.read_hci, tmp_path / "s")
    assert "differs" not in message
    io.write_pfm(tmp_path / "s" / "gt_disp_lowres.pfm", np.zeros((4, 6), np.float32))
    raises_naming(tmp_path / "s" / "gt_disp_lowres.pfm", r"size 6x4 differs from the views' 5x4",
                  io.read_hci, tmp_path / "s")
    io.write_pfm(tmp_path / "s" / "gt_disp_lowres.pfm", np.ones((4, 5), np.float32))
    assert io.read_hci(tmp_path / "s").gt_disparity.shape == (4, 5)


def test_hci_missing_views_message(tmp_path):
    write_hci(tmp_path / "s", (3, 3, 4, 4))
    for index in (1, 2, 3, 4, 5, 7):
        (tmp_path / "s" / f"input_Cam{index:03d}.png").unlink()
    with pytest.warns(liff.MissingViewsWarning, match=r"6 of 9 views missing from the 3x3 grid: "
                      r"input_Cam001\.png, input_Cam002\.png, input_Cam003\.png, "
                      r"input_Cam004\.png, input_Cam005\.png, input_Cam007\.png; read with "
                      r"alpha 0 there, so LiFF uses the 3 views present"):
        assert io.read_hci(tmp_path / "s").light_field.shape[-1] == 4
    (tmp_path / "s" / "input_Cam000.png").unlink()  # 2 views: too few for a 3x3 grid
    raises_naming(tmp_path / "s", r"7 views missing for a 3x3 grid: input_Cam000\.png, "
                  r"input_Cam001\.png, input_Cam002\.png, input_Cam003\.png, input_Cam004\.png "
                  r"\.\.\.; expected at least 3 views", io.read_hci, tmp_path / "s")
    assert io.guess_format(tmp_path / "s") == "hci"


@pytest.mark.parametrize("disparity", [np.full((3, 3), "1.5"), np.ones((3, 3), np.complex64),
                                       np.zeros((3, 3), "V4")])
def test_npz_disparity_must_be_real_numbers(tmp_path, disparity):
    np.savez(tmp_path / "d.npz", light_field=np.zeros((2, 2, 3, 3)), gt_disparity=disparity)
    raises_naming(tmp_path / "d.npz", rf"'gt_disparity'\]: dtype {disparity.dtype}; expected real "
                  r"numbers", io.read_numpy, tmp_path / "d.npz")


@pytest.mark.parametrize("dtype", [">f4", ">f8", ">u2", "<u2", ">i2"])
def test_non_native_byte_order_is_read_as_native(tmp_path, dtype):
    native = np.dtype(dtype).newbyteorder("=")
    lf = coded_lf((2, 2, 3, 4, 3), np.uint16).astype(dtype)
    np.save(tmp_path / "a.npy", lf)
    np.savez(tmp_path / "b.npz", light_field=lf, gt_disparity=np.ones((3, 4), ">f8"))
    if native not in (np.uint16, np.float32, np.float64):
        raises_naming(tmp_path / "a.npy", rf"dtype {native}; expected uint8, uint16",
                      io.read_light_field, tmp_path / "a.npy")
        return
    for path in (tmp_path / "a.npy", tmp_path / "b.npz"):
        result = io.read_light_field(path)
        assert result.light_field.dtype == native and result.light_field.dtype.isnative
        np.testing.assert_array_equal(result.light_field, lf)
    assert io.read_numpy(tmp_path / "b.npz").gt_disparity.dtype == np.float32
    if native == np.uint16:  # writable as images once in native order
        io.write_mosaic(tmp_path / "m.png", lf)
        np.testing.assert_array_equal(io.read_mosaic(tmp_path / "m.png", (2, 2)).light_field, lf)


# --- only regular files and folders: a FIFO would block the reader forever ---------------

FIFO_READERS = {
    "read_light_field .npz": ("lf.npz", lambda p: io.read_light_field(p)),
    "read_light_field .npy": ("lf.npy", lambda p: io.read_light_field(p)),
    "read_light_field .mat": ("lf.mat", lambda p: io.read_light_field(p)),
    "read_light_field .h5": ("lf.h5", lambda p: io.read_light_field(p)),
    "read_light_field mosaic": ("m.png", lambda p: io.read_light_field(p, format="mosaic", grid=(2, 2))),
    "read_numpy": ("lf.npz", io.read_numpy),
    "read_pfm": ("d.pfm", io.read_pfm),
    "read_eslf": ("a.eslf.png", io.read_eslf),
    "read_mat": ("lf.mat", io.read_mat),
    "read_hdf5": ("lf.h5", io.read_hdf5),
}


@pytest.mark.parametrize("name, call", FIFO_READERS.values(), ids=FIFO_READERS.keys())
def test_a_fifo_is_refused_without_opening_it(tmp_path, name, call):
    from lfhelpers import Fifo
    with Fifo(tmp_path / name) as fifo:
        with pytest.raises(ValueError, match=rf"{re.escape(fifo.path)}: is a FIFO"):
            call(fifo.path)
    assert fifo.opened == 0


@pytest.mark.parametrize("kind", ["views", "hci"])
def test_a_fifo_among_the_views_is_refused_without_opening_it(tmp_path, kind):
    from lfhelpers import Fifo
    lf = coded_lf((2, 2, 8, 8, 3))
    folder = tmp_path / "scene"
    folder.mkdir()
    names = ([f"input_Cam{i:03d}.png" for i in range(4)] if kind == "hci" else
             [f"v_{t:02d}_{s:02d}.png" for t in range(2) for s in range(2)])
    for name, view in zip(names[:3], lf.reshape(4, 8, 8, 3)):
        cv2.imwrite(str(folder / name), view)
    with Fifo(folder / names[3]) as fifo:
        with pytest.raises(ValueError, match="is a FIFO"):
            io.read_light_field(folder)
    assert fifo.opened == 0


# --- OpenCV's decoding errors as liff's: ValueError, MemoryError, naming the file --------

def huge_header_png(path):
    """A PNG whose header claims 100000 x 100000 pixels, more than OpenCV decodes."""
    zero_png(path, 4, 4)
    data = bytearray(Path(path).read_bytes())
    data[16:24] = struct.pack(">II", 100_000, 100_000)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])) & 0xFFFFFFFF)
    Path(path).write_bytes(bytes(data))


def folder_with(tmp_path, kind, bad):
    folder = tmp_path / kind
    folder.mkdir()
    names = ([f"input_Cam{i:03d}.png" for i in range(4)] if kind == "hci" else
             [f"v_{t:02d}_{s:02d}.png" for t in range(2) for s in range(2)])
    for name in names:
        zero_png(folder / name, 8, 8)
    bad(folder / names[0])
    return folder, folder / names[0]


HUGE_HEADER = {
    "read_image": lambda tmp: (tmp / "a.png", lambda p: io.images.read_image(p)),
    "read_mosaic": lambda tmp: (tmp / "a.png", lambda p: io.read_mosaic(p, grid=(2, 2))),
    "read_eslf": lambda tmp: (tmp / "a.eslf.png", io.read_eslf),
}


@pytest.mark.parametrize("case", list(HUGE_HEADER) + ["views", "hci"])
def test_an_image_claiming_more_pixels_than_opencv_decodes_is_a_value_error(tmp_path, case):
    # OpenCV's cv2.error (-215, pixels <= CV_IO_MAX_IMAGE_PIXELS) had escaped
    if case in HUGE_HEADER:
        path, call = HUGE_HEADER[case](tmp_path)
        huge_header_png(path)
        target = path
    else:
        target, path = folder_with(tmp_path, case, huge_header_png)
        call = io.read_light_field
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}: .*more pixels than OpenCV"):
        call(str(target))


OUT_OF_MEMORY = """
import os, resource, sys
import liff.io
path, kind = sys.argv[1], sys.argv[2]
vm = int(next(l for l in open("/proc/self/status") if l.startswith("VmSize")).split()[1]) * 1024
resource.setrlimit(resource.RLIMIT_AS, (vm + 48 * 2**20, resource.RLIM_INFINITY))
try:
    liff.io.images.read_image(path) if kind == "image" else liff.io.read_light_field(path)
except MemoryError as e:
    print("MemoryError:", e)
"""


@pytest.mark.parametrize("kind", ["image", "hci", "views"])
def test_running_out_of_memory_while_decoding_is_a_memory_error(tmp_path, kind):
    # a 140 KB PNG decodes to 144 MB; with 48 MB left OpenCV raised cv2.error (-4)
    if kind == "image":
        target = path = tmp_path / "big.png"
        zero_png(path, 12000, 12000)
    else:
        target, path = folder_with(tmp_path, kind, lambda p: zero_png(p, 12000, 12000))
    env = dict(os.environ)
    if "LD_PRELOAD" in env:  # the sanitized run: ASan reserves terabytes of address space;
        del env["LD_PRELOAD"]  # the readers are Python over cv2, the installed liff will do
        env.pop("PYTHONPATH", None)
    proc = subprocess.run([sys.executable, "-c", OUT_OF_MEMORY, str(target), kind],
                          capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    assert f"MemoryError: {path}: not enough memory" in proc.stdout, proc.stdout + proc.stderr


def test_only_decode_image_calls_opencvs_decoders():
    """Every image liff reads goes through liff.io.images.decode_image, which maps
    cv2.error to ValueError / MemoryError naming the file: no other module calls
    OpenCV's decoders (where a cv2.error would reach the caller)."""
    import ast

    decoders = {"imread", "imdecode", "imreadmulti", "imreadanimation", "imcount",
                "imdecodemulti", "imreadWithMetadata"}
    package = Path(io.__file__).resolve().parents[1]
    calls = []  # (file, enclosing function or None) of each use of a decoder
    for source in sorted(package.rglob("*.py")):
        tree = ast.parse(source.read_text(), str(source))
        inside = {}  # id(node) -> the function it is in
        for function in (node for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)):
            inside.update((id(node), function.name) for node in ast.walk(function))
        calls += [(source.relative_to(package).as_posix(), inside.get(id(node)))
                  for node in ast.walk(tree)
                  if isinstance(node, ast.Attribute) and node.attr in decoders]
    assert calls == [("io/images.py", "decode_image")], calls
