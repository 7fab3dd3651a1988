"""A 2-D image is a 1x1 light field, for which LiFF must behave as cv2.SIFT.

cv2.SIFT reports positions of its upsampled first octave +0.25 px off (it maps
upsampled pixel x' to x'/2 although cv2.resize samples it at x'/2 - 0.25); LiFF does
not, so LiFF pt == SIFT pt - 0.25 in x and y. LiFF also keeps extrema whose
refinement cycles between two samples (flat-topped blobs, e.g. large uniform disks),
which cv2.SIFT loses after five steps: LiFF finds every SIFT keypoint, plus those.
Everything else must agree.
"""

import cv2
import numpy as np
import pytest

import liff
from lfhelpers import assert_same_keypoints, nearest_distances, points
from liff import synthetic

SIFT_BIAS = 0.25


@pytest.fixture(scope="module")
def both(texture_image):
    kps, desc = liff.LiFF.create().detectAndCompute(texture_image)
    skps, sdesc = cv2.SIFT.create().detectAndCompute(texture_image, None)
    return kps, desc, skps, sdesc


def pair_up(kps, skps):
    """For each LiFF keypoint, the SIFT keypoint at the same (corrected) place and angle."""
    sp = points(skps) - SIFT_BIAS
    pairs = []
    for i, k in enumerate(kps):
        d = np.hypot(sp[:, 0] - k.pt[0], sp[:, 1] - k.pt[1])
        cand = [j for j in np.flatnonzero(d < 0.05) if abs(skps[j].angle - k.angle) < 1e-2]
        if cand:
            pairs.append((i, cand[0]))
    return pairs


def test_same_keypoints_as_sift(both):
    kps, _, skps, _ = both
    assert len(kps) > 100
    # LiFF misses (almost) none of SIFT's keypoints (observed: all 225)
    back = nearest_distances(points(skps) - SIFT_BIAS, points(kps)) < 0.05
    assert back.mean() >= 0.98
    # and its extra ones, from refinements that cycle, are few (observed 243 vs 225)
    close = nearest_distances(points(kps), points(skps) - SIFT_BIAS) < 0.05
    assert len(skps) <= len(kps) <= 1.12 * len(skps)
    assert close.mean() >= 0.88


def test_large_disk_lost_by_sift_is_found():
    """A disk of radius 7.3 px whose DoG top is flat: SIFT's refinement cycles between two
    samples and drops it; LiFF keeps it, centred within 0.1 px."""
    disk = synthetic.Blob(40.23, 40.73, 7.29, 0.0, 0.1)
    image = synthetic.render_disks([disk], (1, 1, 80, 80))[0, 0].astype(np.float32)
    sift = cv2.SIFT.create(contrastThreshold=0.02).detect(np.round(image * 255).astype(np.uint8))
    assert not any(np.hypot(k.pt[0] - disk.x, k.pt[1] - disk.y) < 2 for k in sift)
    found = liff.LiFF.create(contrastThreshold=0.02).detect(image)
    assert len(found) >= 1
    assert all(np.hypot(k.pt[0] - disk.x, k.pt[1] - disk.y) < 0.1 for k in found)
    # The packed octave stays cv::SIFT's: octave byte, layer in [1, 3], sub-layer byte.
    for k in found:
        assert 0 <= k.octave >> 16 <= 255 and 1 <= (k.octave >> 8) & 255 <= 3


def test_sizes_octaves_responses_equal_sift(both):
    kps, _, skps, _ = both
    pairs = pair_up(kps, skps)
    assert len(pairs) >= 0.9 * len(kps)  # observed 225 of 243 (all of SIFT's 225; angles within 0.01 deg)
    for i, j in pairs:
        k, s = kps[i], skps[j]
        assert k.size == pytest.approx(s.size, rel=1e-4)
        # octave and layer bytes equal; the sub-layer byte round((xi + 0.5) * 255)
        # may differ by one count (float rounding; sizes agree to 1e-4)
        assert k.octave & 0xFFFF == s.octave & 0xFFFF
        assert abs((k.octave >> 16) - (s.octave >> 16)) <= 1
        assert k.response == pytest.approx(s.response, rel=1e-3, abs=1e-6)


def test_descriptors_equal_sift(both):
    kps, desc, skps, sdesc = both
    pairs = np.array(pair_up(kps, skps))
    diff = np.abs(desc[pairs[:, 0]] - sdesc[pairs[:, 1]]).max(axis=1)
    # observed: 89% bit-identical, the rest within one count
    assert np.mean(diff == 0) >= 0.8
    assert np.mean(diff <= 1) >= 0.98


def test_compute_on_sift_keypoints_gives_sift_descriptors(texture_image):
    skps, sdesc = cv2.SIFT.create().detectAndCompute(texture_image, None)
    moved = [
        cv2.KeyPoint(k.pt[0] - SIFT_BIAS, k.pt[1] - SIFT_BIAS, k.size, k.angle, k.response, k.octave, 0)
        for k in skps
    ]
    kps, desc = liff.LiFF.create().compute(texture_image, moved)
    assert len(kps) == len(skps)
    diff = np.abs(desc - sdesc).max(axis=1)
    assert np.mean(diff == 0) >= 0.8 and np.mean(diff <= 1) >= 0.98


@pytest.mark.parametrize("first, last", [(-1.0, 1.0), (-0.5, 1.5), (0.3, 0.3), (-2.0, -1.0)])
def test_2d_slopes_are_the_middle_of_the_range(texture_image, first, last):
    kps = liff.LiFF.create(firstSlope=first, lastSlope=last).detect(texture_image)
    assert len(kps) > 0
    expected = round((first + last) / 2 * liff.SLOPE_SCALE)
    assert {k.class_id for k in kps} == {expected}


def test_2d_image_equals_1x1_light_field(texture_image):
    d = liff.LiFF.create()
    k2, d2 = d.detectAndCompute(texture_image)
    for lf in (texture_image[None, None], texture_image[:, :, None], texture_image[None, None, :, :, None]):
        k4, d4 = d.detectAndCompute(lf)
        assert_same_keypoints(k2, k4)
        np.testing.assert_array_equal(d2, d4)


def test_colour_image_like_sift_on_grey():
    rng = np.random.default_rng(4)
    bgr = cv2.GaussianBlur(rng.integers(0, 256, (128, 128, 3), dtype=np.uint8), (0, 0), 2.5)
    bgr = cv2.normalize(bgr, None, 0, 255, cv2.NORM_MINMAX)
    kps = liff.LiFF.create().detect(bgr)
    skps = cv2.SIFT.create().detect(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), None)
    # LiFF converts colour in float, SIFT after rounding to uint8: nearly the same set
    close = nearest_distances(points(kps), points(skps) - SIFT_BIAS) < 0.1
    assert len(kps) > 20 and close.mean() >= 0.9


@pytest.mark.parametrize("radius", [2.0, 2.4, 3.0])
def test_symmetric_blob_detected_when_sift_detects_it(radius):
    """A Gaussian blob centred on the pixel lattice gives exactly equal DoG samples.

    cv2.SIFT accepts an extremum that ties with a neighbour (it compares with >=);
    LiFF on a 2-D image must then find it too. Observed bug: with radius 2.0 LiFF
    finds nothing for any of these centres while cv2.SIFT finds 8..24 keypoints
    (LiFF's extremum test is strict, extrema.cpp beats3x3 uses > / <).
    """
    missed = []
    for x in (40.0, 40.25, 40.5, 40.75):
        for y in (50.0, 50.25):
            blob = synthetic.Blob(x, y, radius, 0.0, 0.4)
            img = synthetic.render_disks([blob], (1, 1, 96, 96), profile="gaussian")[0, 0]
            img = np.round(img * 255).astype(np.uint8)
            sift_n = len(cv2.SIFT.create().detect(img, None))
            liff_kps = liff.LiFF.create().detect(img)
            near = nearest_distances(np.array([[x, y]]), points(liff_kps))[0] < 0.5
            if sift_n > 0 and not near:
                missed.append(((x, y), f"SIFT {sift_n} keypoints, LiFF {len(liff_kps)}"))
    assert not missed, f"radius {radius}: LiFF misses blobs that cv2.SIFT finds: {missed}"
