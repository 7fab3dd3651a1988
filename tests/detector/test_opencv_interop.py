"""LiFF's outputs go unchanged into OpenCV: matchers, drawing, homography."""

import cv2
import numpy as np
import pytest

import liff
from lfhelpers import textured_lf
from liff import synthetic

SHIFT = (9, -5)  # camera offset (dx, dy) between the two light fields, in pixels


@pytest.fixture(scope="module")
def pair():
    """Two 5x5x128x128 light fields of a textured plane at slope 1, the second with
    the camera moved by SHIFT: content at (x, y) in the first is at (x - dx, y - dy)
    in the second."""
    shape = (5, 5, 128, 128)
    a = textured_lf(shape, slope=1, offset=(0, 0), seed=7)
    b = textured_lf(shape, slope=1, offset=SHIFT, seed=7)
    d = liff.LiFF.create()
    return a, b, d.detectAndCompute(a), d.detectAndCompute(b)


def ratio_test(knn, ratio=0.75):
    return [m[0] for m in knn if len(m) == 2 and m[0].distance < ratio * m[1].distance]


def assert_translation(kps_a, kps_b, matches):
    src = np.float32([kps_a[m.queryIdx].pt for m in matches]).reshape(-1, 1, 2)
    dst = np.float32([kps_b[m.trainIdx].pt for m in matches]).reshape(-1, 1, 2)
    H, inliers = cv2.findHomography(src, dst, cv2.RANSAC, 1.0)
    assert H is not None and inliers.mean() > 0.8
    H = H / H[2, 2]
    # observed: translation within 0.03 px, linear part within 1.3e-3 of identity
    assert H[0, 2] == pytest.approx(-SHIFT[0], abs=0.5)
    assert H[1, 2] == pytest.approx(-SHIFT[1], abs=0.5)
    np.testing.assert_allclose(H[:2, :2], np.eye(2), atol=0.01)
    np.testing.assert_allclose(H[2, :2], 0, atol=1e-3)
    # every corner of the view maps within 0.5 px of where the shift puts it
    corners = np.float32([[0, 0], [127, 0], [0, 127], [127, 127]]).reshape(-1, 1, 2)
    mapped = cv2.perspectiveTransform(corners, H).reshape(-1, 2)
    np.testing.assert_allclose(mapped, corners.reshape(-1, 2) - SHIFT, atol=0.5)


def test_bf_matcher_knn_ratio_and_homography(pair):
    _, _, (ka, da), (kb, db) = pair
    bf = cv2.BFMatcher(liff.LiFF.create().defaultNorm())
    good = ratio_test(bf.knnMatch(da, db, k=2))
    assert len(good) > 100  # observed 247 of 320 x 311 keypoints
    assert_translation(ka, kb, good)


def test_bf_matcher_cross_check(pair):
    _, _, (ka, da), (kb, db) = pair
    matches = cv2.BFMatcher(cv2.NORM_L2, crossCheck=True).match(da, db)
    assert len(matches) > 100
    offsets = np.array([np.subtract(kb[m.trainIdx].pt, ka[m.queryIdx].pt) for m in matches])
    assert np.mean(np.all(np.abs(offsets + SHIFT) < 0.5, axis=1)) > 0.8


def test_flann_kdtree_matcher(pair):
    _, _, (ka, da), (kb, db) = pair
    flann = cv2.FlannBasedMatcher(dict(algorithm=1, trees=4), dict(checks=64))
    good = ratio_test(flann.knnMatch(da, db, k=2))
    assert len(good) > 100
    assert_translation(ka, kb, good)


def test_uint8_descriptors_match_too(pair):
    a, b, _, _ = pair
    d8 = liff.LiFF.create(descriptorType=cv2.CV_8U)
    ka, da = d8.detectAndCompute(a)
    kb, db = d8.detectAndCompute(b)
    assert da.dtype == np.uint8
    good = ratio_test(cv2.BFMatcher(cv2.NORM_L2).knnMatch(da, db, k=2))
    assert_translation(ka, kb, good)


def test_matching_across_slopes_is_consistent(pair):
    # matched features report the same slope in both light fields (the plane's, 1)
    _, _, (ka, da), (kb, db) = pair
    good = ratio_test(cv2.BFMatcher().knnMatch(da, db, k=2))
    sa = liff.keypoint_slopes([ka[m.queryIdx] for m in good])
    sb = liff.keypoint_slopes([kb[m.trainIdx] for m in good])
    assert np.median(np.abs(sa - sb)) < 0.01
    assert np.median(sa) == pytest.approx(1.0, abs=0.02)


def test_blob_scene_translation():
    # The same blob scene seen from a camera moved by (dx, dy): matches give it back.
    shape = (5, 5, 128, 128)
    blobs = synthetic.random_blob_layers([-0.4, 0.3], shape, blobs_per_layer=10, seed=11, margin=20)
    dx, dy = 3.5, -2.25
    moved = [synthetic.Blob(b.x - dx, b.y - dy, b.radius, b.slope, b.intensity) for b in blobs]
    d = liff.LiFF.create()
    ka, da = d.detectAndCompute(synthetic.render_disks(blobs, shape, profile="gaussian"))
    kb, db = d.detectAndCompute(synthetic.render_disks(moved, shape, profile="gaussian"))
    matches = cv2.BFMatcher(cv2.NORM_L2, crossCheck=True).match(da, db)
    src = np.float32([ka[m.queryIdx].pt for m in matches])
    dst = np.float32([kb[m.trainIdx].pt for m in matches])
    H, inliers = cv2.findHomography(src, dst, cv2.RANSAC, 0.5)
    assert inliers.sum() >= 8  # observed 24 of 27 cross-checked matches
    H = H / H[2, 2]
    centre = cv2.perspectiveTransform(np.float32([[[64, 64]]]), H)[0, 0]
    np.testing.assert_allclose(centre, (64 - dx, 64 - dy), atol=0.5)


def test_draw_keypoints_and_matches(pair):
    a, b, (ka, da), (kb, db) = pair
    view_a = np.round(a[2, 2] * 255).astype(np.uint8)
    view_b = np.round(b[2, 2] * 255).astype(np.uint8)
    out = cv2.drawKeypoints(view_a, ka, None, flags=cv2.DRAW_MATCHES_FLAGS_DRAW_RICH_KEYPOINTS)
    assert out.shape == (128, 128, 3) and out.dtype == np.uint8
    assert not np.array_equal(out[..., 0], view_a)  # something was drawn
    good = ratio_test(cv2.BFMatcher().knnMatch(da, db, k=2))[:30]
    canvas = cv2.drawMatches(view_a, ka, view_b, kb, good, None)
    assert canvas.shape == (128, 256, 3)
    knn = cv2.BFMatcher().knnMatch(da, db, k=2)[:10]
    assert cv2.drawMatchesKnn(view_a, ka, view_b, kb, knn, None).shape == (128, 256, 3)


def test_keypoint_convert_and_pickle_round_trip(blob_lf):
    import pickle

    kps = liff.LiFF.create().detect(blob_lf)
    pts = cv2.KeyPoint_convert(kps)
    assert pts.shape == (len(kps), 2)
    back = cv2.KeyPoint_convert(pts.tolist(), size=5.0)
    np.testing.assert_allclose(cv2.KeyPoint_convert(back), pts)
    # class_id (the slope) survives a copy through plain tuples
    rebuilt = [cv2.KeyPoint(*k.pt, k.size, k.angle, k.response, k.octave, k.class_id) for k in kps]
    np.testing.assert_array_equal(liff.keypoint_slopes(rebuilt), liff.keypoint_slopes(kps))
    assert pickle.loads(pickle.dumps(liff.keypoint_slopes(kps))).shape == (len(kps),)


# --- Lists of inputs, as cv2.SIFT.detect([img1, img2]) takes them ---------------------

def _list_inputs():
    rng = np.random.default_rng(3)
    image = cv2.GaussianBlur((rng.random((64, 80)) * 255).astype(np.uint8), (0, 0), 1.5)
    colour = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)[::-1].copy()  # another image, BGR
    light_field = textured_lf((3, 3, 48, 56), slope=1, seed=4)
    return [image, colour, light_field]


def test_a_list_of_inputs_gives_one_result_per_input_as_cv2_sift():
    detector = liff.LiFF.create()
    inputs = _list_inputs()
    # cv2.SIFT's own list semantics, on the installed cv2: one tuple per image.
    sift = cv2.SIFT.create().detect(inputs[:2])
    assert isinstance(sift, tuple) and len(sift) == 2 and all(isinstance(k, tuple) for k in sift)
    found = detector.detect(inputs)
    assert isinstance(found, tuple) and len(found) == len(inputs)
    for item, keypoints in zip(inputs, found):
        assert [k.pt for k in keypoints] == [k.pt for k in detector.detect(item)]
    assert sum(len(k) for k in found) > 0
    assert [[k.pt for k in ks] for ks in detector.detect(tuple(inputs))] == \
        [[k.pt for k in ks] for ks in found]
    assert detector.detect([]) == ()
    keypoints, descriptors = detector.compute(inputs, list(found))
    assert [len(k) for k in keypoints] == [len(k) for k in found]
    for item, k, d in zip(inputs, found, descriptors):
        np.testing.assert_array_equal(d, detector.compute(item, k)[1])


def test_a_list_of_inputs_takes_a_list_of_masks():
    detector = liff.LiFF.create()
    inputs = _list_inputs()[:2]
    none = np.zeros(inputs[0].shape[:2], np.uint8)
    found = detector.detect(inputs, [none, None])
    assert found[0] == () and len(found[1]) == len(detector.detect(inputs[1]))
    assert detector.detect(inputs, masks=[none, none]) == ((), ())
    with pytest.raises(ValueError, match="expected a list of 2"):
        detector.detect(inputs, [none])
    with pytest.raises(ValueError, match="expected a list of 2"):
        detector.detect(inputs, none)


def test_detect_and_compute_refuses_a_list_as_cv2_sift_does():
    inputs = _list_inputs()[:2]
    with pytest.raises(cv2.error):
        cv2.SIFT.create().detectAndCompute(inputs, None)
    with pytest.raises(TypeError, match="not a list of 2 arrays"):
        liff.LiFF.create().detectAndCompute(inputs, None)
    with pytest.raises(TypeError, match="list of keypoint lists"):
        liff.LiFF.create().compute(inputs, None)
