"""The command line as users expect it and as the README documents it (issue 12,
sections 3 and 4): version, help, flags in errors, the README's claims, multi-pose
captures for `liff sfm`, and warnings that say when a result means nothing. (Its
pictures are tests/outputs/test_pictures.py, the Feature2D limits
tests/detector/test_feature2d_limits.py.)"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys

import cv2
import numpy as np
import pytest

import liff
from liff.cli import build_parser, main

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def subcommands():
    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def test_version_and_python_dash_m_liff():
    for argv in (["-m", "liff", "--version"], ["-m", "liff.cli", "--version"]):
        done = subprocess.run([sys.executable, *argv], capture_output=True, text=True)
        assert done.returncode == 0 and done.stdout.startswith(f"liff {liff.__version__} (core on OpenCV ")
        assert f"cv2 {cv2.__version__}" in done.stdout
    done = subprocess.run([sys.executable, "-m", "liff", "synth"], capture_output=True, text=True)
    assert done.returncode == 2 and "--out" in done.stderr


@pytest.mark.parametrize("name", sorted(subcommands()))
def test_every_subcommand_has_a_description_and_every_option_help(name):
    parser = subcommands()[name]
    assert parser.description and len(parser.description) > 40
    for action in parser._actions:
        assert action.help and action.help != argparse.SUPPRESS, action.option_strings or action.dest


@pytest.fixture(scope="module")
def eslf(tmp_path_factory):
    path = tmp_path_factory.mktemp("eslf") / "scene.eslf.png"
    assert main(["synth", "disks", "--out", str(path), "--format", "eslf", "--views", "5",
                 "--size", "32", "32"]) == 0
    return path


@pytest.mark.parametrize("options, flag, keyword", [
    (["--lenslet", "5", "--keep-views", "20"], "--keep-views 20x20", "keep 20"),
    (["--key", "x"], "option(s) --key do not apply", "option(s) key"),
    (["--format", "eslf", "--key", "x"], "expected --lenslet, --keep-views", "expected n, keep"),
    (["--grid", "0", "3", "--format", "mosaic"], "--grid (0, 3)", ": grid (0, 3)"),
    (["--contrast-threshold", "-1"], "--contrast-threshold = -1", "contrastThreshold"),
    (["--first-slope", "2", "--last-slope", "1"], "--first-slope = 2 > --last-slope = 1",
     "firstSlope")])
def test_errors_name_the_flag_not_the_python_keyword(eslf, tmp_path, capsys, options, flag, keyword):
    assert main(["detect", str(eslf), "--out", str(tmp_path / "f.npz"), *options]) == 1
    err = capsys.readouterr().err
    assert flag in err and keyword not in err


def readme_commands():
    with open(os.path.join(ROOT, "README.md")) as f:
        text = f.read()
    blocks = "\n".join(re.findall(r"^```bash\n(.*?)^```", text, re.M | re.S))
    return [line.split("#")[0].split() for line in re.findall(r"^liff .*$", blocks, re.M)]


def test_the_readme_command_lines_parse():
    commands = readme_commands()
    assert len(commands) >= 8
    for argv in commands:
        if argv[1:] == ["--version"]:
            continue
        build_parser().parse_args(argv[1:])  # exits (fails the test) on a wrong option


def test_the_readme_table_of_options_is_true():
    """Each row of the README's table: which subcommands take the reader and detector
    options, and the own options named."""
    with open(os.path.join(ROOT, "README.md")) as f:
        rows = re.findall(r"^\| (`[a-z`, ]+`) \| [^|]+ \| (yes|no) \| (yes|no) \| ([^|]+) \|$",
                          f.read(), re.M)
    parsers = subcommands()
    seen = set()
    for names, reader, detector, own in rows:
        for name in re.findall(r"`(\w+)`", names):
            options = set(parsers[name]._option_string_actions)
            assert ("--keep-views" in options and "--preprocess" in options) == (reader == "yes"), name
            assert ("--contrast-threshold" in options) == (detector == "yes"), name
            assert set(re.findall(r"--[\w-]+", own)) <= options, name
            seen.add(name)
    assert seen == set(parsers)


@pytest.fixture(scope="module")
def poses(tmp_path_factory):
    """`liff synth poses`: 4 poses of 3x3 views, and an unrelated light field beside."""
    folder = tmp_path_factory.mktemp("capture") / "poses"
    assert main(["synth", "poses", "--out", str(folder), "--views", "3", "--size", "120", "160",
                 "--poses", "4"]) == 0
    return folder


def test_synth_poses_writes_light_fields_and_their_poses(poses):
    import json

    assert sorted(os.listdir(poses)) == [f"pose{i:02d}.npz" for i in range(4)]
    with open(str(poses) + ".truth.json") as f:
        truth = json.load(f)
    assert [p["name"] for p in truth["poses"]] == ["pose00", "pose01", "pose02", "pose03"]
    assert np.allclose(np.array(truth["poses"][1]["rotation"]) @ np.array(truth["poses"][1]["rotation"]).T,
                       np.eye(3))
    assert liff.io.read_light_field(poses / "pose00.npz").light_field.shape == (3, 3, 120, 160)


def test_sfm_takes_a_folder_and_says_when_images_are_left_out(poses, tmp_path, capsys):
    assert main(["sfm", str(poses), "--workspace", str(tmp_path / "ws"), "--preprocess"]) == 0
    out, err = capsys.readouterr()
    assert "4 images" in out and re.search(r"registered images\s+100%", out)
    assert "incremental mapping" in err and "done in" in err  # progress of each step
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for name in os.listdir(poses):
        os.symlink(poses / name, mixed / name)
    assert main(["synth", "layers", "--out", str(mixed / "unrelated.npz"), "--views", "3",
                 "--size", "120", "160"]) == 0
    assert main(["sfm", str(mixed), "--workspace", str(tmp_path / "ws2"), "--preprocess"]) == 1
    out, err = capsys.readouterr()
    assert "5 images" in out and "only 4 of 5 images registered" in err
    # Issue 26 item 7: each left-out capture is named, with why.
    assert re.search(r"unrelated\.npz \(image unrelated\.png\): no verified match", err)
    # (named by the progress lines, which name each input done, but not as left out)
    assert "pose00.npz" not in "\n".join(line for line in err.splitlines()
                                         if "file(s) done, last" not in line)
    blank = np.zeros((3, 3, 120, 160), np.uint8)  # a capture with no features
    os.remove(mixed / "unrelated.npz")
    np.save(mixed / "blank.npy", blank)
    assert main(["sfm", str(mixed), "--workspace", str(tmp_path / "ws3"), "--preprocess"]) == 1
    err = capsys.readouterr().err
    assert "only 4 of 5 images registered" in err
    assert re.search(r"blank\.npy \(image blank\.png\): no features \(0 keypoints\)", err)


def test_colmap_log_is_quiet(poses, tmp_path, capfd):
    assert main(["sfm", str(poses), "--workspace", str(tmp_path / "ws"), "--preprocess"]) == 0
    assert not re.search(r"^[IW]\d{4} ", capfd.readouterr().err, re.M)  # glog's INFO / WARNING


def test_match_warns_when_inliers_mean_nothing(poses, tmp_path, capsys):
    """Two unrelated scenes (the issue's case: 7 inliers) are warned about; two poses of
    one scene are not."""
    other = tmp_path / "other"
    assert main(["synth", "poses", "--out", str(other), "--views", "5", "--poses", "2",
                 "--seed", "1"]) == 0
    assert main(["synth", "poses", "--out", str(tmp_path / "p0"), "--views", "5", "--poses", "2"]) == 0
    assert main(["match", str(tmp_path / "p0" / "pose00.npz"), str(other / "pose00.npz"),
                 "--ratio", "0.95"]) == 0
    out, err = capsys.readouterr()
    assert "inliers (homography, 3 px): 7" in out and "liff match: warning: 7 inliers are too few" in err
    assert main(["match", str(tmp_path / "p0" / "pose00.npz"), str(tmp_path / "p0" / "pose01.npz")]) == 0
    out, err = capsys.readouterr()
    assert int(re.search(r"inliers \(homography, 3 px\): (\d+)", out).group(1)) > 100
    assert "warning" not in err


def test_the_readme_shows_what_the_demo_prints(tmp_path, capsys):
    """README, "Set-up": the demo's summary block is what `liff demo` prints, all but
    the seconds (and the picture's folder)."""
    with open(os.path.join(ROOT, "README.md")) as f:
        text = f.read()
    block = re.search(r"^```\n(light field: 9x9 views.*?)^```", text, re.M | re.S)
    assert block, "README has no demo output block"
    assert main(["demo", "--out", str(tmp_path / "liff-demo")]) == 0
    printed = capsys.readouterr().out

    def normalise(output: str) -> list:
        lines = [re.sub(r"in \d+\.\d+ s", "in T s", line) for line in output.strip().splitlines()]
        return [line.rsplit(": ", 1)[0] if line.startswith("picture of") else line
                for line in lines]

    assert normalise(printed) == normalise(block.group(1))
