"""liff.feature_file (the .npz of `liff detect`) and liff.matching."""

from __future__ import annotations

import re
import zipfile

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


def test_file_is_a_deflated_npz_that_numpy_reads(blob_lf, tmp_path):
    # Written at zlib level 1 (COMPRESSION_LEVEL): still an npz of deflated .npy
    # members, named as numpy's savez_compressed names them (".npz" appended).
    kps, desc = liff.LiFF.create().detectAndCompute(blob_lf, None)
    save_features(tmp_path / "f", Features(kps, desc, centre_view(blob_lf)))
    with zipfile.ZipFile(tmp_path / "f.npz") as archive:
        infos = archive.infolist()
    assert sorted(i.filename for i in infos) == ["centre_view.npy", "descriptors.npy", "digest.npy",
                                                "keypoints.npy", "meta.npy", "slopes.npy"]
    assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos)
    described = next(i for i in infos if i.filename == "descriptors.npy")
    assert described.compress_size < 0.8 * described.file_size
    with np.load(tmp_path / "f.npz", allow_pickle=False) as data:
        np.testing.assert_array_equal(data["descriptors"], desc)


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


def small_features(n=3):
    kps = tuple(cv2.KeyPoint(10.0 + i, 20.5, 3.0, 45.0, 0.01, 255 + i, (i - 1) * 4096)
                for i in range(n))
    return Features(kps, np.arange(n * 128, dtype=np.float32).reshape(n, 128))


@pytest.mark.parametrize("descriptors, expected", [
    (np.zeros((3, 64), np.float32), r"shape \(3, 64\) and dtype float32; expected an \(N, 128\)"),
    (np.zeros(384, np.float32), r"shape \(384,\)"),
    (np.zeros((3, 128, 1), np.uint8), r"shape \(3, 128, 1\)"),
    (np.full((3, 128), "a"), r"dtype <U1; expected an \(N, 128\) array of numbers"),
])
def test_save_refuses_descriptors_that_are_not_n_by_128(tmp_path, descriptors, expected):
    features = Features(small_features().keypoints, descriptors)
    with pytest.raises(ValueError, match=r"x\.npz: descriptors of .*" + expected):
        save_features(tmp_path / "x.npz", features)
    assert not (tmp_path / "x.npz").exists()


def test_save_refuses_items_that_are_not_keypoints(tmp_path):
    keypoints = small_features().keypoints + ((1.0, 2.0),)
    with pytest.raises(ValueError, match=r"x\.npz: keypoints\[3\] is tuple; expected cv2\.KeyPoint"):
        save_features(tmp_path / "x.npz", Features(keypoints, np.zeros((4, 128), np.float32)))
    assert not (tmp_path / "x.npz").exists()


def test_round_trip_of_hand_made_keypoints(tmp_path):
    features = small_features()
    save_features(tmp_path / "f.npz", features)
    with np.load(tmp_path / "f.npz") as data:
        assert data["keypoints"].shape == (3, 6) and data["keypoints"].dtype == np.float64
        np.testing.assert_array_equal(data["slopes"], [-1 / 16, 0, 1 / 16])
    back = load_features(tmp_path / "f.npz")
    fields = [(k.pt, k.size, k.angle, k.response, k.octave, k.class_id) for k in back.keypoints]
    assert fields == [(k.pt, k.size, k.angle, k.response, k.octave, k.class_id)
                      for k in features.keypoints]
    np.testing.assert_array_equal(back.slopes, [-1 / 16, 0, 1 / 16])


def damaged_file(tmp_path, **changes):
    """A valid feature file with arrays replaced (None removes one)."""
    arrays = dict(keypoints=np.tile([10.0, 20.0, 3.0, 45.0, 0.01, 255.0], (3, 1)),
                  slopes=np.zeros(3), descriptors=np.zeros((3, 128), np.float32),
                  centre_view=np.zeros((4, 5, 3), np.uint8), meta=np.array("{}"))
    arrays.update(changes)
    path = tmp_path / "damaged.npz"
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


def with_nan(shape, index, value=np.nan):
    array = np.zeros(shape)
    array[index] = value
    return array


@pytest.mark.parametrize("changes, expected", [
    (dict(keypoints=with_nan((3, 6), (1, 0))), "keypoints holds NaN or infinity"),
    (dict(keypoints=with_nan((3, 6), (2, 5), np.inf)), "keypoints holds NaN or infinity"),
    (dict(slopes=with_nan(3, 0, -np.inf)), "slopes holds NaN or infinity"),
    (dict(descriptors=with_nan((3, 128), (0, 5))), "descriptors holds NaN or infinity"),
    (dict(descriptors=np.full((3, 128), "x")), "descriptors has dtype <U1, not numbers"),
    (dict(keypoints=np.full((3, 6), b"1")), r"keypoints has dtype \|S1, not numbers"),
    (dict(slopes=np.ones(3, np.complex128)), "slopes has dtype complex128, not numbers"),
    (dict(keypoints=with_nan((3, 6), (0, 5), 2.0 ** 40)), r"octaves span 0 \.\. 1\.09951e\+12, beyond int32"),
    (dict(keypoints=with_nan((3, 6), (0, 5), -2.0 ** 31 - 1)), r"octaves span -2\.14748e\+09 .*beyond int32"),
    (dict(slopes=with_nan(3, 0, 1e6)), r"slopes span 0 \.\. 1e\+06; expected \|slope\| < 32768"),
    (dict(keypoints=with_nan((3, 6), (0, 2), 1e300)), r"keypoints hold 1e\+300, beyond float32"),
    (dict(meta=np.array("[1, 2]")), "meta is list, not a JSON object"),
    (dict(centre_view=np.zeros((4, 5), np.float64)), "centre_view is ndarray float64 .*not a uint8 image"),
])
def test_damaged_arrays_are_named(tmp_path, changes, expected):
    path = damaged_file(tmp_path, **changes)
    with pytest.raises(ValueError, match=expected + r".*; expected a liff feature file") as info:
        load_features(path)
    assert str(path) in str(info.value)


def test_member_that_is_not_npy_is_named(tmp_path):
    """np.load returns the raw bytes of a zip member that is not a .npy file."""
    path = damaged_file(tmp_path)
    assert len(load_features(path).keypoints) == 3
    rebuilt = tmp_path / "bytes.npz"
    with zipfile.ZipFile(path) as old, zipfile.ZipFile(rebuilt, "w") as new:
        for name in old.namelist():
            new.writestr(name, b"not an array" if name == "slopes.npy" else old.read(name))
    with pytest.raises(ValueError, match=rf"{re.escape(str(rebuilt))}: slopes is bytes, not an array"):
        load_features(rebuilt)


def test_largest_valid_values_still_load(tmp_path):
    octave = 2.0 ** 31 - 1
    path = damaged_file(tmp_path, keypoints=np.tile([1e38, -1e38, 3.0, 45.0, 0.01, octave], (3, 1)),
                        slopes=np.array([-32768.0, 0.0, 32767.99]))
    back = load_features(path)
    assert back.keypoints[0].octave == 2 ** 31 - 1
    assert [k.class_id for k in back.keypoints] == [-2 ** 31, 0, round(32767.99 * 65536)]
