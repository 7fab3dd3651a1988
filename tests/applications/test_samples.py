"""The Python samples run (on built-in data) and say what they should."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import cv2

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "samples")


def run_sample(name, *args):
    result = subprocess.run([sys.executable, os.path.join(SAMPLES, name), *args],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert not re.search(r"^[IW]\d{4} ", result.stderr, re.M), result.stderr  # COLMAP's log: quiet
    return result.stdout


def test_opencv_swap_recovers_the_translation(tmp_path):
    out = tmp_path / "matches.png"
    printed = run_sample("opencv_swap.py", "--out", str(out))
    tx, ty = map(float, re.search(r"translation \(([-\d.]+), ([-\d.]+)\)", printed).groups())
    assert abs(tx + 12) < 0.2 and abs(ty + 7) < 0.2
    assert int(re.search(r"(\d+) inliers", printed).group(1)) >= 20
    assert cv2.imread(str(out)) is not None


def test_features_3d_on_the_built_in_scene(tmp_path):
    out = tmp_path / "f3d.png"
    printed = run_sample("features_3d.py", "--out", str(out), "--hci", "")
    assert float(re.search(r"median \|slope - ground truth\| ([\d.]+)", printed).group(1)) < 0.05
    assert cv2.imread(str(out)) is not None


def test_colmap_reconstruction_from_a_folder_of_light_fields(tmp_path):
    printed = run_sample("colmap_reconstruction.py", "--workspace", str(tmp_path / "ws"))
    assert printed.count("features") == 5
    registered = int(re.search(r"registered (\d+)% of 5 images", printed).group(1))
    assert registered >= 80
    assert int(re.search(r"(\d+) 3D points", printed).group(1)) > 100


def test_metric_pose_recovers_the_motion_in_metres():
    printed = run_sample("metric_pose.py")
    error = float(re.search(r"translation error ([\d.]+)%", printed).group(1))
    assert error < 2.0
    assert float(re.search(r"rotation error ([\d.]+) deg", printed).group(1)) < 0.5
    assert int(re.search(r"inlier matches: (\d+)", printed).group(1)) >= 50
