"""Masks restrict where keypoints are; nfeatures keeps the strongest."""

import cv2
import numpy as np
import pytest

import liff
from lfhelpers import assert_no_descriptors, assert_same_keypoints, kp_fields


def rect_mask(shape, y0, y1, x0, x1, dtype):
    m = np.zeros(shape, dtype=dtype)
    m[y0:y1, x0:x1] = 255 if dtype == np.uint8 else True
    return m


def inside(mask, kps):
    """Whether each keypoint's nearest pixel (round half up, as cvRound) is set."""
    return [bool(mask[int(np.floor(k.pt[1] + 0.5)), int(np.floor(k.pt[0] + 0.5))]) for k in kps]


@pytest.mark.parametrize("dtype", [np.uint8, np.bool_])
def test_mask_keeps_keypoints_inside_and_is_a_subset(detector, blob_lf, dtype):
    full_k, full_d = detector.detectAndCompute(blob_lf)
    mask = rect_mask(blob_lf.shape[2:], 20, 70, 10, 55, dtype)
    kps, desc = detector.detectAndCompute(blob_lf, mask)
    assert 0 < len(kps) < len(full_k)
    assert all(inside(mask, kps))
    # masked result == the unmasked keypoints that fall inside the mask
    full = {kp_fields(k): i for i, k in enumerate(full_k)}
    assert all(kp_fields(k) in full for k in kps)
    expected = [k for k, ok in zip(full_k, inside(mask, full_k)) if ok]
    assert_same_keypoints(kps, expected)
    # descriptors do not depend on the mask
    rows = [full[kp_fields(k)] for k in kps]
    np.testing.assert_array_equal(desc, full_d[rows])
    # detect() honours the mask too, identically
    assert_same_keypoints(detector.detect(blob_lf, mask=mask), kps)


def test_bool_and_uint8_masks_agree(detector, blob_lf):
    rng = np.random.default_rng(0)
    mask_b = rng.random(blob_lf.shape[2:]) < 0.5
    a = detector.detect(blob_lf, mask_b)
    b = detector.detect(blob_lf, mask_b.astype(np.uint8))
    c = detector.detect(blob_lf, mask_b.astype(np.uint8) * 7)  # any non-zero value
    assert_same_keypoints(a, b)
    assert_same_keypoints(a, c)
    assert all(inside(mask_b, a))


def test_empty_and_full_masks(detector, blob_lf):
    shape = blob_lf.shape[2:]
    kps, desc = detector.detectAndCompute(blob_lf, np.zeros(shape, np.uint8))
    assert kps == ()
    assert_no_descriptors(desc)
    assert_same_keypoints(
        detector.detect(blob_lf, np.ones(shape, np.uint8)), detector.detect(blob_lf)
    )


def test_single_channel_3d_mask_as_cv2_sift(detector, blob_lf, texture_image):
    """A mask of shape (V, U, 1) is a one-channel image, as cv2.SIFT takes it."""
    mask = rect_mask(blob_lf.shape[2:], 20, 70, 10, 55, np.uint8)
    assert_same_keypoints(detector.detect(blob_lf, mask[:, :, None]), detector.detect(blob_lf, mask))
    mask2 = rect_mask(texture_image.shape, 0, 80, 0, 160, np.uint8)
    assert_same_keypoints(detector.detect(texture_image, mask2[:, :, None]),
                          detector.detect(texture_image, mask2))
    assert len(cv2.SIFT.create().detect(texture_image, mask2[:, :, None])) > 0


def test_mask_on_2d_image(detector, texture_image):
    mask = rect_mask(texture_image.shape, 0, 80, 0, 160, np.uint8)
    kps = detector.detect(texture_image, mask)
    assert len(kps) > 0 and all(inside(mask, kps))


def best_with_ties(responses, n):
    """cv2.KeyPointsFilter.retainBest's rule: the n strongest and all tied with the n-th."""
    bar = sorted(responses, reverse=True)[n - 1]
    return sorted((r for r in responses if r >= bar), reverse=True)


@pytest.mark.parametrize("n", [1, 2, 5, 17])
def test_nfeatures_keeps_the_strongest(blob_lf, n):
    all_k = liff.LiFF.create().detect(blob_lf)
    assert len(all_k) > n
    kps, desc = liff.LiFF.create(nfeatures=n).detectAndCompute(blob_lf)
    assert len(kps) >= n and desc.shape == (len(kps), 128)
    kept = sorted((k.response for k in kps), reverse=True)
    assert kept == best_with_ties([k.response for k in all_k], n)
    # the kept keypoints are unchanged members of the full set, in the same order
    assert_same_keypoints(kps, [k for k in all_k if k.response >= kept[-1]])


def test_nfeatures_keeps_every_orientation_of_a_tie_as_cv2_sift():
    """A round blob's extremum has several orientations, one keypoint each with equal
    responses: cv2.SIFT keeps all of them at nfeatures=1, and so does LiFF (it used to
    keep one). (Which orientations a nearly flat histogram gives can differ between
    the two by one peak at the 80% bar; the count of a tie is what is compared here.)"""
    yy, xx = np.mgrid[0:96, 0:96]
    image = (60 + 150 * np.exp(-((xx - 47.0) ** 2 + (yy - 47.0) ** 2) / (2 * 6.0 ** 2)))
    image = np.round(image).astype(np.uint8)
    sift_all = cv2.SIFT.create().detect(image, None)
    sift = cv2.SIFT.create(nfeatures=1).detect(image, None)
    best = max(k.response for k in sift_all)
    assert len(sift) == sum(k.response == best for k in sift_all) > 1
    ours_all = liff.LiFF.create().detect(image)
    ours = liff.LiFF.create(nfeatures=1).detect(image)
    best = max(k.response for k in ours_all)
    assert_same_keypoints(ours, [k for k in ours_all if k.response == best])
    assert len(ours) == len(sift)


def test_nfeatures_larger_than_available(blob_lf):
    all_k = liff.LiFF.create().detect(blob_lf)
    kps = liff.LiFF.create(nfeatures=len(all_k) + 100).detect(blob_lf)
    assert_same_keypoints(kps, all_k)
    assert_same_keypoints(liff.LiFF.create(nfeatures=len(all_k)).detect(blob_lf), all_k)


def test_nfeatures_with_mask(blob_lf):
    mask = rect_mask(blob_lf.shape[2:], 0, 48, 0, 96, np.uint8)
    masked = liff.LiFF.create().detect(blob_lf, mask)
    kps = liff.LiFF.create(nfeatures=3).detect(blob_lf, mask)
    assert len(masked) > 3
    assert all(inside(mask, kps))
    assert sorted((k.response for k in kps), reverse=True) == best_with_ties(
        [k.response for k in masked], 3)


def test_set_nfeatures_after_creation(blob_lf):
    d = liff.LiFF.create()
    n_all = len(d.detect(blob_lf))
    d.setNFeatures(4)
    assert len(d.detect(blob_lf)) == len(liff.LiFF.create(nfeatures=4).detect(blob_lf)) >= 4
    d.setNFeatures(0)
    assert len(d.detect(blob_lf)) == n_all
