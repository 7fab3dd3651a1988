"""Reading the captures people have (issue 12, section 2): view names with a scene id,
view blocks that do not start at 0 or 1, incomplete view sets, ESLF lenslet sizes other
than 14, MATLAB and HDF5 light fields, intensity scale, and detection masks."""

from __future__ import annotations

import re
import sys
import warnings
from pathlib import Path

import cv2
import h5py
import numpy as np
import pytest
from test_readers_and_writers import COTTON, coded_lf, raises_naming

import liff
from lfhelpers import matlab_order, write_mat_v5, write_mat_v73
from liff import io, synthetic
from liff.cli import main
from liff.feature_file import load_features
from liff.preprocess import border_mask


def write_named(folder: Path, lf: np.ndarray, name, views=None) -> None:
    """Writes the views ``views`` (default all) of ``lf`` as ``name(t, s)``."""
    folder.mkdir(parents=True, exist_ok=True)
    T, S = lf.shape[:2]
    for t, s in views if views is not None else [(t, s) for t in range(T) for s in range(S)]:
        assert cv2.imwrite(str(folder / name(t, s)), lf[t, s])


def cross(T: int, S: int) -> set:
    return {(t, s) for t in range(T) for s in range(S) if t == T // 2 or s == S // 2}


def star(T: int, S: int) -> set:
    return cross(T, S) | {(t, s) for t in range(T) for s in range(S)
                          if abs(t - T // 2) == abs(s - S // 2)}


# ---------------------------------------------------------------- view names and blocks

@pytest.mark.parametrize("name", [
    lambda t, s: f"0421_{t:02d}_{s:02d}.png",          # Lytro dataset: scene 421, row, column
    lambda t, s: f"IMG_0421_{t + 1}_{s + 1}.png",       # a scene id, 1-based and unpadded
    lambda t, s: f"view_{t:02d}_{s:02d}_0001.png",      # a frame number after the indices
    lambda t, s: f"out_{t:02d}_{s:02d}_{100.5 + t:.6f}_{-3.25 * s:.6f}.png",  # gantry positions
])
def test_view_indices_are_found_beside_scene_ids_and_frame_numbers(tmp_path, name):
    lf = coded_lf((3, 4, 5, 6, 3))
    write_named(tmp_path, lf, name)
    result = io.read_views(tmp_path)
    np.testing.assert_array_equal(result.light_field, lf)
    assert result.metadata["grid"] == (3, 4) and result.metadata["missing"] == []


def test_scene_id_with_one_row_of_views(tmp_path):
    """Row index 0 in every name, like the scene id: the last pair is still (t, s)."""
    lf = coded_lf((1, 5, 4, 4))
    write_named(tmp_path, lf, lambda t, s: f"0421_{t:02d}_{s:02d}.png")
    result = io.read_views(tmp_path)
    assert result.light_field.shape == (1, 5, 4, 4)
    np.testing.assert_array_equal(result.light_field, lf)


def test_two_scenes_in_one_folder_are_refused(tmp_path):
    lf = coded_lf((2, 2, 4, 4))
    write_named(tmp_path, lf, lambda t, s: f"0421_{t:02d}_{s:02d}.png")
    write_named(tmp_path, lf, lambda t, s: f"0422_{t:02d}_{s:02d}.png")
    raises_naming(tmp_path, r"names hold 3 _-joined numbers and more than two of them vary "
                  r"\(e\.g\. 0421_00_00\.png and 0422_01_01\.png: several light fields in one "
                  r"folder\?\)", io.read_views, tmp_path)


def test_names_numbered_two_ways_are_refused(tmp_path):
    lf = coded_lf((2, 2, 4, 4))
    write_named(tmp_path, lf, lambda t, s: f"0421_{t:02d}_{s:02d}.png")
    cv2.imwrite(str(tmp_path / "scene_0_0.png"), lf[0, 0])
    raises_naming(tmp_path, r"runs of different lengths .*scene_0_0\.png \(2 numbers\) and "
                  r"0421_00_00\.png \(3 numbers\)", io.read_views, tmp_path)


def test_a_crop_of_a_larger_grid_reads_with_or_without_grid_and_pattern(tmp_path):
    """Rows and columns 8..10 of a 17x17 gantry grid."""
    lf = coded_lf((3, 3, 5, 4, 3))
    write_named(tmp_path, lf, lambda t, s: f"cam_{t + 8}_{s + 8}.png")
    for options in ({}, {"grid": (3, 3)}, {"pattern": r"cam_(?P<t>\d+)_(?P<s>\d+)\.png"},
                    {"grid": (3, 3), "pattern": r"cam_(?P<t>\d+)_(?P<s>\d+)\.png"}):
        result = io.read_views(tmp_path, **options)
        np.testing.assert_array_equal(result.light_field, lf)
        assert result.metadata["first_index"] == (8, 8)
        assert result.metadata["files"][0][0] == "cam_8_8.png"
    # the block's own axes: rows 8..10, columns 3..5
    other = tmp_path / "offset"
    write_named(other, lf, lambda t, s: f"cam_{t + 8}_{s + 3}.png")
    assert io.read_views(other).metadata["first_index"] == (8, 3)
    # a grid whose longer side has more views than the names give is refused
    raises_naming(tmp_path, r"280 views missing for a 17x17 grid \(numbered from t=8, s=8\): "
                  r"\(t=8, s=11\).*; expected at least 17 views \(the grid's longer side\)",
                  io.read_views, tmp_path, grid=(17, 17))


def test_cli_reads_a_crop_with_grid_and_pattern(tmp_path, capsys):
    lf = (synthetic.textured_layers((3, 3, 64, 64), noise_variance=0).light_field * 255).astype(np.uint8)
    write_named(tmp_path / "crop", lf, lambda t, s: f"cam_{t + 8}_{s + 8}.png")
    out = tmp_path / "f.npz"
    assert main(["detect", str(tmp_path / "crop"), "--out", str(out), "--grid", "3", "3",
                 "--pattern", r"cam_(?P<t>\d+)_(?P<s>\d+)\.png"]) == 0
    assert load_features(out).meta["shape"] == [3, 3, 64, 64]


# ---------------------------------------------------------------- incomplete view sets

@pytest.mark.parametrize("pattern", [cross, star])
@pytest.mark.parametrize("dtype, channels, full", [(np.uint8, (3,), 255), (np.uint8, (), 255),
                                                   (np.uint16, (3,), 65535)])
def test_cross_and_star_read_as_the_grid_with_alpha(tmp_path, pattern, dtype, channels, full):
    lf = coded_lf((5, 5, 4, 6) + channels, dtype)
    present = pattern(5, 5)
    write_named(tmp_path, lf, lambda t, s: f"v_{t}_{s}.png", present)
    result = io.read_views(tmp_path)
    out = result.light_field
    C = channels[0] if channels else 1
    assert out.shape == (5, 5, 4, 6, C + 1) and out.dtype == dtype
    assert result.metadata["added_alpha"] is True
    assert result.metadata["missing"] == sorted(set(np.ndindex(5, 5)) - present)
    for t, s in np.ndindex(5, 5):
        if (t, s) in present:
            np.testing.assert_array_equal(out[t, s, ..., :C], lf[t, s].reshape(4, 6, C))
            assert (out[t, s, ..., C] == full).all()
            assert result.metadata["files"][t][s] == f"v_{t}_{s}.png"
        else:
            assert not out[t, s].any() and result.metadata["files"][t][s] is None


def test_incomplete_views_with_alpha_keep_their_channels(tmp_path):
    lf = coded_lf((3, 3, 4, 4, 4))
    write_named(tmp_path, lf, lambda t, s: f"v_{t}_{s}.png", cross(3, 3))
    result = io.read_views(tmp_path)
    assert result.light_field.shape == (3, 3, 4, 4, 4) and result.metadata["added_alpha"] is False
    np.testing.assert_array_equal(result.light_field[1, 0], lf[1, 0])
    assert not result.light_field[0, 0].any()


def epinet(T: int, S: int) -> set:
    """HCI's EPINET subset: the centre row and column and both diagonals (33 of 9x9)."""
    return star(T, S)


@pytest.mark.parametrize("shape, present, named", [
    ((5, 5), set(np.ndindex(5, 5)) - {(0, 3)}, "(t=0, s=3)"),  # not symmetric: a lost view
    ((5, 5), cross(5, 5) - {(2, 1)}, "(t=0, s=0), (t=0, s=1), (t=0, s=3)"),  # a broken cross
    ((3, 7), {(t, s) for t in range(3) for s in range(7) if s % 2 == 0}, "(t=0, s=1)"),  # columns
    ((9, 9), epinet(9, 9), "(t=0, s=1), (t=0, s=2), (t=0, s=3)"),
])
def test_incomplete_sets_of_any_pattern_read_with_alpha_and_name_the_missing(tmp_path, shape,
                                                                            present, named):
    """Issue 26 item 10: any pattern reads as the grid, alpha 0 at the missing views,
    and a MissingViewsWarning names them (all of them in metadata)."""
    lf = coded_lf(shape + (4, 4))
    write_named(tmp_path, lf, lambda t, s: f"v_{t}_{s}.png", present)
    missing = sorted(set(np.ndindex(*shape)) - present)
    with pytest.warns(liff.MissingViewsWarning) as caught:
        result = io.read_views(tmp_path)
    message = str(caught[0].message)
    assert message.startswith(str(tmp_path)) and named in message
    assert f"{len(missing)} of {shape[0] * shape[1]} views missing" in message
    assert result.metadata["missing"] == missing
    out = result.light_field
    assert out.shape == shape + (4, 4, 2)
    for t, s in np.ndindex(*shape):
        assert (out[t, s, ..., 1] == (255 if (t, s) in present else 0)).all()
        if (t, s) in present:
            np.testing.assert_array_equal(out[t, s, ..., 0], lf[t, s])


def test_too_few_views_for_their_grid_are_refused(tmp_path):
    """Fewer views than the grid's longer side: names that are not view indices."""
    lf = coded_lf((5, 5, 4, 4))
    write_named(tmp_path, lf, lambda t, s: f"v_{t}_{s}.png", {(0, 0), (4, 4), (2, 2), (1, 3)})
    raises_naming(tmp_path, r"21 views missing for a 5x5 grid \(numbered from t=0, s=0\): "
                  r"\(t=0, s=1\), .* \.\.\.; expected at least 5 views \(the grid's longer "
                  r"side\) for an incomplete set: 4 view\(s\)", io.read_views, tmp_path)


def test_huge_indices_are_refused_without_allocating(tmp_path):
    lf = coded_lf((1, 2, 4, 4))
    cv2.imwrite(str(tmp_path / "v_0_0.png"), lf[0, 0])
    cv2.imwrite(str(tmp_path / "v_1000000_1000000.png"), lf[0, 1])
    raises_naming(tmp_path, r"1000001x1000001 grid .*expected at least 1000001 views .*: 2 view",
                  io.read_views, tmp_path)


@pytest.mark.parametrize("grid, cfg", [((9, 9), True), ((9, 9), False), ((5, 7), True)])
def test_an_hci_subset_reads_with_alpha_and_names_the_missing(tmp_path, grid, cfg):
    """EPINET's 33 of 81 input_CamNNN.png (centre row, column, diagonals), with and
    without parameters.cfg (the grid: the smallest square numbering every view)."""
    T, S = grid
    lf = coded_lf(grid + (6, 8, 3))
    present = epinet(T, S) if T == S else cross(T, S)
    for t, s in present:
        cv2.imwrite(str(tmp_path / f"input_Cam{t * S + s:03d}.png"), lf[t, s])
    if cfg:
        (tmp_path / "parameters.cfg").write_text(
            f"[extrinsics]\nnum_cams_x = {S}\nnum_cams_y = {T}\n")
    with pytest.warns(liff.MissingViewsWarning, match=r"input_Cam001\.png") as caught:
        result = io.read_light_field(tmp_path)
    assert f"{T * S - len(present)} of {T * S} views missing" in str(caught[0].message)
    out = result.light_field
    assert result.format == "hci" and out.shape == grid + (6, 8, 4)
    for t, s in np.ndindex(T, S):
        assert (out[t, s, ..., 3] == (255 if (t, s) in present else 0)).all()
        if (t, s) in present:
            np.testing.assert_array_equal(out[t, s, ..., :3], lf[t, s])


def test_liff_on_a_cross_finds_the_slopes_of_the_full_grid(tmp_path, blob_scene):
    """The missing views' alpha 0 keeps them out of the focal stack: the cross finds the
    blobs at their slopes, with the contrast of the full grid, whereas the same views as
    black images (alpha dropped) darken every focal slice to 9/25 of it."""
    blobs, lf = blob_scene
    grey = np.round(lf * 255).astype(np.uint8)
    write_named(tmp_path, grey, lambda t, s: f"0421_{t:02d}_{s:02d}.png", cross(5, 5))
    subset = io.read_views(tmp_path).light_field
    truth = np.array([(b.x, b.y) for b in blobs]), np.array([b.slope for b in blobs])

    def on_blobs(kps):
        """(slope errors, responses) of the keypoints within 1.5 px of a blob."""
        pts = np.array([k.pt for k in kps]).reshape(-1, 2)
        d = np.sqrt(((pts[:, None] - truth[0][None]) ** 2).sum(-1))
        near = d.min(1) < 1.5
        errors = np.abs(liff.keypoint_slopes(kps)[near] - truth[1][d.argmin(1)[near]])
        return errors, np.array([k.response for k in kps])[near]

    full_errors, full_response = on_blobs(liff.LiFF.create().detect(grey))
    cross_errors, cross_response = on_blobs(liff.LiFF.create().detect(subset))
    assert len(cross_errors) >= 0.9 * len(full_errors) and len(cross_errors) >= 12
    assert np.median(cross_errors) < 0.05 and np.median(full_errors) < 0.05
    assert np.median(cross_response) == pytest.approx(np.median(full_response), rel=0.25)
    _, black_response = on_blobs(liff.LiFF.create().detect(subset[..., 0]))
    assert np.median(black_response) == pytest.approx(9 / 25 * np.median(cross_response), rel=0.25)


def test_cotton_star_and_cross_are_as_accurate_as_the_full_grid(tmp_path):
    """docs/INPUTS.md's figures (benchmarks/incomplete_views.py): median slope error on
    cotton, slopes -2..2 (9 slopes): full 0.019, star 0.021, cross 0.019."""
    if not COTTON.is_dir():
        pytest.skip(f"HCI 'cotton' light field not found at {COTTON}")
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from hci_depth import truth_at
    from incomplete_views import read_subset, subsets

    scene = io.read_hci(COTTON)
    medians = {}
    for name in ("star", "cross"):
        folder = tmp_path / name
        folder.mkdir()
        subset = read_subset(scene.light_field, subsets(9, 9)[name], str(folder))
        kps = liff.LiFF.create(firstSlope=-2, lastSlope=2, numSlopes=9).detect(subset)
        pts = np.array([k.pt for k in kps]).reshape(-1, 2)
        medians[name] = np.median(np.abs(liff.keypoint_slopes(kps) - truth_at(scene.gt_disparity, pts)))
        assert len(kps) > 100
    assert medians["star"] == pytest.approx(0.021, abs=0.002)
    assert medians["cross"] == pytest.approx(0.019, abs=0.002)


# ---------------------------------------------------------------- ESLF lenslet size

def lenslet_image(n: int, alpha: bool = True, size=(48, 56), seed: int = 0) -> np.ndarray:
    """A Lytro-like lenslet image: n x n views, vignetted lenslets (alpha 0 outside the
    lenslet circle), as ESLF."""
    lf = synthetic.textured_layers((n, n) + size, seed=seed).light_field
    capture = synthetic.lenslet_capture(lf, border=0)
    image = capture.transpose(2, 0, 3, 1, 4).reshape(size[0] * n, size[1] * n, 4)
    return image if alpha else np.ascontiguousarray(image[..., :3])


@pytest.mark.parametrize("n", [9, 13, 14, 15, 16])
@pytest.mark.parametrize("alpha", [True, False])
def test_lenslet_size_is_detected(tmp_path, n, alpha):
    image = lenslet_image(n, alpha)
    path = tmp_path / "capture_eslf.png"
    cv2.imwrite(str(path), image)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no LensletSizeWarning: n divides the image
        result = io.read_light_field(path)
    assert result.format == "eslf"
    assert result.metadata["lenslet_size"] == n and result.metadata["lenslet_size_detected"]
    evidence = result.metadata["lenslet_evidence"]
    assert set(evidence) == ({"rows", "columns", "alpha rows", "alpha columns"} if alpha
                             else {"rows", "columns"})
    assert all(m == n for m, _ in evidence.values())
    assert result.light_field.shape == (n, n, 48, 56, 4 if alpha else 3)
    np.testing.assert_array_equal(result.light_field[2, 3], image[2::n, 3::n])


def test_explicit_lenslet_size_is_honoured(tmp_path):
    path = tmp_path / "capture.eslf.png"
    cv2.imwrite(str(path), lenslet_image(15))
    result = io.read_eslf(path, n=14)  # wrong, but given: read as asked
    assert result.light_field.shape[:2] == (14, 14)
    assert result.metadata["lenslet_size_detected"] is False and result.metadata["lenslet_evidence"] == {}


def test_lenslet_size_of_a_cotton_eslf():
    if not COTTON.is_dir():
        pytest.skip(f"HCI 'cotton' light field not found at {COTTON}")
    lf = io.read_hci(COTTON).light_field
    image = lf.transpose(2, 0, 3, 1, 4).reshape(512 * 9, 512 * 9, 3)
    n, evidence = io.detect_lenslet_size(image)
    assert n == 9 and all(score > 0.5 for _, score in evidence.values())


@pytest.mark.parametrize("image", [
    np.random.default_rng(0).integers(0, 256, (600, 700, 3), dtype=np.uint8),  # noise
    cv2.GaussianBlur(np.random.default_rng(1).random((600, 700)).astype(np.float32), (0, 0), 3),
])
def test_images_that_are_not_lenslet_images_are_refused(tmp_path, image):
    path = tmp_path / "photo.tif"
    cv2.imwrite(str(path), image)
    raises_naming(path, r"cannot tell the lenslet size from the image \(700x600; best period and "
                  r"share of variance explained per profile: rows: .*\); expected an ESLF image "
                  r"whose lenslets show in its pixels or alpha, or the size given", io.read_eslf, path)


def test_detected_size_that_does_not_divide_the_image_warns(tmp_path):
    image = lenslet_image(15, size=(57, 57))[:854, :854]  # 854 = 61 * 14, not a multiple of 15
    path = tmp_path / "cropped.eslf.png"
    cv2.imwrite(str(path), image)
    with pytest.warns(io.LensletSizeWarning, match=r"lenslet size 15 detected .* the image "
                      r"\(854x854\) is a whole number of 14-pixel lenslets"):
        result = io.read_eslf(path)
    assert result.metadata["lenslet_size"] == 15 and result.metadata["cropped"] == (14, 14)


def test_eslf_names():
    for name in ("IMG_5776.eslf.png", "IMG_5776_eslf.png", "a/b_ESLF.PNG", "x.eslf.jpg"):
        assert io.guess_format(name) == "eslf", name
    assert io.guess_format("eslf.png") is None and io.guess_format("selfie.png") is None
    # what liff synth writes beside an ESLF image is no light field (a folder of them read
    # it as one, and failed)
    assert io.guess_format("IMG_5776.eslf.png.truth.json") is None
    assert io.guess_format("IMG_5776_eslf.txt") is None


# ---------------------------------------------------------------- MATLAB .mat

@pytest.mark.parametrize("writer", [write_mat_v5, write_mat_v73], ids=["v5", "v7.3"])
@pytest.mark.parametrize("dtype, channels", [(np.uint16, 4), (np.uint8, 3), (np.float32, 2),
                                             (np.float64, 1)])
def test_light_field_toolbox_mat_files(tmp_path, writer, dtype, channels):
    """LF(t, s, v, u, c), RGB(+weight) in MATLAB: read as (T, S, V, U, C) BGR(+weight)."""
    lf = coded_lf((3, 4, 5, 6, channels), np.uint16).astype(dtype)
    path = tmp_path / "IMG_0001__Decoded.mat"
    writer(path, {"LF": matlab_order(lf), "LensletGridModel": {"HSpacing": np.array(14.3)},
                  "GeneratedByInfo": {"mfilename": "LFUtilDecodeLytroFolder"}})
    result = io.read_light_field(path)
    assert result.format == "mat" and result.metadata["key"] == "LF"
    assert result.metadata["version"] == ("v5" if writer is write_mat_v5 else "v7.3")
    assert result.light_field.dtype == dtype and result.light_field.flags.c_contiguous
    np.testing.assert_array_equal(result.light_field, lf if channels > 1 else lf[..., 0])
    # the axis order, seen in MATLAB's terms: LF(t, s, v, u, c) is liff's [t, s, v, u, c]
    if channels == 4:
        assert result.light_field[2, 3, 4, 5, 0] == matlab_order(lf)[2, 3, 4, 5, 2]  # B is MATLAB's c=3


@pytest.mark.parametrize("writer", [write_mat_v5, write_mat_v73], ids=["v5", "v7.3"])
def test_hci_benchmark_struct(tmp_path, writer):
    """convertBlenderTo5D.m: a struct LF with fields LF (double RGB in [0, 1]) and
    disp_lowres, beside parameters (a struct of text and numbers)."""
    lf = coded_lf((3, 3, 5, 6, 3))
    disparity = np.random.default_rng(0).normal(size=(5, 6))
    struct_fields = {"LF": matlab_order(lf) / 255.0, "disp_lowres": disparity, "f": np.array(5000.0)}
    if writer is write_mat_v5:
        struct_fields["parameters"] = {"meta": {"disp_min": np.array(-1.5), "note": "text"}}
    writer(tmp_path / "LF.mat", {"LF": struct_fields})
    result = io.read_mat(tmp_path / "LF.mat")
    assert result.metadata["key"] == "LF.LF"
    np.testing.assert_allclose(result.light_field * 255, lf)
    np.testing.assert_allclose(result.gt_disparity, disparity.astype(np.float32))


def test_mat_variable_choice_and_errors(tmp_path):
    lf = coded_lf((2, 2, 3, 4))
    write_mat_v5(tmp_path / "two.mat", {"a": lf, "b": lf[::-1]})
    raises_naming(tmp_path / "two.mat", r"variables \['a', 'b'\]; expected one named 'LF', a single "
                  r"variable, or key=", io.read_mat, tmp_path / "two.mat")
    np.testing.assert_array_equal(io.read_mat(tmp_path / "two.mat", key="b").light_field, lf[::-1])
    raises_naming(tmp_path / "two.mat", r"no variable 'c'; expected one of \['a', 'b'\]",
                  io.read_mat, tmp_path / "two.mat", key="c")
    write_mat_v73(tmp_path / "logical.mat", {"LF": lf > 100})
    raises_naming(tmp_path / "logical.mat", r"\['LF'\]: MATLAB class logical; expected one of uint8, "
                  r"uint16, single, double", io.read_mat, tmp_path / "logical.mat")
    write_mat_v5(tmp_path / "int16.mat", {"LF": lf.astype(np.int16)})
    raises_naming(tmp_path / "int16.mat", r"dtype int16; expected uint8, uint16, float32 or float64",
                  io.read_mat, tmp_path / "int16.mat")
    write_mat_v73(tmp_path / "struct.mat", {"LF": {"data": lf}})
    raises_naming(tmp_path / "struct.mat", r"struct with fields \['data'\]; expected a light field, "
                  r"or a struct with a field 'LF'", io.read_mat, tmp_path / "struct.mat")
    (tmp_path / "junk.mat").write_bytes(b"junk" * 40)
    raises_naming(tmp_path / "junk.mat", r"expected a MATLAB \.mat file", io.read_mat,
                  tmp_path / "junk.mat")
    raises_naming(tmp_path / "absent.mat", r"no such file", io.read_mat, tmp_path / "absent.mat")


@pytest.mark.parametrize("bug", sorted(p.name for p in (Path(__file__).resolve().parents[2] / "fuzz"
                                                          / "corpus" / "mat").glob("bug-loadmat-*")))
def test_damaged_mat_files_scipy_would_crash_on_are_refused(bug):
    """scipy 1.17's loadmat crashes the interpreter on data type codes without a dtype;
    liff's guard (liff/io/_matv5.py) refuses them first."""
    path = Path(__file__).resolve().parents[2] / "fuzz" / "corpus" / "mat" / bug
    raises_naming(path, r"\['LF'\]: not read \(numeric data has data type \d+; expected one of "
                  r"\[1, 2, 3, 4, 5, 6, 7, 9, 12, 13\]\)", io.read_mat, path)


@pytest.mark.parametrize("module, call", [
    ("scipy.io", lambda p: io.read_mat(p)),
    ("h5py", lambda p: io.read_hdf5(p)),
])
def test_a_dependency_missing_all_the_same_says_how_to_install_it(tmp_path, monkeypatch, module,
                                                                  call):
    """SciPy and h5py are dependencies (issue 26 item 10: LFToolbox's v7.3 .mat and the
    2013 HCI benchmark's lf.h5 read on a plain pip install); an installation that
    skipped them is told which package to install."""
    (tmp_path / "x.bin").write_bytes(b"data")
    monkeypatch.setitem(sys.modules, module, None)
    package = module.split(".")[0]
    with pytest.raises(ImportError, match=re.escape(f"a dependency of liff that is not installed "
                                                    f"here: pip install {package}")):
        call(tmp_path / "x.bin")


def test_h5py_and_scipy_are_dependencies_not_extras():
    import tomllib

    with open(Path(__file__).resolve().parents[2] / "pyproject.toml", "rb") as f:
        project = tomllib.load(f)["project"]
    names = {re.match(r"[\w-]+", d).group(0) for d in project["dependencies"]}
    assert {"h5py", "scipy"} <= names


# ---------------------------------------------------------------- HDF5

def write_hci_2013(path: Path, lf_rgb: np.ndarray) -> None:
    """The 2013 HCI benchmark's lf.h5 layout: dataset LF (T, S, V, U, 3) uint8 RGB,
    GT_DEPTH (T, S, V, U), camera attributes on the root."""
    with h5py.File(path, "w") as f:
        f["LF"] = lf_rgb
        f["GT_DEPTH"] = np.ones(lf_rgb.shape[:4], np.float32)
        f.attrs.update({"dH": np.array([0.05]), "focalLength": np.array([9.375]),
                        "shift": np.array([0.5]), "vRes": np.array([lf_rgb.shape[0]])})


def test_hci_2013_hdf5(tmp_path):
    lf = coded_lf((3, 4, 5, 6, 3))
    write_hci_2013(tmp_path / "lf.h5", matlab_order(lf))  # RGB on disk
    result = io.read_light_field(tmp_path / "lf.h5")
    assert result.format == "hdf5" and result.metadata["key"] == "LF"
    np.testing.assert_array_equal(result.light_field, lf)
    assert result.metadata["datasets"] == ["GT_DEPTH", "LF"]
    assert result.metadata["attributes"] == {"dH": 0.05, "focalLength": 9.375, "shift": 0.5, "vRes": 3}


def test_hdf5_dataset_choice_and_errors(tmp_path):
    lf = coded_lf((2, 2, 3, 4))
    with h5py.File(tmp_path / "g.hdf5", "w") as f:
        f["data/lf"] = lf
        f["data/notes"] = np.zeros(3)
    np.testing.assert_array_equal(io.read_light_field(tmp_path / "g.hdf5").light_field, lf)
    np.testing.assert_array_equal(io.read_hdf5(tmp_path / "g.hdf5", key="/data/lf").light_field, lf)
    raises_naming(tmp_path / "g.hdf5", r"\['data/notes'\]: array has shape \(3,\); expected a light "
                  r"field", io.read_hdf5, tmp_path / "g.hdf5", key="data/notes")
    with h5py.File(tmp_path / "two.h5", "w") as f:
        f["a"], f["b"] = lf, lf
    raises_naming(tmp_path / "two.h5", r"datasets \['a', 'b'\]; expected one named 'LF', a single "
                  r"dataset, or key=", io.read_hdf5, tmp_path / "two.h5")
    write_mat_v73(tmp_path / "m.h5", {"LF": lf})
    raises_naming(tmp_path / "m.h5", r"a MATLAB v7\.3 file .* read it as a \.mat file \(format='mat'\)",
                  io.read_hdf5, tmp_path / "m.h5")
    np.testing.assert_array_equal(io.read_light_field(tmp_path / "m.h5", format="mat").light_field, lf)
    (tmp_path / "junk.h5").write_bytes(b"junk")
    raises_naming(tmp_path / "junk.h5", r"unreadable .*expected an HDF5 file", io.read_hdf5,
                  tmp_path / "junk.h5")


# ---------------------------------------------------------------- intensity scale

def twelve_bit(lf: np.ndarray) -> np.ndarray:
    return np.round(lf * 4095).astype(np.uint16)


@pytest.mark.parametrize("array, expected", [
    (np.full((2, 2, 8, 8), 1023, np.uint16), r"uint16 with values in \[1023, 1023\] .*10-bit "
                                             r"data\? .*bit_depth=10 \(--bit-depth 10\)"),
    (np.arange(4096, dtype=np.uint16).reshape(1, 1, 64, 64), r"values in \[0, 4095\] .*12-bit data\? "
                                                             r".*1/16 of the contrast.*bit_depth=12"),
    (np.linspace(0, 255, 2 * 2 * 8 * 8).reshape(2, 2, 8, 8), r"float64 with values in \[0, 255\] "
                                                             r".*bit_depth=8 .*lf / 255"),
    (np.linspace(-1, 1, 64).reshape(1, 1, 8, 8).astype(np.float32), r"float32 with values in "
                                                                     r"\[-1, 1\] .*scale it to \[0, 1\]"),
    (np.full((1, 1, 8, 8), 0.02, np.float32), r"uses 1/50 of the \[0, 1\] range"),
])
def test_intensity_off_scale_warns_with_the_range_and_the_fix(array, expected):
    before = array.copy()
    with pytest.warns(liff.IntensityWarning, match=expected) as record:
        message = io.check_intensity(array, source="x.npy")
    assert message.startswith("x.npy: ") and str(record[0].message) == message
    assert record[0].filename == __file__  # stacklevel=2: the caller
    np.testing.assert_array_equal(array, before)


@pytest.mark.parametrize("array", [
    np.full((2, 2, 8, 8), 65535, np.uint16), np.full((2, 2, 8, 8), 16384, np.uint16),
    np.full((2, 2, 8, 8), 3, np.uint8), np.linspace(0, 1, 256).reshape(1, 1, 16, 16),
    np.zeros((2, 2, 4, 4), np.uint16), np.zeros((2, 2, 4, 4), np.int32),
])
def test_intensity_on_scale_is_quiet(array):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert io.check_intensity(array) is None


def test_intensity_check_skips_the_weight_channel_and_samples_views():
    lf = np.zeros((9, 9, 8, 8, 4), np.uint16)
    lf[..., :3] = 4000
    lf[..., 3] = 65535  # a full weight does not make the data full-range
    with pytest.warns(liff.IntensityWarning, match=r"\[4000, 4000\]"):
        io.check_intensity(lf)
    lf[4, 4, 0, 0, :3] = 65535  # a highlight in the centre view is seen
    assert io.intensity_range(lf) == (4000, 65535)


def test_scale_bit_depth():
    lf = np.array([0, 1, 1022, 1023], np.uint16).reshape(1, 1, 2, 2)
    before = lf.copy()
    out = io.scale_bit_depth(lf, 10)
    assert out.dtype == np.uint16 and out.ravel().tolist() == [0, 64, 65471, 65535]
    np.testing.assert_array_equal(lf, before)
    weighted = np.stack([lf, np.full_like(lf, 7)], -1)
    np.testing.assert_array_equal(io.scale_bit_depth(weighted, 10)[..., 1], 7)  # weight as it was
    floats = np.array([0.0, 127.5, 255.0], np.float32).reshape(1, 1, 1, 3)
    np.testing.assert_allclose(io.scale_bit_depth(floats, 8), [[[[0, 0.5, 1]]]])
    assert io.scale_bit_depth(lf.astype(np.uint8), 8) is not None
    with pytest.raises(ValueError, match=r"^lf\.npy: values up to 1023 exceed 511, the largest 9-bit "
                                         r"value; expected bit_depth >= 10$"):
        io.scale_bit_depth(lf, 9, "lf.npy")
    with pytest.raises(ValueError, match=r"bit_depth = 12 for a uint8 light field; expected at most 8"):
        io.scale_bit_depth(lf.astype(np.uint8), 12)
    for bad in (0, 17, 2.5, "10"):
        with pytest.raises(ValueError, match=r"bit_depth = .*; expected a whole number of bits from "
                                             r"1 to 16"):
            io.scale_bit_depth(lf, bad)


def test_twelve_bit_data_finds_nothing_until_rescaled(tmp_path, blob_lf):
    """The field report: 12-bit sensor values in uint16 give (almost) no features; read
    with bit_depth=12 they give what the same data in 16 bits gives."""
    np.save(tmp_path / "raw.npy", twelve_bit(blob_lf))
    detector = liff.LiFF.create()
    reference = len(detector.detect(np.round(blob_lf * 65535).astype(np.uint16)))
    raw = io.read_light_field(tmp_path / "raw.npy").light_field
    assert len(detector.detect(raw)) <= 0.1 * reference
    with pytest.warns(liff.IntensityWarning, match="bit_depth=12"):
        io.check_intensity(raw)
    scaled = io.read_light_field(tmp_path / "raw.npy", bit_depth=12)
    assert scaled.metadata["bit_depth"] == 12
    assert abs(len(detector.detect(scaled.light_field)) - reference) <= 0.1 * reference


def test_floats_in_0_255_find_noise_until_rescaled(tmp_path, blob_lf):
    np.save(tmp_path / "f.npy", (blob_lf * 255).astype(np.float32))
    detector = liff.LiFF.create()
    reference = len(detector.detect(blob_lf.astype(np.float32)))
    raw = io.read_light_field(tmp_path / "f.npy").light_field
    assert len(detector.detect(raw)) >= 1.2 * reference
    scaled = io.read_light_field(tmp_path / "f.npy", bit_depth=8).light_field
    assert abs(len(detector.detect(scaled)) - reference) <= 0.1 * reference


def test_cli_bit_depth(tmp_path, blob_lf, capsys):
    np.save(tmp_path / "raw.npy", twelve_bit(blob_lf))
    assert main(["detect", str(tmp_path / "raw.npy"), "--out", str(tmp_path / "a.npz")]) == 0
    assert main(["detect", str(tmp_path / "raw.npy"), "--out", str(tmp_path / "b.npz"),
                 "--bit-depth", "12"]) == 0
    assert len(load_features(tmp_path / "b.npz").keypoints) > 5 * len(load_features(tmp_path / "a.npz").keypoints)
    assert main(["detect", str(tmp_path / "raw.npy"), "--out", str(tmp_path / "c.npz"),
                 "--bit-depth", "10"]) == 1
    assert re.search(r"raw\.npy: values up to 40\d\d exceed 1023, the largest 10-bit value; "
                     r"expected --bit-depth >= 12", capsys.readouterr().err)


# ---------------------------------------------------------------- masks

def test_border_mask_drops_the_black_border_only():
    lf = synthetic.textured_layers((5, 5, 80, 100), noise_variance=0).light_field
    capture = synthetic.lenslet_capture(lf, border=0.05)
    before = capture.copy()
    mask = border_mask(capture, margin=4)
    np.testing.assert_array_equal(capture, before)
    assert mask.shape == (80, 100) and mask.dtype == np.uint8 and set(np.unique(mask)) == {0, 255}
    assert not mask[0].any() and not mask[:, -1].any() and mask[40, 50] == 255
    assert (border_mask(synthetic.lenslet_capture(lf, border=0)) == 255).all()
    # a dark region inside the scene is kept; one touching the border is dropped
    dark = capture.copy()
    dark[:, :, 30:40, 40:50, :3] = 0
    dark[:, :, 30:40, 0:20, :3] = 0
    mask = border_mask(dark, margin=0)
    assert (mask[30:40, 40:50] == 255).all() and not mask[35, 10]
    # pixels no view sees (alpha 0 everywhere) are dropped
    unseen = capture.copy()
    unseen[:, :, :, 60:, 3] = 0
    assert not border_mask(unseen, margin=0)[40, 80]


def test_cli_mask_file_and_auto(tmp_path, blob_lf, capsys):
    np.save(tmp_path / "lf.npy", blob_lf)
    keep = np.zeros((96, 96), np.uint8)
    keep[:, :48] = 200
    cv2.imwrite(str(tmp_path / "mask.png"), keep)
    assert main(["detect", str(tmp_path / "lf.npy"), "--out", str(tmp_path / "m.npz"),
                 "--mask", str(tmp_path / "mask.png")]) == 0
    masked = load_features(tmp_path / "m.npz")
    expected = liff.LiFF.create().detect(blob_lf, keep)
    assert len(masked.keypoints) == len(expected) > 3
    assert all(round(k.pt[0]) < 48 for k in masked.keypoints)
    assert masked.meta["mask"] == str(tmp_path / "mask.png")

    cv2.imwrite(str(tmp_path / "small.png"), keep[:50])
    assert main(["detect", str(tmp_path / "lf.npy"), "--out", str(tmp_path / "s.npz"),
                 "--mask", str(tmp_path / "small.png")]) == 1
    assert re.search(r"small\.png: mask is 96x50 \(width x height\); expected the views' size "
                     r"96x96 of .*lf\.npy", capsys.readouterr().err)

    assert main(["detect", str(tmp_path / "lf.npy"), "--out", str(tmp_path / "n.npz"),
                 "--mask", str(tmp_path / "missing.png")]) == 1
    assert "--mask " + str(tmp_path / "missing.png") + ": no such file" in capsys.readouterr().err
    assert not (tmp_path / "n.npz").exists()

    capture = synthetic.lenslet_capture(synthetic.textured_layers((5, 5, 96, 128)).light_field,
                                        border=0.02)
    np.save(tmp_path / "capture.npy", capture)
    assert main(["detect", str(tmp_path / "capture.npy"), "--out", str(tmp_path / "a.npz"),
                 "--mask", "auto"]) == 0
    auto = border_mask(capture)
    kept = load_features(tmp_path / "a.npz").keypoints
    assert len(kept) == len(liff.LiFF.create().detect(capture, auto))
    assert all(auto[round(k.pt[1]), round(k.pt[0])] for k in kept)


def mosaic_image(lf: np.ndarray) -> np.ndarray:
    """(T, S, V, U[, C]) as one image of T x S tiles."""
    T, S, V, U = lf.shape[:4]
    return lf.transpose((0, 2, 1, 3) + tuple(range(4, lf.ndim))).reshape((T * V, S * U) + lf.shape[4:])


def eslf_of(lf: np.ndarray) -> np.ndarray:
    """(T, S, V, U[, C]) as an ESLF image (no vignetting, no alpha)."""
    T, S, V, U = lf.shape[:4]
    return lf.transpose((2, 0, 3, 1) + tuple(range(4, lf.ndim))).reshape((V * T, U * S) + lf.shape[4:])


def disks(views: int, size) -> np.ndarray:
    """liff synth disks as it writes it: the paper's low-contrast disks, 16-bit."""
    shape = (views, views) + tuple(size)
    lf = synthetic.render_disks(synthetic.paper_disks(shape=shape, seed=0), shape)
    return np.round(np.clip(lf, 0, 1) * 65535).astype(np.uint16)


@pytest.mark.parametrize("views, size", [(5, (96, 128)), (5, (128, 96)), (7, (96, 128)),
                                         (3, (64, 80)), (5, (64, 80))])
def test_a_mosaic_is_not_taken_for_a_lenslet_image(views, size):
    """Break test 5: the mosaics of liff synth disks show a period along one axis only
    (19 along the columns of 5x5 views of 96x128, 0.33 of the variance; 21 along the
    rows, 0.21), which a lenslet image, whose lenslets are square, shows along both."""
    with pytest.raises(ValueError, match=r"cannot tell the lenslet size .* along both rows "
                       r"and columns|the lenslet size is ambiguous: rows: (\d+) .*columns: (?!\1 )"):
        io.detect_lenslet_size(mosaic_image(disks(views, size)))


@pytest.mark.parametrize("views, size", [(5, (96, 128)), (5, (128, 96)), (5, (160, 240)),
                                         (7, (128, 96)), (9, (96, 128)), (14, (64, 80))])
def test_lenslet_images_of_low_contrast_scenes_are_detected(views, size):
    """The same scenes as ESLF images (no vignetting: only the content shows the
    lenslets), detected along both axes; 5x5 views of 128x96 and 160x240 were refused or
    taken on one profile's word before the profiles were detrended."""
    n, evidence = io.detect_lenslet_size(eslf_of(disks(views, size)))
    assert n == views and evidence["rows"][0] == evidence["columns"][0] == views
