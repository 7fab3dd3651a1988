"""Masks restrict where keypoints are; nfeatures keeps the strongest."""

import numpy as np
import pytest

import liff

from lfhelpers import assert_same_keypoints, kp_fields


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
    assert detector.detectAndCompute(blob_lf, np.zeros(shape, np.uint8)) == ((), None)
    assert_same_keypoints(
        detector.detect(blob_lf, np.ones(shape, np.uint8)), detector.detect(blob_lf)
    )


def test_mask_on_2d_image(detector, texture_image):
    mask = rect_mask(texture_image.shape, 0, 80, 0, 160, np.uint8)
    kps = detector.detect(texture_image, mask)
    assert len(kps) > 0 and all(inside(mask, kps))


@pytest.mark.parametrize("n", [1, 2, 5, 17])
def test_nfeatures_keeps_the_strongest(blob_lf, n):
    all_k = liff.LiFF.create().detect(blob_lf)
    assert len(all_k) > n
    kps, desc = liff.LiFF.create(nfeatures=n).detectAndCompute(blob_lf)
    assert len(kps) == n and desc.shape == (n, 128)
    responses = sorted((k.response for k in all_k), reverse=True)
    kept = sorted((k.response for k in kps), reverse=True)
    assert kept == responses[:n]
    # the kept keypoints are unchanged members of the full set
    full = {kp_fields(k) for k in all_k}
    assert all(kp_fields(k) in full for k in kps)


def test_nfeatures_larger_than_available(blob_lf):
    all_k = liff.LiFF.create().detect(blob_lf)
    kps = liff.LiFF.create(nfeatures=len(all_k) + 100).detect(blob_lf)
    assert_same_keypoints(kps, all_k)
    assert_same_keypoints(liff.LiFF.create(nfeatures=len(all_k)).detect(blob_lf), all_k)


def test_nfeatures_with_mask(blob_lf):
    mask = rect_mask(blob_lf.shape[2:], 0, 48, 0, 96, np.uint8)
    masked = liff.LiFF.create().detect(blob_lf, mask)
    kps = liff.LiFF.create(nfeatures=3).detect(blob_lf, mask)
    assert len(kps) == min(3, len(masked))
    assert all(inside(mask, kps))
    best = sorted((k.response for k in masked), reverse=True)[:3]
    assert sorted((k.response for k in kps), reverse=True) == best


def test_set_nfeatures_after_creation(blob_lf):
    d = liff.LiFF.create()
    n_all = len(d.detect(blob_lf))
    d.setNFeatures(4)
    assert len(d.detect(blob_lf)) == 4
    d.setNFeatures(0)
    assert len(d.detect(blob_lf)) == n_all
