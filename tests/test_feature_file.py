"""liff.feature_file (the .npz of `liff detect`) and liff.matching."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import liff
from liff.feature_file import Features, centre_view, load_features, save_features
from liff.matching import ratio_matches, verify


@pytest.mark.parametrize("descriptor_type", [cv2.CV_32F, cv2.CV_8U])
def test_round_trip_keeps_every_field(blob_lf, tmp_path, descriptor_type):
    kps, desc = liff.LiFF.create(descriptorType=descriptor_type).detectAndCompute(blob_lf, None)
    path = tmp_path / "f.npz"
    save_features(path, Features(kps, desc, centre_view(blob_lf), {"note": "x"}))
    back = load_features(path)
    assert len(back.keypoints) == len(kps) > 0
    for a, b in zip(kps, back.keypoints):
        assert (a.pt, a.size, a.angle, a.response, a.octave, a.class_id) == \
               (b.pt, b.size, b.angle, b.response, b.octave, b.class_id)
    assert back.descriptors.dtype == desc.dtype
    np.testing.assert_array_equal(back.descriptors, desc)
    assert back.meta == {"note": "x"} and back.centre_view.dtype == np.uint8


def test_no_features_round_trip(tmp_path):
    save_features(tmp_path / "e.npz", Features((), None))
    back = load_features(tmp_path / "e.npz")
    assert back.keypoints == () and back.descriptors is None and back.centre_view is None


def test_bad_feature_files_are_named(tmp_path):
    with pytest.raises(ValueError, match="1 keypoints but 2 descriptors"):
        save_features(tmp_path / "x.npz", Features((cv2.KeyPoint(1, 2, 3),), np.zeros((2, 128))))
    np.savez(tmp_path / "other.npz", light_field=np.zeros((2, 2, 4, 4)))
    with pytest.raises(ValueError, match="other.npz.*no keypoints"):
        load_features(tmp_path / "other.npz")
    np.savez(tmp_path / "shapes.npz", keypoints=np.zeros((3, 6)), slopes=np.zeros(3),
             descriptors=np.zeros((2, 128)))
    with pytest.raises(ValueError, match=r"shapes.npz.*expected \(N, 6\)"):
        load_features(tmp_path / "shapes.npz")


def test_centre_view_drops_alpha():
    lf = np.zeros((3, 4, 8, 9, 4), np.uint8)
    lf[1, 2, ..., 0] = 7
    view = centre_view(lf)
    assert view.shape == (8, 9, 3) and np.all(view[..., 0] == 7)
    assert centre_view(np.zeros((8, 9, 2))).shape == (8, 9)


def test_ratio_test_and_translation_homography(texture_image):
    sift = cv2.SIFT.create()
    kps_a, desc_a = sift.detectAndCompute(texture_image[:140, :140], None)
    kps_b, desc_b = sift.detectAndCompute(texture_image[5:145, 9:149], None)
    matches = ratio_matches(desc_a, desc_b, 0.75)
    result = verify(kps_a, kps_b, matches, "homography", 2.0)
    assert result.inlier_count >= 0.8 * len(matches) > 20
    np.testing.assert_allclose(result.model[:2, 2], [-9, -5], atol=0.5)
    assert ratio_matches(None, desc_b) == [] and verify(kps_a, kps_b, []).model is None
    with pytest.raises(ValueError, match="ratio"):
        ratio_matches(desc_a, desc_b, 1.5)
    with pytest.raises(ValueError, match="homography"):
        verify(kps_a, kps_b, matches, "affine")
