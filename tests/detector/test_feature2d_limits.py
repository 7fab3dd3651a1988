"""What does not cross over into OpenCV (README, "What does not cross over"): a LiFF
detector is refused by cv2's Feature2D wrappers such as AffineFeature, and the
README's stitching workaround works."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import liff


def test_a_liff_detector_does_not_cross_into_cv2_feature2d_and_the_workaround_works():
    """README, "What does not cross over": the refusal, and the stitching workaround."""
    detector = liff.LiFF.create()
    with pytest.raises(TypeError, match="Feature2D"):
        cv2.AffineFeature.create(detector)
    lf = liff.synthetic.textured_layers((5, 5, 96, 128), noise_variance=0).light_field
    features = []
    for i, light_field in enumerate((lf[:, :, 4:, 7:], lf[:, :, :-4, :-7])):
        keypoints, descriptors = detector.detectAndCompute(light_field, None)
        f = cv2.detail.ImageFeatures()
        f.img_idx, f.img_size = i, (light_field.shape[3], light_field.shape[2])
        f.keypoints, f.descriptors = keypoints, cv2.UMat(descriptors)
        features.append(f)
    pairs = cv2.detail.BestOf2NearestMatcher(False, 0.3).apply2(features)
    assert pairs[1].num_inliers > 50
    np.testing.assert_allclose(pairs[1].H[:2, 2], (7, 4), atol=0.5)  # the shift between the two

