"""``--camera-file`` for liff pose and liff sfm (issue 31 item 4): liff synth's truth
file and the Light Field Toolbox's calibration output, with errors naming the field."""

from __future__ import annotations

import argparse
import json
import re

import numpy as np
import pytest
import scipy.io

import liff
from lfhelpers import toolbox_H
from liff.cli import main
from liff.cli.calibration import add_camera_options, camera_from_args, read_camera_file


@pytest.fixture(scope="module")
def poses(tmp_path_factory):
    folder = tmp_path_factory.mktemp("synth") / "poses"
    assert main(["synth", "poses", "--out", str(folder), "--views", "3", "--size", "120", "160",
                 "--poses", "2", "--seed", "4"]) == 0
    return folder


def parse(*argv):
    parser = argparse.ArgumentParser()
    add_camera_options(parser)
    return camera_from_args(parser.parse_args(list(argv)))


def test_liff_synths_truth_file_is_its_camera(poses):
    truth_path = str(poses) + ".truth.json"
    with open(truth_path, encoding="utf-8") as f:
        truth = json.load(f)
    k = truth["intrinsics"]
    expected = liff.LightFieldCamera(k["focal"], truth["baseline"], (k["cx"], k["cy"]),
                                     truth["focus_depth"])
    assert parse("--camera-file", truth_path) == expected == read_camera_file(truth_path)


def test_liff_pose_with_the_camera_file_equals_the_camera_by_hand(poses, capsys):
    truth_path = str(poses) + ".truth.json"
    with open(truth_path, encoding="utf-8") as f:
        truth = json.load(f)
    k = truth["intrinsics"]
    pair = [str(poses / "pose00.npz"), str(poses / "pose01.npz")]
    assert main(["pose", *pair, "--camera-file", truth_path]) == 0
    from_file = capsys.readouterr().out
    assert main(["pose", *pair, "--camera", *(repr(v) for v in (k["focal"], truth["baseline"],
                                                                  k["cx"], k["cy"])),
                 "--focus-distance", repr(truth["focus_depth"])]) == 0
    assert capsys.readouterr().out == from_file and "|t| = " in from_file


def test_pose_out_never_replaces_the_camera_file_it_reads(poses, tmp_path, capsys):
    """--out is an output: the camera file is an input like the light fields, refused as
    --out even with --overwrite, before anything is read or detected."""
    camera = tmp_path / "cam.json"
    camera.write_text((poses.parent / (poses.name + ".truth.json")).read_text())
    before = camera.read_text()
    pair = [str(poses / "pose00.npz"), str(poses / "pose01.npz")]
    assert main(["pose", *pair, "--camera-file", str(camera), "--out", str(camera),
                 "--overwrite"]) == 1
    assert "--out" in capsys.readouterr().err and camera.read_text() == before


@pytest.mark.parametrize("drop, named", [("baseline", "baseline"), ("focus_depth", "focus_depth"),
                                         ("intrinsics.cx", "intrinsics.cx")])
def test_a_truth_file_missing_a_field_is_refused_naming_it(poses, tmp_path, drop, named):
    with open(str(poses) + ".truth.json", encoding="utf-8") as f:
        truth = json.load(f)
    parent, _, key = drop.rpartition(".")
    del (truth[parent] if parent else truth)[key]
    path = tmp_path / "truth.json"
    path.write_text(json.dumps(truth))
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}: no {re.escape(named)}; "
                                         r"expected liff synth's truth with intrinsics.focal"):
        read_camera_file(str(path))


@pytest.mark.parametrize("layout", ["CalInfo.json", "RectOptions.json", "decoded.mat", "cal.mat",
                                    "decoded_v73.mat"])
def test_the_light_field_toolboxs_output_is_read(tmp_path, layout):
    """CalInfo.json's EstCamIntrinsicsH; a decoded light field's RectOptions.
    RectCamIntrinsicsH, in JSON or in the .mat the toolbox saves."""
    H = toolbox_H(h11=3e-4, views=11)
    expected = liff.LightFieldCamera.from_lftoolbox(H)
    path = tmp_path / layout
    if layout == "CalInfo.json":
        path.write_text(json.dumps({"EstCamIntrinsicsH": H.tolist(),
                                    "EstCamDistortionV": [0, 0, 0, 0, 0]}))
    elif layout == "RectOptions.json":
        path.write_text(json.dumps({"RectOptions": {"RectCamIntrinsicsH": H.tolist()}}))
    elif layout == "decoded.mat":
        scipy.io.savemat(path, {"LF": np.zeros((2, 2, 2, 2)),
                                "RectOptions": {"RectCamIntrinsicsH": H, "NInverse_Distortion_Iters": 2}})
    elif layout == "cal.mat":
        scipy.io.savemat(path, {"EstCamIntrinsicsH": H})
    else:  # save('-v7.3'): HDF5, column-major (h5py sees the transpose)
        import h5py

        with h5py.File(path, "w") as f:
            f.create_dataset("RectOptions/RectCamIntrinsicsH", data=H.T)
            f.create_dataset("LF", data=np.zeros((2, 2, 2, 2)))
    assert read_camera_file(str(path)) == expected


def test_camera_files_that_hold_no_camera_are_refused_clearly(tmp_path):
    cases = {"list.json": ("[1, 2]", r"a JSON list; expected an object"),
             "other.json": ('{"focal": 3}', r"none of intrinsics.focal, .*EstCamIntrinsicsH"),
             "broken.json": ("{", r"unreadable JSON"),
             "badH.json": ('{"EstCamIntrinsicsH": [[1, 2], [3, 4]]}', r"EstCamIntrinsicsH: .*5"),
             "text.json": ('{"baseline": "wide", "intrinsics": {"focal": 1, "cx": 0, "cy": 0}, '
                           '"focus_depth": 1}', r"baseline is \"wide\"; expected a number")}
    for name, (content, message) in cases.items():
        (tmp_path / name).write_text(content)
        with pytest.raises(ValueError, match=re.escape(str(tmp_path / name)) + ".*" + message):
            read_camera_file(str(tmp_path / name))
    with pytest.raises(ValueError, match="no such file; expected a camera file"):
        read_camera_file(str(tmp_path / "absent.json"))


def test_pose_and_sfm_offer_the_camera_file(tmp_path, capsys):
    from liff.cli import build_parser

    parser = build_parser()
    for command in ("pose", "sfm"):
        args = parser.parse_args([command, "a", "b", "--camera-file", "c.json"]
                                 + (["--workspace", "w"] if command == "sfm" else []))
        assert args.camera_file == "c.json"
    assert main(["pose", "a.npz", "b.npz", "--camera-file", str(tmp_path / "none.json")]) == 1
    assert "none.json: no such file; expected a camera file" in capsys.readouterr().err


@pytest.mark.parametrize("field, value, message", [
    ("baseline", True, "baseline is true; expected a number"),
    ("baseline", "0.04", 'baseline is "0.04"; expected a number'),
    ("focal", None, "no intrinsics.focal; expected liff synth's truth"),
    ("baseline", float("nan"), "baseline = nan; expected a positive finite number"),
    ("baseline", -0.04, "baseline = -0.04; expected a positive finite number"),
])
def test_a_truth_file_field_that_is_no_number_is_refused_naming_file_and_field(
        tmp_path, field, value, message):
    """Break test of issue 31: true and "0.04" were taken as numbers (float()), and a
    nan or negative baseline's error did not name the file."""
    truth = {"intrinsics": {"focal": 300.0, "cx": 63.5, "cy": 47.5}, "baseline": 0.04,
             "focus_depth": 5.0}
    (truth["intrinsics"] if field == "focal" else truth)[field] = value
    path = tmp_path / "cam.truth.json"
    path.write_text(json.dumps(truth))
    with pytest.raises(ValueError, match=re.escape(f"{path}: {message}")):
        read_camera_file(str(path))


def test_a_calibration_of_another_view_size_is_refused_naming_both_sizes_and_the_file(
        poses, tmp_path, capsys):
    """Break test of issue 31: a truth file of 320x240 views was taken for 160x120 views
    (feature files, light fields, liff pose and liff sfm) and gave a pose, silently."""
    other = tmp_path / "other"
    assert main(["synth", "poses", "--out", str(other), "--views", "3", "--size", "60", "80",
                 "--poses", "2", "--seed", "4", "--quiet"]) == 0
    truth = str(other) + ".truth.json"
    pair = [str(poses / "pose00.npz"), str(poses / "pose01.npz")]
    expected = (f"{pair[0]}: views of 160x120 pixels, but --camera-file {truth} is the "
                f"calibration of views of 80x60 pixels; expected the calibration of these "
                f"inputs' camera")
    assert main(["pose", *pair, "--camera-file", truth]) == 1
    captured = capsys.readouterr()
    assert expected in captured.err and "R =" not in captured.out
    features = [str(tmp_path / "a.npz"), str(tmp_path / "b.npz")]
    for source, out in zip(pair, features):
        assert main(["detect", source, "--out", out, "--quiet"]) == 0
    capsys.readouterr()
    assert main(["pose", *features, "--camera-file", truth]) == 1
    assert (f"{features[0]}: views of 160x120 pixels, but --camera-file {truth} is the "
            "calibration of views of 80x60 pixels") in capsys.readouterr().err
    # liff sfm: refused before a database is written
    workspace = tmp_path / "ws"
    assert main(["sfm", *pair, "--workspace", str(workspace), "--camera-file", truth]) == 1
    assert expected in capsys.readouterr().err
    assert not (workspace / "database.db").exists()


def hci_parameters(folder, width=80, height=60, cams=(3, 3)):
    folder.mkdir(exist_ok=True)
    (folder / "parameters.cfg").write_text(
        "[intrinsics]\nfocal_length_mm = 100\nsensor_size_mm = 35\n"
        f"image_resolution_x_px = {width}\nimage_resolution_y_px = {height}\n"
        f"[extrinsics]\nbaseline_mm = 40\nfocus_distance_m = 5\nnum_cams_x = {cams[1]}\n"
        f"num_cams_y = {cams[0]}\n")
    return folder


@pytest.mark.parametrize("width, height, cams, stated", [
    (160, 120, (4, 4), "160x120 pixels in a 4x4 grid"),
    (320, 240, (3, 3), "320x240 pixels in a 3x3 grid")])
def test_an_hci_scene_of_another_view_size_or_grid_is_refused(poses, tmp_path, capsys, width,
                                                              height, cams, stated):
    scene = hci_parameters(tmp_path / "scene", width, height, cams)
    pair = [str(poses / "pose00.npz"), str(poses / "pose01.npz")]
    assert main(["pose", *pair, "--hci", str(scene)]) == 1
    assert (f"{pair[0]}: views of 160x120 pixels in a 3x3 grid, but --hci {scene} is the "
            f"calibration of views of {stated}") in capsys.readouterr().err
    for cams in ((3, 3), (5, 7)):  # the inputs' own grid, or one they are the centre of
        hci_parameters(scene, 160, 120, cams)
        assert main(["pose", *pair, "--hci", str(scene)]) == 0
        assert "R =" in capsys.readouterr().out
    hci_parameters(scene, 160, 120, (4, 3))  # 3 views are no centred part of 4
    assert main(["pose", *pair, "--hci", str(scene)]) == 1
    assert ("in a 4x3 grid; expected the calibration of these inputs' camera (the same view "
            "size, and its grid or a centred part of it") in capsys.readouterr().err


def test_a_toolbox_file_is_checked_against_the_light_field_it_holds_or_its_principal_point(
        poses, tmp_path, capsys):
    """A decoded light field's .mat states the view size and grid (its LF's header); a
    calibration without one (CalInfo.json, a text H) must at least put the principal
    point inside the inputs' views."""
    H = toolbox_H(h11=3e-4, views=3, pixels=301)  # principal point (157, 146)
    pair = [str(poses / "pose00.npz"), str(poses / "pose01.npz")]
    decoded = tmp_path / "IMG_0001__Decoded.mat"
    scipy.io.savemat(decoded, {"LF": np.zeros((5, 5, 434, 625, 4), np.uint16),
                               "RectOptions": {"RectCamIntrinsicsH": H}}, do_compression=True)
    assert main(["pose", *pair, "--camera-file", str(decoded)]) == 1
    assert (f"{pair[0]}: views of 160x120 pixels in a 3x3 grid, but --camera-file {decoded} is "
            "the calibration of views of 625x434 pixels in a 5x5 grid") in capsys.readouterr().err
    calinfo = tmp_path / "CalInfo.json"
    calinfo.write_text(json.dumps({"EstCamIntrinsicsH": H.tolist()}))
    text = tmp_path / "H.txt"
    np.savetxt(text, H)
    for flag, path in (("--camera-file", calinfo), ("--lftoolbox", text)):
        assert main(["pose", *pair, flag, str(path)]) == 1
        assert (f"{pair[0]}: views of 160x120 pixels, but the principal point (157, 146) of "
                f"{flag} {path} lies outside them") in capsys.readouterr().err
