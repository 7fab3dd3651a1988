"""Calibrated light fields: LightFieldCamera, metric pose, scale-sensitive matching,
metric SfM and the ``liff pose`` command (docs/METRIC.md)."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import liff
import liff.cli.pose
from lfhelpers import toolbox_H
from liff import captures
from liff.cli import main
from liff.io import read_hci, read_pfm

HCI = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "hci" / "cotton"
# The captures' slopes span [-1, 1] from the back wall to the nearest box; the detector
# searches a little beyond (the one place these tests choose a slope range).
CAPTURE_SLOPES = dict(firstSlope=-1.25, lastSlope=1.25, numSlopes=21)


def keypoint(x, y, slope, size=4.0, response=0.05):
    return cv2.KeyPoint(float(x), float(y), size, -1, response, 0, int(round(slope * liff.SLOPE_SCALE)))


def camera_of(capture):
    k = capture.intrinsics
    return liff.LightFieldCamera(k.focal, capture.baseline, (k.cx, k.cy), capture.focus_depth)


def true_relative(capture, i, j):
    a, b = capture.poses[i], capture.poses[j]
    R = b.rotation @ a.rotation.T
    return R, b.translation - R @ a.translation


# --- the camera model ------------------------------------------------------------------

def test_depth_and_slope_are_inverse_and_infinity_is_nan():
    camera = liff.LightFieldCamera(500.0, 0.01, (100.0, 80.0), focus_distance=2.0)
    z = np.array([0.5, 1.0, 2.0, 10.0, 1e6])
    assert np.allclose(camera.depth(camera.slopes(z)), z, rtol=1e-9)
    assert camera.slopes([2.0])[0] == pytest.approx(0.0)  # slope 0 at the focus distance
    assert camera.slopes([1.0])[0] > 0 > camera.slopes([4.0])[0]  # nearer: larger slope
    at_infinity = camera.slope_at_infinity
    assert at_infinity == pytest.approx(-500 * 0.01 / 2.0)
    assert np.isnan(camera.depth([at_infinity, at_infinity - 0.1])).all()
    parallel = liff.LightFieldCamera(500.0, 0.01, (0.0, 0.0))
    assert parallel.depth([1.0])[0] == pytest.approx(5.0)  # Z = f b / slope
    assert np.isnan(parallel.depth([0.0, -1.0])).all()


def test_points_project_back_to_their_keypoints_and_sizes_scale_with_depth():
    camera = liff.LightFieldCamera(300.0, 0.04, (159.5, 119.5), focus_distance=5.0)
    kps = [keypoint(10.0, 20.0, 0.5, size=6.0), keypoint(200.0, 100.0, -0.3, size=3.0),
           keypoint(50.0, 50.0, -3.0)]  # beyond infinity
    X = camera.points_3d(kps)
    assert X.shape == (3, 3) and X.dtype == np.float64
    z = camera.depth(liff.keypoint_slopes(kps))
    assert np.allclose(X[:2, 2], z[:2])
    uv = X[:2, :2] / X[:2, 2:] * 300.0 + [159.5, 119.5]
    assert np.allclose(uv, [[10.0, 20.0], [200.0, 100.0]])
    assert np.isnan(X[2]).all()
    size = camera.metric_size(kps)
    assert np.allclose(size[:2], np.array([6.0, 3.0]) * z[:2] / 300.0)
    assert np.isnan(size[2])
    assert camera.points_3d([]).shape == (0, 3)


@pytest.mark.parametrize("kwargs, message", [
    (dict(focal_length=0), "focal_length"), (dict(focal_length=-1), "focal_length"),
    (dict(focal_length=float("nan")), "focal_length"), (dict(focal_length="a"), "focal_length"),
    (dict(focal_length=math.inf), "focal_length"), (dict(baseline=0), "baseline"),
    (dict(baseline=-0.1), "baseline"), (dict(principal_point=(1.0,)), "principal_point"),
    (dict(principal_point=(1.0, float("nan"))), "principal_point"),
    (dict(principal_point=None), "principal_point"), (dict(focus_distance=0), "focus_distance"),
    (dict(focus_distance=-2), "focus_distance"), (dict(focus_distance=float("nan")), "focus_distance"),
    (dict(focal_length="1000"), "focal_length"), (dict(baseline=True), "baseline"),
])
def test_bad_camera_arguments_name_the_range(kwargs, message):
    args = dict(focal_length=300.0, baseline=0.04, principal_point=(10.0, 10.0), focus_distance=5.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=f"{message}.*expected"):
        liff.LightFieldCamera(**args)


def test_keypoints_must_be_keypoints():
    camera = liff.LightFieldCamera(300.0, 0.04, (0.0, 0.0))
    with pytest.raises(ValueError, match="cv2.KeyPoint"):
        camera.points_3d([(1.0, 2.0)])


# --- HCI ---------------------------------------------------------------------------------

def test_keypoints_without_a_slope_are_refused_where_the_slope_is_the_measurement():
    """cv2.SIFT's keypoints have class_id -1, which would read as slope -1.5e-5: a
    confident wrong depth, pose or size. Refused with what was expected."""
    camera = liff.LightFieldCamera(500.0, 0.01, (64.0, 48.0))
    plain = [cv2.KeyPoint(10.0 + i, 20.0, 4.0) for i in range(4)]
    descriptors = np.eye(4, 128, dtype=np.float32)
    for call in (lambda: camera.points_3d(plain), lambda: camera.metric_size(plain),
                 lambda: liff.estimate_relative_pose(plain, descriptors, plain, descriptors, camera)):
        with pytest.raises(ValueError, match="class_id -1.*expected keypoints from liff.LiFF"):
            call()
    assert camera.points_3d([keypoint(10, 20, 0.5)]).shape == (1, 3)


@pytest.fixture(scope="module")
def cotton():
    if not HCI.is_dir():
        pytest.skip(f"HCI 'cotton' light field not found at {HCI}")
    return HCI


def test_hci_camera_reproduces_the_ground_truth_depth(cotton):
    camera = liff.LightFieldCamera.from_hci(cotton)
    assert camera.focal_length == pytest.approx(100.0 / 35.0 * 512)
    assert camera.baseline == pytest.approx(0.025) and camera.focus_distance == pytest.approx(4.25)
    assert camera.principal_point == (255.5, 255.5)
    assert liff.LightFieldCamera.from_hci(cotton / "parameters.cfg") == camera
    disparity = read_pfm(cotton / "gt_disp_lowres.pfm")
    depth = read_pfm(cotton / "gt_depth_lowres.pfm")
    relative = np.abs(camera.depth(disparity.ravel()) - depth.ravel()) / depth.ravel()
    # The relation is exact; the two low-resolution maps differ only where they
    # average pixels of several depths (object edges).
    assert np.median(relative) < 1e-5
    assert np.percentile(relative, 95) < 1e-4
    # the reader returns the same camera
    assert read_hci(cotton).camera == camera
    assert liff.io.read_light_field(cotton).metadata["camera"] == camera


def test_hci_camera_errors_name_file_and_entry(tmp_path):
    with pytest.raises(ValueError, match="parameters.cfg: no such file"):
        liff.LightFieldCamera.from_hci(tmp_path)
    cfg = tmp_path / "parameters.cfg"
    cfg.write_text("[intrinsics]\nfocal_length_mm = 100\nsensor_size_mm = 35\n"
                   "image_resolution_x_px = 512\nimage_resolution_y_px = 512\n"
                   "[extrinsics]\nbaseline_mm = 25\n")
    with pytest.raises(ValueError, match=r"\[extrinsics\] focus_distance_m missing"):
        liff.LightFieldCamera.from_hci(cfg)
    cfg.write_text(cfg.read_text() + "focus_distance_m = -4\n")
    with pytest.raises(ValueError, match=r"focus_distance_m = '-4'; expected a positive"):
        liff.LightFieldCamera.from_hci(cfg)


# --- Light Field Toolbox ------------------------------------------------------------------

# (toolbox_H, the calibration matrix these tests use, is in lfhelpers: tests/cli/test_camera_file.py
# uses it too.)

def test_lftoolbox_camera_agrees_with_the_toolbox_rays():
    """Slopes simulated from H's own ray model (a ray through pixel k of view i crosses
    z = 0 at s and has direction u: X = s + u Z) give back the depth and position."""
    H = toolbox_H()
    camera = liff.LightFieldCamera.from_lftoolbox(H)
    given = liff.LightFieldCamera.from_lftoolbox(H, views=(9, 9))
    assert np.allclose([given.focal_length, given.baseline, given.focus_distance, *given.principal_point],
                       [camera.focal_length, camera.baseline, camera.focus_distance, *camera.principal_point])
    assert camera.principal_point == pytest.approx((157.0, 146.0))  # the centre pixel + (7, -4)
    z0 = -H[0, 2] / H[2, 2]  # the views' centres of projection lie at z = -H13 / H33
    point = np.array([0.05, -0.03, 0.6])  # toolbox frame, metres
    i = np.arange(1, 10, dtype=float)
    # X = (H11 i + H13 k + H15) + (H31 i + H33 k + H35) Z, solved for k (same for y with ell)
    k = (point[0] - H[0, 0] * i - H[0, 4] - (H[2, 0] * i + H[2, 4]) * point[2]) / (H[0, 2] + H[2, 2] * point[2])
    ell = (point[1] - H[1, 1] * i - H[1, 4] - (H[3, 1] * i + H[3, 4]) * point[2]) / (H[1, 3] + H[3, 3] * point[2])
    slope_x, slope_y = -np.polyfit(i, k, 1)[0], -np.polyfit(i, ell, 1)[0]  # x_view = x - slope (s - s_c)
    assert slope_x == pytest.approx(slope_y)
    kp = keypoint(k[4] - 1, ell[4] - 1, slope_x)  # centre view i = 5, 0-based pixels
    assert camera.depth([slope_x])[0] == pytest.approx(point[2] - z0, rel=1e-9)
    # (class_id keeps the slope to 1/65536 px per view: 3e-5 relative in depth here)
    assert camera.points_3d([kp])[0] == pytest.approx(point - [0, 0, z0], rel=1e-4)
    # Focus: -H31 / baseline; H31 = 0 is a camera focused at infinity
    assert camera.focus_distance == pytest.approx(camera.baseline / 2e-4)
    assert liff.LightFieldCamera.from_lftoolbox(toolbox_H(h31=0.0)).focus_distance == math.inf


@pytest.mark.parametrize("change, message", [
    (lambda H: H[:4], "shape"), (lambda H: np.where(H == 1, np.nan, H), "non-finite"),
    (lambda H: _set(H, (0, 1), 1e-4), "mixes horizontal"), (lambda H: _set(H, (4, 0), 1.0), "last row"),
    (lambda H: _set(H, (2, 2), -2.5e-3), "mirrored"), (lambda H: _set(H, (3, 3), 3e-3), "differs between s and t"),
    (lambda H: _set(H, (0, 0), -2e-4), "baseline"),
])
def test_lftoolbox_refuses_what_the_model_cannot_take(change, message):
    with pytest.raises(ValueError, match=message):
        liff.LightFieldCamera.from_lftoolbox(change(toolbox_H()))


def _set(H, index, value):
    H = H.copy()
    H[index] = value
    return H


# --- scale-sensitive matching ------------------------------------------------------------

def test_metric_size_test_lets_the_right_candidate_win():
    rng = np.random.default_rng(0)
    b = rng.random((3, 128)).astype(np.float32) * 100
    a = b[:1] + 0.5  # nearest to b[0] ...
    b[1] = a[0] + 0.45  # ... but a look-alike of another size is a little nearer
    sizes = (np.array([0.10]), np.array([0.10, 0.40, 0.12]))
    assert liff.matching.ratio_matches(a, b, 0.8) == []  # ambiguous: the ratio test drops it
    matches = liff.matching.ratio_matches(a, b, 0.8, metric_sizes=sizes, max_size_factor=1.5)
    assert [(m.queryIdx, m.trainIdx) for m in matches] == [(0, 0)]
    # unknown sizes (NaN, beyond infinity) are not rejected
    unknown = (np.array([np.nan]), sizes[1])
    assert liff.matching.ratio_matches(a, b, 0.8, metric_sizes=unknown, max_size_factor=1.5) == []


@pytest.mark.parametrize("kwargs, message", [
    (dict(max_size_factor=1.0), "expected a finite factor > 1"),
    (dict(max_size_factor=float("inf")), "expected a finite factor > 1"),
    (dict(metric_sizes=(np.ones(1), np.ones(3))), "both"),
    (dict(metric_sizes=(np.ones(2), np.ones(3)), max_size_factor=2.0), "one each"),
    (dict(metric_sizes=(-np.ones(1), np.ones(3)), max_size_factor=2.0), "positive"),
])
def test_scale_sensitive_matching_refuses_bad_options(kwargs, message):
    d = np.eye(3, 128, dtype=np.float32)
    with pytest.raises(ValueError, match=message):
        liff.matching.ratio_matches(d[:1], d, 0.8, **kwargs)


# --- metric relative pose ----------------------------------------------------------------

@pytest.fixture(scope="module")
def pose_capture():
    """Three poses (10 degrees apart) of a box scene, 5x5 views of 240x180, with features."""
    capture = captures.make_capture(seed=4, n_poses=3, views=(5, 5), size=(180, 240), focal=240.0,
                                    span_degrees=20.0, supersample=1)
    detector = liff.LiFF.create(contrastThreshold=0.02, **CAPTURE_SLOPES)
    features = [detector.detectAndCompute(lf) for lf in capture.light_fields]
    return capture, features


def test_relative_pose_has_absolute_scale(pose_capture):
    capture, features = pose_capture
    camera = camera_of(capture)
    for i, j in ((0, 1), (0, 2)):
        R_true, t_true = true_relative(capture, i, j)
        (k1, d1), (k2, d2) = features[i], features[j]
        R, t, matches = liff.estimate_relative_pose(k1, d1, k2, d2, camera)
        assert R.shape == (3, 3) and t.shape == (3,)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-9)
        assert np.linalg.norm(t - t_true) <= 0.02 * np.linalg.norm(t_true)
        assert np.degrees(np.linalg.norm(cv2.Rodrigues(R @ R_true.T)[0])) <= 0.5
        assert len(matches) >= 50 and all(isinstance(m, cv2.DMatch) for m in matches)
        # the inliers agree with the true pose
        X1 = camera.points_3d([k1[m.queryIdx] for m in matches]) @ R_true.T + t_true
        uv = X1[:, :2] / X1[:, 2:] * camera.focal_length + camera.principal_point
        err = np.linalg.norm(uv - [k2[m.trainIdx].pt for m in matches], axis=1)
        assert np.median(err) < 1.0


def test_relative_pose_of_a_capture_with_itself_is_the_identity(pose_capture):
    capture, features = pose_capture
    k, d = features[1]
    R, t, matches = liff.estimate_relative_pose(k, d, k, d, camera_of(capture))
    assert np.allclose(R, np.eye(3), atol=1e-6) and np.linalg.norm(t) < 1e-6
    assert len(matches) > 0.5 * len(k)


def test_pose_estimation_refuses_rather_than_guesses():
    camera = liff.LightFieldCamera(300.0, 0.04, (100.0, 100.0))
    rng = np.random.default_rng(1)
    d = (rng.random((40, 128)) * 100).astype(np.float32)
    two = [keypoint(10, 10, 1.0), keypoint(50, 60, 2.0)]
    with pytest.raises(liff.PoseEstimationError, match="at least 3"):
        liff.estimate_relative_pose(two, d[:2], two, d[:2], camera)
    # points on one line (one 3-D line, same features in both captures)
    line = [keypoint(10 + 4 * i, 20 + 2 * i, 0.5 + 0.02 * i) for i in range(40)]
    with pytest.raises(liff.PoseEstimationError, match="degenerate|no rigid motion"):
        liff.estimate_relative_pose(line, d, line, d, camera)
    # every slope at or beyond infinity: no depth at all
    far = [keypoint(rng.uniform(0, 200), rng.uniform(0, 200), -0.5) for _ in range(40)]
    with pytest.raises(liff.PoseEstimationError, match="depth"):
        liff.estimate_relative_pose(far, d, far, d, camera)
    assert issubclass(liff.PoseEstimationError, ValueError)


def test_pose_estimation_checks_its_input():
    camera = liff.LightFieldCamera(300.0, 0.04, (100.0, 100.0))
    kps = [keypoint(10, 10, 1.0)] * 3
    d = np.ones((3, 128), np.float32)
    with pytest.raises(ValueError, match="expected a liff.LightFieldCamera"):
        liff.estimate_relative_pose(kps, d, kps, d, "camera")
    with pytest.raises(ValueError, match="2 descriptors for 3 keypoints"):
        liff.estimate_relative_pose(kps, d, kps, d[:2], camera)
    with pytest.raises(ValueError, match="widths 128 .a. and 64 .b.; expected the same width"):
        liff.estimate_relative_pose(kps, d, kps, d[:, :64], camera)
    nan_kps = [keypoint(10, 10, 1.0), keypoint(float("nan"), 10, 1.0), keypoint(12, 10, 1.0)]
    with pytest.raises(ValueError, match="index 1.*expected finite pixel coordinates"):
        liff.estimate_relative_pose(nan_kps, d, kps, d, camera)
    for seed in (-1, 2 ** 40, 1.5, True):
        with pytest.raises(ValueError, match=r"seed = .*expected an integer in \[0, 2\*\*31\)"):
            liff.estimate_relative_pose(kps, d, kps, d, camera, seed=seed)


@pytest.mark.parametrize("a, b, message", [
    (np.ones((2, 128), np.float32), np.ones((3, 64), np.float32), "widths 128 .a. and 64 .b."),
    (np.ones(128, np.float32), np.ones((3, 128), np.float32), "2-D .N, D. array"),
    (np.ones((2, 128), np.float32), np.full((3, 128), np.nan, np.float32), "descriptors_b hold NaN"),
    (np.array([["x"] * 128] * 2), np.ones((3, 128), np.float32), "dtype <U1"),
])
def test_ratio_matching_checks_descriptors(a, b, message):
    with pytest.raises(ValueError, match=message):
        liff.matching.ratio_matches(a, b, 0.8)


def synthetic_observations(camera, n_right, n_wrong, sigma_xy, sigma_slope, seed):
    """Matched observations (x, y, slope) of two captures 1 m apart (turned 8 degrees)
    of points at 2-15 m: ``n_right`` with Gaussian noise, then ``n_wrong`` wrong
    pairings (each capture-1 feature with another point's capture-2 feature)."""
    rng = np.random.default_rng(seed)
    R = cv2.Rodrigues(np.radians([1.0, 8.0, 0.5]))[0]
    t = np.array([-0.95, 0.05, 0.3])
    n = n_right + n_wrong
    cx, cy = camera.principal_point
    X1 = camera.back_project(np.column_stack([rng.uniform(0.15, 0.85, n) * 2 * cx,
                                              rng.uniform(0.15, 0.85, n) * 2 * cy]),
                             rng.uniform(2.0, 15.0, n))
    X2 = X1 @ R.T + t

    def observe(X):
        xy = X[:, :2] / X[:, 2:] * camera.focal_length + camera.principal_point
        return np.column_stack([xy + rng.normal(0, sigma_xy, (n, 2)),
                                camera.slopes(X[:, 2]) + rng.normal(0, sigma_slope, n)])

    obs1, obs2 = observe(X1), observe(X2)
    obs2[n_right:] = obs2[n_right + rng.permutation(n_wrong)]
    return obs1, obs2, R, t


def test_ransac_scores_in_the_observations_where_far_points_are_noisy():
    # Slope noise is alike for every feature, so a far point's depth is poor (Z^2 / (f b)
    # times it: 0.2 m at 15 m): a 3-D RANSAC (threshold 3% of the median depth) keeps
    # fewer of the right matches here (36 of 40; COLMAP's kept 37) and its pose is
    # 2.8x worse (COLMAP's, not the least-squares fit of its inliers, 27x); scored by the
    # observations, RANSAC keeps all 40 and no wrong ones.
    from liff.pose import observation_ransac, ransac_pose
    from liff.pose.model import back_project

    camera = liff.LightFieldCamera(400.0, 0.05, (200.0, 150.0))
    obs1, obs2, R_true, t_true = synthetic_observations(camera, 40, 60, 0.2, 0.02, seed=3)
    R, t, inliers = observation_ransac(obs1, obs2, camera, camera, seed=0)
    assert inliers[:40].sum() >= 36 and inliers[40:].sum() <= 1
    assert np.linalg.norm(t - t_true) <= 0.01 * np.linalg.norm(t_true)
    X1, X2 = back_project(camera, obs1), back_project(camera, obs2)
    threshold = 0.03 * np.median(np.concatenate([X1[:, 2], X2[:, 2]]))
    R3, t3, inliers3 = ransac_pose(X1, X2, threshold)
    assert inliers3[:40].sum() < inliers[:40].sum()
    assert np.linalg.norm(t3 - t_true) > 2 * np.linalg.norm(t - t_true)
    # every match wrong: some motion still agrees with a few, as with random re-pairings
    obs1, obs2, _, _ = synthetic_observations(camera, 0, 300, 0.2, 0.02, seed=4)
    with pytest.raises(liff.PoseEstimationError, match="re-paired at random"):
        observation_ransac(obs1, obs2, camera, camera, seed=0)


def test_refinement_noise_does_not_shrink_with_few_matches():
    # With 6 matches the pose absorbs a good share of the residuals; a noise estimate
    # that counted only each point's share shrank round after round (median 0.47x the
    # true position noise over these seeds) and dropped right matches until some fits
    # failed. Counting the pose's share, the estimate stays near the truth.
    from liff.pose import refine_relative_pose

    camera = liff.LightFieldCamera(400.0, 0.05, (200.0, 150.0))
    ratios, kept = [], []
    for seed in range(30):
        obs1, obs2, R, t = synthetic_observations(camera, 6, 0, 0.2, 0.02, seed)
        pose = refine_relative_pose(obs1, obs2, camera, camera, R, t)
        ratios.append((pose.sigma_xy / 0.2, pose.sigma_slope / 0.02))
        kept.append(pose.inliers.sum())
    assert np.all(np.abs(np.log(np.median(ratios, axis=0))) < np.log(1.25))
    assert min(kept) >= 5


# --- metric SfM and the command line -----------------------------------------------------

@pytest.fixture(scope="module")
def pose_files(pose_capture, tmp_path_factory):
    capture, _ = pose_capture
    folder = tmp_path_factory.mktemp("poses")
    paths = []
    for i, lf in enumerate(capture.light_fields):
        paths.append(str(folder / f"pose{i}.npy"))
        np.save(paths[-1], lf)
    return capture, paths


def camera_options(camera):
    return ["--camera", repr(camera.focal_length), repr(camera.baseline),
            *map(repr, camera.principal_point), "--focus-distance", repr(camera.focus_distance)]


def detector_options():
    return ["--contrast-threshold", "0.02", "--first-slope", "-1.25", "--last-slope", "1.25",
            "--num-slopes", "21"]


def test_cli_pose_prints_and_writes_the_metric_pose(pose_files, tmp_path, capsys):
    capture, paths = pose_files
    out = tmp_path / "pose.json"
    assert main(["pose", paths[0], paths[1], *camera_options(camera_of(capture)),
                 *detector_options(), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "inlier matches" in printed and "|t| =" in printed
    result = json.loads(out.read_text())
    _, t_true = true_relative(capture, 0, 1)
    assert np.linalg.norm(np.array(result["t"]) - t_true) <= 0.02 * np.linalg.norm(t_true)


def test_cli_pose_keeps_an_existing_out_file(pose_files, tmp_path, capsys, monkeypatch):
    capture, paths = pose_files
    keep = tmp_path / "keep.json"
    keep.write_text("not ours")
    detected = []
    real = liff.cli.pose.features_from_light_field
    monkeypatch.setattr(liff.cli.pose, "features_from_light_field",
                        lambda *args: detected.append(args) or real(*args))
    options = [*camera_options(camera_of(capture)), *detector_options()]
    assert main(["pose", paths[0], paths[1], *options, "--out", str(keep)]) == 1
    err = capsys.readouterr().err
    assert f"{keep}: exists; expected a new --out path (or --overwrite to replace it)" in err
    assert keep.read_text() == "not ours" and detected == []  # said before detecting
    assert main(["pose", paths[0], paths[1], *options, "--out", paths[0]]) == 1
    assert "--out" in capsys.readouterr().err and np.load(paths[0]).ndim >= 4
    assert main(["pose", paths[0], paths[1], *options, "--out", str(keep), "--overwrite"]) == 0
    assert "R" in json.loads(keep.read_text())


def test_cli_pose_needs_a_camera(pose_files, capsys, monkeypatch):
    _, paths = pose_files
    detected = []
    monkeypatch.setattr(liff.cli.pose, "features_from_light_field",
                        lambda *args: detected.append(args))
    assert main(["pose", paths[0], paths[1], *detector_options()]) == 1
    err = capsys.readouterr().err
    assert f"no camera calibration for {paths[0]} and {paths[1]}" in err
    assert detected == []  # said before detecting (it had detected both first)
    assert main(["pose", paths[0], paths[1], "--focus-distance", "3"]) == 1
    assert "--focus-distance goes with --camera" in capsys.readouterr().err


@pytest.mark.parametrize("mapper, line", [
    (None, r"model 0 in metres from 3 pair poses \(pose graph\); checks: the pair baselines say "
           r"x ([\d.e+-]+), \d+ of \d+ observations' slopes \(noise [\d.e+-]+ px per view\) x ([\d.e+-]+)"),
    ("default", r"scaled to metres: x ([\d.e+-]+) \(from the metric baselines of 3 image pairs"),
])
def test_cli_sfm_with_a_camera_is_in_metres(pose_files, tmp_path, capsys, mapper, line):
    import pycolmap

    capture, paths = pose_files
    workspace = tmp_path / "ws"
    assert main(["sfm", *paths, "--workspace", str(workspace), "--preprocess",
                 *camera_options(camera_of(capture)), *detector_options()]
                + ([] if mapper is None else ["--mapper", mapper])) == 0
    printed = capsys.readouterr().out
    assert "matched by metric pose: 3 of 3 pairs" in printed  # a camera given
    assert f"reconstruction ({mapper or 'poses'} mapper)" in printed
    checks = [float(x) for x in re.search(line, printed).groups()]
    # the pose graph's model is metric already: both checks say so within 1%
    assert all(x > 0 for x in checks) and (mapper or all(x == pytest.approx(1, abs=0.01) for x in checks))
    model = pycolmap.Reconstruction(str(workspace / "sparse" / "0"))
    # the calibration's intrinsics are kept (COLMAP's pixels: +0.5)
    camera = camera_of(capture)
    assert list(next(iter(model.cameras.values())).params) == pytest.approx(
        [camera.focal_length, camera.principal_point[0] + 0.5, camera.principal_point[1] + 0.5])
    centres = {model.image(i).name: model.image(i).projection_center() for i in model.reg_image_ids()}
    assert len(centres) == 3
    est = [centres[f"pose{i}.png"] for i in range(3)]
    true = [p.centre for p in capture.poses]
    for a, b in ((0, 1), (1, 2), (0, 2)):
        ratio = np.linalg.norm(est[a] - est[b]) / np.linalg.norm(true[a] - true[b])
        assert ratio == pytest.approx(1.0, abs=0.02)


def pose_database(capture, features, folder):
    """(camera, FeatureImages pose0.png..., database path) of a fresh database in folder."""
    from liff import colmap

    camera = camera_of(capture)
    images = [colmap.FeatureImage(f"pose{i}.png", lf[2, 2], k, d)
              for i, (lf, (k, d)) in enumerate(zip(capture.light_fields, features))]
    database = folder / "database.db"
    colmap.write_database(database, folder / "images", images, focal=camera.focal_length,
                          principal_point=camera.principal_point)
    return camera, images, database


def test_metric_model_from_pair_poses_and_both_scale_estimates(pose_capture, tmp_path):
    from liff import colmap

    capture, features = pose_capture
    camera, images, database = pose_database(capture, features, tmp_path)
    pair_poses = colmap.match_by_pose(database, images, camera)
    result = colmap.reconstruct_from_poses(database, tmp_path / "images", tmp_path / "sparse", pair_poses)
    model = result.best
    assert model.num_reg_images() == 3 and model.num_points3D() >= 100
    assert (tmp_path / "sparse" / "0" / "images.bin").exists()
    # the cameras where the true poses put them (metres, up to the world frame)
    centres = {model.image(i).name: model.image(i).projection_center() for i in model.reg_image_ids()}
    for a, b in ((0, 1), (1, 2), (0, 2)):
        d_est = np.linalg.norm(centres[f"pose{a}.png"] - centres[f"pose{b}.png"])
        d_true = np.linalg.norm(capture.poses[a].centre - capture.poses[b].centre)
        assert d_est == pytest.approx(d_true, rel=0.01)
    # shrunk by half, both estimates find the factor 2 back; without pair poses, the slopes
    colmap.scale_reconstruction(model, 0.5)
    slopes = {im.name: liff.keypoint_slopes(im.keypoints) for im in images}
    fit = colmap.metric_scale(model, slopes, camera, pair_poses)
    assert fit.source == "baselines" and fit.pairs == 3
    assert fit.scale == pytest.approx(2.0, rel=0.01)
    assert fit.scale_from_slopes == pytest.approx(2.0, rel=0.01)
    alone = colmap.metric_scale(model, slopes, camera)
    assert alone.source == "slopes" and alone.pairs == 0 and alone.scale == fit.scale_from_slopes
    with pytest.raises(ValueError, match="expected a liff.colmap.PairPose"):
        colmap.metric_scale(model, slopes, camera, {("pose0.png", "pose1.png"): (np.eye(3), np.zeros(3))})
    reversed_keys = {(b, a): pose for (a, b), pose in pair_poses.items()}
    with pytest.raises(ValueError, match=r"is not the pose match_by_pose wrote .* \(reversed names"):
        colmap.reconstruct_from_poses(database, tmp_path / "images", tmp_path / "sparse3", reversed_keys)
    for bad, message in (([], "pair_poses is a list; expected the dict"),
                         ({"pose0.png": None}, "key 'pose0.png'; expected a tuple")):
        with pytest.raises(ValueError, match=message):
            colmap.reconstruct_from_poses(database, tmp_path / "images", tmp_path / "sparse4", bad)
    with pytest.raises(ValueError, match="slopes is a list; expected a dict"):
        colmap.metric_scale(model, list(slopes.values()), camera)
    with pytest.raises(ValueError, match="camera is a NoneType; expected a liff.LightFieldCamera"):
        colmap.metric_scale(model, slopes, None)
    with pytest.raises(ValueError, match=r"\['other.png'\], not in the database"):
        colmap.reconstruct_from_poses(database, tmp_path / "images", tmp_path / "sparse2",
                                      {("pose0.png", "other.png"): pair_poses[("pose0.png", "pose1.png")]})


def test_match_by_pose_writes_a_pair_without_baseline_as_panoramic(pose_capture, tmp_path):
    # The same capture twice: the pose is the identity, no baseline to triangulate; an
    # essential matrix from a unit translation of arbitrary direction would be made up.
    import pycolmap

    from liff import colmap

    capture, features = pose_capture
    camera = camera_of(capture)
    (k, d), lf = features[1], capture.light_fields[1]
    images = [colmap.FeatureImage(name, lf[2, 2], k, d) for name in ("a.png", "b.png")]
    database = tmp_path / "database.db"
    colmap.write_database(database, tmp_path / "images", images, focal=camera.focal_length,
                          principal_point=camera.principal_point)
    poses = colmap.match_by_pose(database, images, camera)
    assert poses[("a.png", "b.png")].inliers > 0.5 * len(k)
    with pycolmap.Database.open(str(database)) as db:
        ids = {im.name: im.image_id for im in db.read_all_images()}
        geometry = db.read_two_view_geometry(ids["a.png"], ids["b.png"])
    assert geometry.config == pycolmap.TwoViewGeometryConfiguration.PANORAMIC
    assert np.allclose(np.asarray(geometry.H) / geometry.H[2, 2], np.eye(3), atol=1e-6)
    # a model from that pose registers both images but has nothing to triangulate, and no
    # baseline to scale by (its sigma is 0: every residual is)
    model = colmap.reconstruct_from_poses(database, tmp_path / "images", tmp_path / "sparse", poses).best
    assert model.num_reg_images() == 2 and model.num_points3D() == 0
    with pytest.raises(ValueError, match="0 observations of 3-D points with a slope and no registered "
                                         "pair with a metric pose"):
        colmap.metric_scale(model, {"a.png": liff.keypoint_slopes(k), "b.png": liff.keypoint_slopes(k)},
                            camera, poses)


def test_cli_sfm_says_what_to_try_when_the_default_mapper_makes_no_model(pose_files, tmp_path, capsys):
    # Two poses 10 degrees apart: COLMAP's default mapper wants 16 degrees for its first
    # pair; the model from the pair poses (the default with a camera) has no such limit.
    capture, paths = pose_files
    assert main(["sfm", *paths[:2], "--workspace", str(tmp_path / "ws"), "--mapper", "default",
                 *camera_options(camera_of(capture)), *detector_options()]) == 1
    captured = capsys.readouterr()
    assert "FAILED (no model)" in captured.out
    assert "try --mapper permissive" in captured.err
    assert main(["sfm", *paths[:2], "--workspace", str(tmp_path / "ws2"),
                 *camera_options(camera_of(capture)), *detector_options()]) == 0
    assert "model 0 in metres from 1 pair pose (pose graph)" in capsys.readouterr().out


def test_cli_sfm_counts_the_pairs_matched_on_workers(pose_files, tmp_path, capsys, monkeypatch):
    # Matching by pose is the step a user waits on: a bar counts its pairs, and --workers
    # spreads them over processes.
    monkeypatch.setenv("LIFF_PROGRESS", "1")
    capture, paths = pose_files
    assert main(["sfm", *paths, "--workspace", str(tmp_path / "ws"), "--workers", "2",
                 *camera_options(camera_of(capture)), *detector_options()]) == 0
    captured = capsys.readouterr()
    assert "liff sfm: pairs matched" in captured.err and "3/3" in captured.err
    assert "matched by metric pose: 3 of 3 pairs" in captured.out


def test_cli_sfm_warns_when_the_slopes_do_not_fit_the_camera(pose_files, tmp_path, capsys):
    # A baseline 10x off still gives poses and a model, consistent with that wrong camera;
    # only the slopes' residuals (3.5 px per view where a right camera gives ~0.01) say so.
    capture, paths = pose_files
    wrong = dataclasses.replace(camera_of(capture), baseline=10 * camera_of(capture).baseline)
    main(["sfm", *paths[:2], "--workspace", str(tmp_path / "ws"), *camera_options(wrong),
          *detector_options()])
    assert "check the camera (focal length, baseline, focus distance)" in capsys.readouterr().err


def test_cli_sfm_pose_matching_needs_a_camera(pose_files, tmp_path, capsys):
    _, paths = pose_files
    assert main(["sfm", *paths, "--workspace", str(tmp_path / "ws"), "--matching", "pose",
                 *detector_options()]) == 1
    assert "--matching pose needs the camera's calibration" in capsys.readouterr().err
    assert main(["sfm", *paths, "--workspace", str(tmp_path / "ws"), "--mapper", "poses",
                 *detector_options()]) == 1
    assert "--mapper poses builds the model from the pairs' metric poses; expected --matching pose" \
        in capsys.readouterr().err


def test_match_by_pose_writes_verified_geometries(pose_capture, tmp_path):
    import pycolmap

    from liff import colmap

    capture, features = pose_capture
    camera, images, database = pose_database(capture, features, tmp_path)
    poses = colmap.match_by_pose(database, images[::-1], camera)  # any order
    inliers = {pair: pose.inliers for pair, pose in poses.items()}
    assert set(inliers) == {("pose0.png", "pose1.png"), ("pose0.png", "pose2.png"),
                            ("pose1.png", "pose2.png")}
    with pycolmap.Database.open(str(database)) as db:
        ids = {im.name: im.image_id for im in db.read_all_images()}
        for (a, b), n in inliers.items():
            assert n >= 50
            geometry = db.read_two_view_geometry(ids[a], ids[b])
            assert geometry.config == pycolmap.TwoViewGeometryConfiguration.CALIBRATED
            pairs = np.asarray(geometry.inlier_matches)
            assert len(pairs) == n
            # each inlier agrees with the true pose: x2^T E x1 = 0 for normalised rays
            R, t = true_relative(capture, int(a[4]), int(b[4]))
            K_inv = np.linalg.inv(camera.matrix())
            k1, k2 = features[int(a[4])][0], features[int(b[4])][0]
            x1 = np.column_stack([[k1[i].pt for i in pairs[:, 0]], np.ones(n)]) @ K_inv.T
            x2 = np.column_stack([[k2[i].pt for i in pairs[:, 1]], np.ones(n)]) @ K_inv.T
            tx, ty, tz = t / np.linalg.norm(t)
            E = np.array([[0, -tz, ty], [tz, 0, -tx], [-ty, tx, 0]]) @ R  # [t]_x R
            assert np.median(np.abs(np.einsum("ni,ij,nj->n", x2, E, x1))) < 2e-3
            assert np.allclose(np.asarray(geometry.E) / np.linalg.norm(geometry.E),
                               E / np.linalg.norm(E), atol=0.05)
    with pytest.raises(ValueError, match="already holds matches"):
        colmap.match_by_pose(database, images, camera)
    fewer = colmap.FeatureImage("pose0.png", images[0].image, images[0].keypoints[:50],
                                images[0].descriptors[:50])
    with pytest.raises(ValueError, match="50 keypoints given"):
        colmap.match_by_pose(database, [fewer, images[1]], camera)
    with pytest.raises(ValueError, match="not in the database"):
        colmap.match_by_pose(database, [colmap.FeatureImage("other.png", images[0].image,
                                                            images[0].keypoints, images[0].descriptors)],
                             camera)
    with pytest.raises(ValueError, match="seed = -1; expected an integer"):
        colmap.match_by_pose(database, images, camera, seed=-1)


def test_match_by_pose_on_workers_equals_serial(pose_capture, tmp_path):
    import pycolmap

    from liff import colmap

    capture, features = pose_capture
    results, stored = [], []
    for workers in (1, 2):
        camera, images, database = pose_database(capture, features, tmp_path / f"w{workers}")
        done = []
        poses = colmap.match_by_pose(database, images, camera, workers=workers,
                                     progress=lambda: done.append(1))
        assert len(done) == 3  # one call per pair
        results.append(poses)
        with pycolmap.Database.open(str(database)) as db:
            ids = {im.name: im.image_id for im in db.read_all_images()}
            stored.append({pair: np.asarray(db.read_two_view_geometry(ids[pair[0]], ids[pair[1]]).inlier_matches)
                           for pair in poses})
    assert results[0].keys() == results[1].keys()
    for pair, serial in results[0].items():
        parallel = results[1][pair]
        assert np.array_equal(serial.rotation, parallel.rotation)
        assert np.array_equal(serial.translation, parallel.translation)
        assert np.array_equal(serial.covariance, parallel.covariance)
        assert serial.inliers == parallel.inliers >= 50
        assert np.array_equal(stored[0][pair], stored[1][pair])
    with pytest.raises(ValueError, match="workers = 0; expected a positive integer"):
        colmap.match_by_pose(database, images, camera, workers=0)


def write_hci_scene(folder, light_field, camera, width=None):
    """An HCI-style scene folder (input_CamNNN.png, parameters.cfg) of a grey light field
    in [0, 1], its parameters.cfg describing ``camera`` (principal point at the centre)."""
    T, S, V, U = light_field.shape
    folder.mkdir()
    for t in range(T):
        for s in range(S):
            view = np.clip(np.round(light_field[t, s] * 255), 0, 255).astype(np.uint8)
            cv2.imwrite(str(folder / f"input_Cam{t * S + s:03d}.png"), cv2.merge([view] * 3))
    sensor_mm = 35.0
    (folder / "parameters.cfg").write_text(
        f"[intrinsics]\nfocal_length_mm = {camera.focal_length * sensor_mm / max(U, V)!r}\n"
        f"sensor_size_mm = {sensor_mm}\nimage_resolution_x_px = {width or U}\n"
        f"image_resolution_y_px = {V}\n[extrinsics]\nnum_cams_x = {S}\nnum_cams_y = {T}\n"
        f"baseline_mm = {camera.baseline * 1000!r}\nfocus_distance_m = {camera.focus_distance!r}\n")


def test_cli_pose_takes_the_camera_from_hci_scenes(pose_capture, tmp_path, capsys):
    capture, _ = pose_capture
    camera = camera_of(capture)
    for i in (0, 1):
        write_hci_scene(tmp_path / f"scene{i}", capture.light_fields[i], camera)
    read = read_hci(tmp_path / "scene0").camera
    assert read.focal_length == pytest.approx(camera.focal_length)
    assert read.principal_point == camera.principal_point
    out = tmp_path / "pose.json"
    assert main(["pose", str(tmp_path / "scene0"), str(tmp_path / "scene1"), *detector_options(),
                 "--out", str(out)]) == 0
    _, t_true = true_relative(capture, 0, 1)
    t = np.array(json.loads(out.read_text())["t"])
    assert np.linalg.norm(t - t_true) <= 0.02 * np.linalg.norm(t_true)
    capsys.readouterr()
    # parameters.cfg that contradicts the views is refused by the reader
    write_hci_scene(tmp_path / "bad", capture.light_fields[0][:2, :2], camera, width=512)
    with pytest.raises(ValueError, match="image_resolution 512x180 differs from the views' 240x180"):
        read_hci(tmp_path / "bad")


def test_camera_options_read_a_toolbox_matrix_and_refuse_bad_files(tmp_path):
    import argparse

    from liff.cli.calibration import add_camera_options, camera_from_args

    parser = argparse.ArgumentParser()
    add_camera_options(parser)
    H = toolbox_H()
    text = tmp_path / "H.txt"
    np.savetxt(text, H, delimiter=",")  # as MATLAB's writematrix would
    expected = liff.LightFieldCamera.from_lftoolbox(H)
    assert camera_from_args(parser.parse_args(["--lftoolbox", str(text)])) == expected
    np.save(tmp_path / "H.npy", H)
    assert camera_from_args(parser.parse_args(["--lftoolbox", str(tmp_path / "H.npy")])) == expected
    assert camera_from_args(parser.parse_args([])) is None
    (tmp_path / "bad.txt").write_text("1 2 x\n")
    with pytest.raises(ValueError, match="bad.txt: unreadable"):
        camera_from_args(parser.parse_args(["--lftoolbox", str(tmp_path / "bad.txt")]))
    with pytest.raises(ValueError, match="no such file"):
        camera_from_args(parser.parse_args(["--lftoolbox", str(tmp_path / "none.txt")]))
    with pytest.raises(ValueError, match=r"^--camera F \(focal length\) = -1.0; expected a "
                                         "positive finite number"):
        camera_from_args(parser.parse_args(["--camera", "-1", "0.1", "0", "0"]))
    with pytest.raises(ValueError, match=r"^--focus-distance = -3.0; expected a positive"):
        camera_from_args(parser.parse_args(["--camera", "1", "0.1", "0", "0",
                                            "--focus-distance", "-3"]))


def test_transfer_distance_of_a_point_in_capture_2s_image_plane_is_no_match():
    # A pose that puts a point almost in capture 2's image plane predicts it with a
    # variance of ~1e32 px^2: numpy's solve raised "Singular matrix" out of
    # estimate_relative_pose (a benchmark pair, 9x9 views, noise 1e-3). Now: no match.
    from liff.pose.ransac import _transfer_distances

    camera = liff.LightFieldCamera(300.0, 0.04, (100.0, 100.0))
    obs1 = np.array([[100.0, 100.0, 2.0], [120.0, 90.0, 1.0]])
    w = camera.inverse_depth(obs1[:, 2])
    R = Rotation.from_rotvec([0, np.pi / 2 - 1e-9, 0]).as_matrix()
    d = np.array([0.0, 0.0, 1.0])
    t = np.array([0.0, 0.0, (1e-8 - (R @ d)[2]) / w[0]])
    sigma = np.array([[0.5, 0.05]] * 2)
    distance = _transfer_distances(obs1, obs1, sigma, sigma, camera, camera, R, t)
    assert distance.shape == (2,) and distance[0] == np.inf


def test_colmap_steps_name_a_missing_database_and_a_wrong_model(tmp_path):
    from liff import colmap

    missing = tmp_path / "none.db"
    for call in (lambda: colmap.reconstruct_from_poses(missing, tmp_path, tmp_path / "s", {}),
                 lambda: colmap.match_by_pose(missing, [], None),
                 lambda: colmap.reconstruct(missing, tmp_path, tmp_path / "s"),
                 lambda: colmap.table_metrics(missing)):
        with pytest.raises(ValueError, match="none.db: no such COLMAP database; expected one written"):
            call()
    with pytest.raises(ValueError, match="reconstruction is a NoneType; expected a pycolmap.Reconstruction"):
        colmap.metric_scale(None, {}, liff.LightFieldCamera(300.0, 0.04, (1.0, 1.0)))


def test_cli_pose_warns_of_few_inliers_and_refuses_a_folder_out(tmp_path, capsys, monkeypatch):
    """Issue 29: a pose from a handful of inliers is printed with exit 0 but warned of
    (as liff match warns below 15); --out a folder is refused before detecting."""
    monkeypatch.chdir(tmp_path)
    assert main(["synth", "poses", "--out", "arc", "--views", "3", "--size", "64", "80", "--poses", "3",
                 "--quiet"]) == 0
    truth = json.loads(Path("arc.truth.json").read_text())
    k = truth["intrinsics"]
    camera = ["--camera", str(k["focal"]), str(truth["baseline"]), str(k["cx"]), str(k["cy"]),
              "--focus-distance", str(truth["focus_depth"])]
    detected = []
    real = liff.cli.pose.features_from_light_field
    monkeypatch.setattr(liff.cli.pose, "features_from_light_field",
                        lambda *args: detected.append(args) or real(*args))
    assert main(["pose", "arc/pose00.npz", "arc/pose01.npz", *camera, "--out", "arc", "--overwrite"]) == 1
    assert "--out arc is a folder; expected a JSON file path" in capsys.readouterr().err and not detected
    assert main(["pose", "arc/pose00.npz", "arc/pose01.npz", *camera]) == 0
    out, err = capsys.readouterr()
    inliers = int(re.search(r"(\d+) inlier matches", out)[1])
    assert inliers < 15 and f"liff pose: warning: {inliers} inlier matches are too few" in err


def test_cli_pose_without_the_focus_distance_hints_at_it(tmp_path, capsys, monkeypatch):
    """Break test 5: --camera F B CX CY without --focus-distance on a scene of slopes
    below 0 (liff synth poses, focused at 5.09 m) said '0 putative matches with a depth
    in both captures (of 54)' and no more; the error says the focus distance may be
    missing."""
    monkeypatch.chdir(tmp_path)
    assert main(["synth", "poses", "--out", "arc", "--views", "5", "--size", "96", "128",
                 "--poses", "2", "--quiet"]) == 0
    truth = json.loads(Path("arc.truth.json").read_text())
    k = truth["intrinsics"]
    camera = ["--camera", str(k["focal"]), str(truth["baseline"]), str(k["cx"]), str(k["cy"])]
    capsys.readouterr()
    assert main(["pose", "arc/pose00.npz", "arc/pose01.npz", *camera]) == 1
    err = capsys.readouterr().err
    assert re.search(r"liff pose: \d+ putative matches with a depth in both captures \(of \d+\); "
                     r"expected at least \d+; \d+ of the matches have slopes <= 0, at or beyond "
                     r"infinity for a camera focused at infinity", err), err
    assert "give the focus distance (--focus-distance M with --camera)" in err
    assert main(["pose", "arc/pose00.npz", "arc/pose01.npz", *camera,
                 "--focus-distance", str(truth["focus_depth"])]) == 0
