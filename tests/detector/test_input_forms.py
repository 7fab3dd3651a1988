"""Input forms: dtypes, colour, layouts, memory order; inputs are never modified."""

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import liff
from lfhelpers import (
    assert_close_keypoints,
    assert_no_descriptors,
    assert_same_keypoints,
    nearest_distances,
    points,
    to_dtype,
)

DTYPES = [np.uint8, np.uint16, np.float32, np.float64]


@pytest.fixture(scope="module")
def reference(blob_lf):
    return liff.LiFF.create().detectAndCompute(blob_lf)


@pytest.mark.parametrize("dtype", DTYPES)
def test_dtypes_agree(blob_lf, reference, dtype):
    ref_k, ref_d = reference
    lf = to_dtype(blob_lf, dtype)
    kps, desc = liff.LiFF.create().detectAndCompute(lf)
    assert desc.dtype == np.float32
    # observed: the same 52 keypoints for all four; uint8 moves them by < 0.01 px
    assert abs(len(kps) - len(ref_k)) <= max(2, 0.05 * len(ref_k))
    dist = nearest_distances(points(kps), points(ref_k))
    assert np.mean(dist < 0.1) >= 0.9
    # slope of each keypoint vs the slope of the nearest reference keypoint
    d2 = ((points(kps)[:, None, :] - points(ref_k)[None, :, :]) ** 2).sum(-1)
    nearest = d2.argmin(axis=1)
    slope_diff = np.abs(liff.keypoint_slopes(kps) - liff.keypoint_slopes(ref_k)[nearest])
    assert np.median(slope_diff) < 0.01
    if dtype in (np.float32, np.float64):
        assert_same_keypoints(kps, ref_k)  # float32 and float64 inputs are bit-identical
        np.testing.assert_array_equal(desc, ref_d)


@pytest.mark.parametrize("dtype", DTYPES)
def test_integer_scaling(blob_lf, dtype):
    # uint8 is /255 and uint16 /65535: a float input holding the same values agrees
    lf = to_dtype(blob_lf, dtype)
    scale = np.iinfo(dtype).max if np.dtype(dtype).kind == "u" else 1.0
    as_float = (lf / scale).astype(np.float32)
    # equal up to float rounding of the scaling (observed: < 1e-4 px)
    assert_close_keypoints(liff.LiFF.create().detect(lf), liff.LiFF.create().detect(as_float))


@pytest.mark.parametrize("dtype", DTYPES)
def test_bgr_equals_luminance(blob_lf, dtype):
    b, g, r = 0.8 * blob_lf, blob_lf, np.clip(1.15 * blob_lf, 0, 1)
    bgr = to_dtype(np.stack([b, g, r], axis=-1), dtype)
    as_float = bgr.astype(np.float64) / (np.iinfo(dtype).max if np.dtype(dtype).kind == "u" else 1)
    grey = (0.114 * as_float[..., 0] + 0.587 * as_float[..., 1] + 0.299 * as_float[..., 2])
    kc, dc = liff.LiFF.create().detectAndCompute(bgr)
    kg, dg = liff.LiFF.create().detectAndCompute(grey.astype(np.float32))
    assert len(kc) == len(kg) > 0
    np.testing.assert_allclose(points(kc), points(kg), atol=1e-3)
    np.testing.assert_allclose(liff.keypoint_slopes(kc), liff.keypoint_slopes(kg), atol=1e-3)
    assert np.abs(dc - dg).max() <= 1


@pytest.mark.parametrize("dtype", DTYPES)
def test_single_channel_axis(blob_lf, dtype):
    lf = to_dtype(blob_lf, dtype)
    assert_same_keypoints(liff.LiFF.create().detect(lf[..., None]), liff.LiFF.create().detect(lf))


@pytest.mark.parametrize(
    "make",
    [
        lambda a: a[:, :, :, ::-1],
        lambda a: a[::-1, ::-1],
        lambda a: np.asfortranarray(a),
        lambda a: np.pad(a, ((0, 0), (0, 0), (0, 0), (0, 5)))[..., :-5],
        lambda a: np.moveaxis(np.ascontiguousarray(np.moveaxis(a, 3, 0)), 0, 3),
    ],
    ids=["flip-u", "flip-views", "fortran", "padded-rows", "strided-last-axis"],
)
@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_non_contiguous_equals_contiguous_copy(blob_lf, make, dtype):
    view = make(to_dtype(blob_lf, dtype))
    assert not view.flags.c_contiguous
    kv, dv = liff.LiFF.create().detectAndCompute(view)
    kc, dc = liff.LiFF.create().detectAndCompute(np.ascontiguousarray(view))
    assert len(kv) > 0
    assert_same_keypoints(kv, kc)
    np.testing.assert_array_equal(dv, dc)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("colour", [False, True])
def test_inputs_are_not_modified(blob_lf, dtype, colour):
    lf = to_dtype(blob_lf, dtype)
    if colour:
        lf = np.ascontiguousarray(np.repeat(lf[..., None], 3, axis=-1))
    before = lf.copy()
    mask = np.ones(lf.shape[2:4], np.uint8)
    mask_before = mask.copy()
    d = liff.LiFF.create()
    kps, _ = d.detectAndCompute(lf, mask)
    d.detect(lf)
    d.compute(lf, kps)
    np.testing.assert_array_equal(lf, before)
    np.testing.assert_array_equal(mask, mask_before)
    assert lf.flags.writeable


def test_read_only_input_accepted(blob_lf):
    assert not blob_lf.flags.writeable  # the fixture is frozen
    assert len(liff.LiFF.create().detect(blob_lf)) > 0


@pytest.mark.parametrize("dtype", [">f4", ">f8", ">u2"])
def test_big_endian_input(blob_lf, dtype):
    # The Python layer converts non-native byte order; the result must equal native.
    # Observed bug: ValueError "light field dtype is float32; expected uint8, uint16,
    # float32 or float64 (native byte order)" even after the conversion.
    native = to_dtype(blob_lf, np.dtype(dtype).newbyteorder("="))
    swapped = native.astype(dtype)
    assert_same_keypoints(liff.LiFF.create().detect(swapped), liff.LiFF.create().detect(native))


def test_nested_lists_and_umat(texture_image):
    d = liff.LiFF.create()
    ref = d.detect(texture_image)
    assert_same_keypoints(d.detect(cv2.UMat(np.ascontiguousarray(texture_image))), ref)
    small = texture_image[:64, :64]
    assert_close_keypoints(d.detect((small / 255.0).tolist()), d.detect(small))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    T=st.integers(1, 4), S=st.integers(1, 4), V=st.integers(1, 40), U=st.integers(1, 40),
    dtype=st.sampled_from(DTYPES), channels=st.sampled_from([0, 1, 2, 3, 4]),
    seed=st.integers(0, 2**16),
)
def test_any_small_light_field_gives_valid_output(T, S, V, U, dtype, channels, seed):
    rng = np.random.default_rng(seed)
    shape = (T, S, V, U) + ((channels,) if channels else ())
    lf = rng.random(shape)
    for t in range(T):  # smooth each view a little so that features exist
        for s in range(S):
            lf[t, s] = cv2.GaussianBlur(lf[t, s], (0, 0), 1.0).reshape(lf[t, s].shape)
    lf = to_dtype(lf, dtype)
    d = liff.LiFF.create()
    kps, desc = d.detectAndCompute(lf)
    assert isinstance(kps, tuple)
    if not kps:
        assert_no_descriptors(desc)
        return
    assert desc.shape == (len(kps), 128) and np.isfinite(desc).all()
    p = points(kps)
    assert np.all(p >= -0.5) and np.all(p[:, 0] <= U - 0.5) and np.all(p[:, 1] <= V - 0.5)
    s = liff.keypoint_slopes(kps)
    # within half a slice spacing of the searched slopes (the automatic range)
    searched = d.getSearchedSlopes()
    half = 1.0 / (max(T, S) - 1) if max(T, S) > 1 else 0.0
    assert np.all((s >= searched[0] - half - 1e-4) & (s <= searched[-1] + half + 1e-4))
