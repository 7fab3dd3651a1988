"""benchmarks/scoring.py and benchmarks/baselines.py: the code the quality benchmarks
rest on (beside the benchmarks, not in the package: users do not call them)."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

import liff
from liff import synthetic

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import baselines  # noqa: E402
from scoring import above_threshold, score_blobs  # noqa: E402


def kp(x, y, slope=0.0, response=0.1):
    return cv2.KeyPoint(x, y, 4, 0, response, 0, int(round(slope * liff.SLOPE_SCALE)))


def test_score_blobs_counts_hits_misses_and_false_positives():
    blobs = [synthetic.Blob(20, 20, 6, 0.5, 0.1), synthetic.Blob(60, 20, 3, -0.5, 0.1)]
    keypoints = [kp(21, 20.5, slope=0.45),  # hit on blob 0
                 kp(25, 20),                # on blob 0's disk, 5 px off: neither
                 kp(90, 90)]                # far from both: false positive
    score = score_blobs(keypoints, blobs)
    assert score.found.tolist() == [True, False]
    assert score.tp_rate == 0.5
    assert score.false_positives == 1
    assert np.allclose(score.slope_errors, [-0.05], atol=1e-4)
    assert score_blobs([], blobs).false_positives == 0


def test_above_threshold_equals_a_run_at_that_threshold():
    shape = (5, 5, 96, 96)
    blobs = synthetic.paper_disks(8, shape, seed=1)
    lf = synthetic.render_disks(blobs, shape, noise_variance=1e-2, seed=2).astype(np.float32)
    low = liff.LiFF.create(contrastThreshold=0.01).detect(lf)
    for threshold in (0.02, 0.04, 0.08):
        direct = liff.LiFF.create(contrastThreshold=threshold).detect(lf)
        filtered = above_threshold(low, threshold)
        fields = lambda ks: sorted((k.pt, k.size, k.angle, k.class_id) for k in ks)  # noqa: E731
        assert fields(direct) == fields(filtered)


def test_consolidate_requires_the_fraction_and_finds_the_plane():
    """A point at (30, 40) with slope 0.5, detected in 15 of 25 views at the positions
    the slope convention gives, plus scattered noise detections."""
    T = S = 5
    rng = np.random.default_rng(0)
    detections = []
    for t in range(T):
        for s in range(S):
            kps = [kp(*rng.uniform(0, 100, 2))]  # noise
            if (t * S + s) % 5 < 3:  # 15 of 25 views
                kps.append(kp(30 - 0.5 * (s - 2), 40 - 0.5 * (t - 2)))
            detections.append((t, s, kps))
    found = baselines.consolidate(detections, (T, S), fraction=0.5)
    assert len(found) == 1
    assert np.hypot(found[0].pt[0] - 30, found[0].pt[1] - 40) < 0.2
    assert abs(liff.keypoint_slopes(found)[0] - 0.5) < 0.051
    assert baselines.consolidate(detections, (T, S), fraction=0.7) == ()


def test_repeated_sift_finds_clean_disks():
    shape = (5, 5, 128, 128)
    blobs = synthetic.paper_disks(6, shape, seed=3)
    lf = synthetic.render_disks(blobs, shape).astype(np.float32)
    found = baselines.repeated_sift(lf, 0.25, liff.LiFF.create(contrastThreshold=0.02))
    score = score_blobs(found, blobs)
    assert score.tp_rate >= 5 / 6
    assert np.median(np.abs(score.slope_errors)) < 0.1


@pytest.mark.parametrize("fraction", [0.0, -0.1, 1.5, float("nan")])
def test_consolidate_rejects_a_fraction_outside_0_1(fraction):
    with pytest.raises(ValueError, match="fraction"):
        baselines.consolidate([(0, 0, [kp(5, 5)])], (1, 1), fraction)
