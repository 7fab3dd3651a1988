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
from liff.cli import main
from liff.cli.calibration import add_camera_options, camera_from_args, read_camera_file

from test_metric import toolbox_H


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
