"""liff.io: PFM images and HCI scene folders."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest

import liff
from liff import synthetic
from liff.io import read_hci, read_pfm, write_pfm

COTTON = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "hci" / "cotton"


@pytest.mark.parametrize("shape", [(5, 7), (4, 6, 3)])
def test_pfm_round_trip(tmp_path, shape):
    image = np.random.default_rng(0).normal(size=shape).astype(np.float32)
    write_pfm(tmp_path / "a.pfm", image)
    assert np.array_equal(read_pfm(tmp_path / "a.pfm"), image)


def test_pfm_rows_are_stored_bottom_up(tmp_path):
    image = np.array([[1, 2], [3, 4]], np.float32)  # top row 1, 2
    write_pfm(tmp_path / "a.pfm", image)
    raw = (tmp_path / "a.pfm").read_bytes()
    assert raw.startswith(b"Pf\n2 2\n-1.0\n")
    assert np.frombuffer(raw[-16:], "<f4").tolist() == [3, 4, 1, 2]


def test_pfm_big_endian(tmp_path):
    image = np.arange(6, dtype=np.float32).reshape(2, 3)
    (tmp_path / "b.pfm").write_bytes(b"Pf\n3 2\n1.0\n" + image[::-1].astype(">f4").tobytes())
    assert np.array_equal(read_pfm(tmp_path / "b.pfm"), image)


@pytest.mark.parametrize("content, word", [
    (b"P6\n2 2\n255\n" + bytes(12), "not a PFM"),
    (b"Pf\n2 x\n-1\n", "header"),
    (b"Pf\n2 2\n0\n" + bytes(16), "scale"),
    (b"Pf\n4 4\n-1\n" + bytes(16), "expected 64"),
    (b"Pf\n", "truncated"),
])
def test_pfm_bad_files_raise(tmp_path, content, word):
    (tmp_path / "bad.pfm").write_bytes(content)
    with pytest.raises(ValueError, match=word):
        read_pfm(tmp_path / "bad.pfm")


def write_hci_folder(folder: Path, lf: np.ndarray, disparity=None, grid=True):
    """Writes a light field (T, S, V, U) in [0, 1] as an HCI scene folder."""
    T, S = lf.shape[:2]
    folder.mkdir(parents=True, exist_ok=True)
    for t in range(T):
        for s in range(S):
            view = np.clip(lf[t, s] * 255 + 0.5, 0, 255).astype(np.uint8)
            cv2.imwrite(str(folder / f"input_Cam{t * S + s:03d}.png"), cv2.merge([view] * 3))
    if grid:
        (folder / "parameters.cfg").write_text(
            f"[extrinsics]\nnum_cams_x = {S}\nnum_cams_y = {T}\n\n"
            "[meta]\ndisp_min = -1.0\ndisp_max = 1.0\n")
    if disparity is not None:
        write_pfm(folder / "gt_disp_lowres.pfm", disparity)


def test_hci_folder_reads_and_its_disparity_matches_liff_slopes(tmp_path):
    """A synthetic scene written in the HCI layout: reading it back gives the views in
    (T, S) order, and LiFF's slopes agree with the written ground-truth disparity."""
    shape = (5, 5, 96, 96)
    blobs = synthetic.random_blob_layers([-0.6, 0.3], shape, blobs_per_layer=6, seed=4)
    lf = synthetic.render_disks(blobs, shape, profile="gaussian")
    disparity = np.zeros(shape[2:], np.float32)
    for b in blobs:  # disparity of each blob's neighbourhood
        yy, xx = np.mgrid[0:shape[2], 0:shape[3]]
        disparity[np.hypot(xx - b.x, yy - b.y) < 2 * b.radius] = b.slope
    write_hci_folder(tmp_path / "scene", lf, disparity)
    scene = read_hci(tmp_path / "scene")
    assert scene.light_field.shape == shape + (3,)
    assert (scene.disp_min, scene.disp_max) == (-1.0, 1.0)
    expected = np.clip(lf * 255 + 0.5, 0, 255).astype(np.uint8)
    assert np.array_equal(scene.light_field[..., 0], expected)
    kps = liff.LiFF.create().detect(scene.light_field)
    pts = np.round([k.pt for k in kps]).astype(int)
    truth = scene.gt_disparity[pts[:, 1], pts[:, 0]]
    near = truth != 0  # on a blob (the background has no disparity written)
    assert near.sum() >= 8
    assert np.median(np.abs(liff.keypoint_slopes(kps)[near] - truth[near])) < 0.05


def test_hci_errors_name_the_problem(tmp_path):
    lf = np.full((2, 2, 16, 16), 0.5)
    write_hci_folder(tmp_path / "s", lf)
    (tmp_path / "s" / "input_Cam002.png").unlink()  # (a lost view: read, and named)
    with pytest.warns(liff.MissingViewsWarning, match="input_Cam002.png"):
        assert read_hci(tmp_path / "s").light_field.shape == (2, 2, 16, 16, 4)
    with pytest.raises(ValueError, match="no input_CamNNN"):
        read_hci(tmp_path)
    with pytest.raises(ValueError, match="not a folder"):
        read_hci(tmp_path / "nothing")
    write_hci_folder(tmp_path / "odd", np.full((2, 2, 16, 16), 0.5))
    cv2.imwrite(str(tmp_path / "odd" / "input_Cam003.png"), np.zeros((8, 16, 3), np.uint8))
    with pytest.raises(ValueError, match="differs"):
        read_hci(tmp_path / "odd")
    write_hci_folder(tmp_path / "nogrid", np.full((1, 3, 8, 8), 0.5), grid=False)
    with pytest.raises(ValueError, match="square"):
        read_hci(tmp_path / "nogrid")


def test_cotton_scene():
    if not COTTON.is_dir():
        pytest.skip(f"HCI 'cotton' light field not found at {COTTON}")
    scene = read_hci(COTTON)
    assert scene.light_field.shape == (9, 9, 512, 512, 3)
    assert (scene.disp_min, scene.disp_max) == (-1.6, 1.5)
    gt = scene.gt_disparity
    assert gt.shape == (512, 512) and np.isfinite(gt).all()
    assert -1.6 <= gt.min() < gt.max() <= 1.5


def pfm_bytes(image: np.ndarray, header: bytes, order: str = "<f4") -> bytes:
    """A PFM file of ``image`` (rows top-down) under a hand-written ``header``."""
    return header + np.ascontiguousarray(image[::-1], dtype=order).tobytes()


@pytest.mark.parametrize("shape", [(2, 3), (5, 4), (3, 4, 3)])
@pytest.mark.parametrize("header, order", [
    (b"{magic}\r\n{w} {h}\r\n-1.0\r\n", "<f4"),                       # CR+LF (Windows tools)
    (b"{magic}\r\n{w} {h}\r\n1.0\r\n", ">f4"),                        # CR+LF, big-endian
    (b"# written by a tool\n{magic}\n# size\n{w} {h}\n# scale\n-1\n", "<f4"),  # comments
    (b"{magic}\r\n# comment\r\n{w}\t\t{h}\r\n\r\n  -0.5\n", "<f4"),   # CR+LF, comment, blanks
    (b"{magic}   \n  {w}\n{h}  \n  1.0\n", ">f4"),                     # extra whitespace
    (b"{magic} {w} {h} -1.0\n", "<f4"),                                # one line
])
def test_pfm_header_variants_read_alike(tmp_path, shape, header, order):
    """Issue 26 item 2: CR+LF line ends were read as garbage (values ~1e29)."""
    image = np.random.default_rng(len(header)).normal(size=shape).astype(np.float32)
    magic = b"PF" if len(shape) == 3 else b"Pf"
    head = header.replace(b"{magic}", magic).replace(b"{w}", b"%d" % shape[1]) \
        .replace(b"{h}", b"%d" % shape[0])
    (tmp_path / "v.pfm").write_bytes(pfm_bytes(image, head, order))
    read = read_pfm(tmp_path / "v.pfm")
    assert read.dtype == np.float32 and np.array_equal(read, image)


def test_pfm_crlf_header_whose_data_starts_with_a_line_feed_byte(tmp_path):
    """A header ending in a lone CR, data starting with 0x0a: the file's size tells."""
    data = b"\n" + bytes(7)  # the first float's first byte is 0x0a
    (tmp_path / "cr.pfm").write_bytes(b"Pf\r2 1\r-1\r" + data[:-1] + b"\x00")
    expected = np.frombuffer(data, "<f4").reshape(1, 2)
    assert np.array_equal(read_pfm(tmp_path / "cr.pfm"), expected)
    (tmp_path / "crlf.pfm").write_bytes(b"Pf\r\n2 1\r\n-1\r" + data)  # CR + (LF of the data)
    assert np.array_equal(read_pfm(tmp_path / "crlf.pfm"), expected)


@pytest.mark.parametrize("content, expected", [
    (b"PF4\n2 2\n-1\n" + bytes(64), r"magic b'PF4'; expected b'Pf' or b'PF'"),
    (b"Pf\n2.5 2\n-1\n" + bytes(64), r"expected integer width and height"),
    (b"Pf\n# only a comment\n", r"truncated PFM header"),
    (b"Pf\r\n2 2\r\n-1\r\n" + bytes(8), r"PFM data holds 8 bytes; expected 16 for 2x2x1"),
    (b"Pf\n2 2\ninf\n" + bytes(16), r"finite non-zero scale"),
])
def test_pfm_headers_the_format_does_not_allow_are_refused_clearly(tmp_path, content, expected):
    (tmp_path / "bad.pfm").write_bytes(content)
    with pytest.raises(ValueError, match=re.escape(str(tmp_path / "bad.pfm")) + ".*" + expected):
        read_pfm(tmp_path / "bad.pfm")
