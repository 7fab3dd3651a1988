"""An alpha channel (C = 2 grey + alpha, C = 4 BGRA) is a per-sample validity weight:
the focal stack is sum(a L) / sum(a), so samples with a = 0 cannot create features."""

from __future__ import annotations

import numpy as np
import pytest

import lfhelpers


def with_alpha(lf: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """(T, S, V, U) grey + (T, S, V, U) alpha -> (T, S, V, U, 2)."""
    return np.stack([lf, alpha.astype(lf.dtype)], axis=-1)


def test_opaque_alpha_changes_nothing(detector, blob_lf):
    kps, desc = detector.detectAndCompute(blob_lf, None)
    for dtype, one in [(np.float32, 1.0), (np.uint8, 255)]:
        lf = np.round(blob_lf * 255).astype(np.uint8) if dtype == np.uint8 else blob_lf
        grey_kps, grey_desc = detector.detectAndCompute(lf, None)
        kps_a, desc_a = detector.detectAndCompute(with_alpha(lf, np.full(lf.shape, one)), None)
        lfhelpers.assert_same_keypoints(grey_kps, kps_a)
        np.testing.assert_array_equal(grey_desc, desc_a)
    # BGRA with opaque alpha equals BGR.
    bgr = np.repeat(blob_lf[..., None], 3, axis=-1)
    bgra = np.concatenate([bgr, np.ones(blob_lf.shape + (1,), np.float32)], axis=-1)
    lfhelpers.assert_same_keypoints(detector.detect(bgr), detector.detect(bgra))
    assert len(kps) > 0 and desc.shape == (len(kps), 128)


def test_uniform_alpha_is_a_no_op(detector, blob_lf):
    """A constant weight cancels in sum(a L) / sum(a) (0.5 is exact in binary)."""
    kps = detector.detect(blob_lf)
    half = detector.detect(with_alpha(blob_lf, np.full(blob_lf.shape, 0.5)))
    lfhelpers.assert_close_keypoints(kps, half, atol=1e-4)


def test_zero_weight_samples_are_ignored(detector, blob_scene):
    """Bright squares pasted at the same pixels of the outer ring of views (as dead or
    vignetted samples would be) create spurious features, unless their alpha is 0;
    with alpha 0 the features are those of the clean light field."""
    blobs, clean = blob_scene
    corrupt = np.array(clean, copy=True)
    alpha = np.ones(clean.shape, np.float32)
    T, S = clean.shape[:2]
    ring = [(t, s) for t in range(T) for s in range(S) if t in (0, T - 1) or s in (0, S - 1)]
    for y, x in [(20, 30), (60, 70), (40, 10)]:
        for t, s in ring:
            corrupt[t, s, y:y + 8, x:x + 8] = 1.0
            alpha[t, s, y:y + 8, x:x + 8] = 0.0
    clean_kps = detector.detect(clean)
    corrupt_kps = detector.detect(corrupt)
    weighted_kps = detector.detect(with_alpha(corrupt, alpha))
    clean_pts = lfhelpers.points(clean_kps)

    def spurious(kps):
        """Distinct positions (orientations of one point count once) far from clean ones."""
        pts = np.unique(np.round(lfhelpers.points(kps), 2), axis=0)
        return int(np.sum(lfhelpers.nearest_distances(pts, clean_pts) > 1.5))

    assert spurious(corrupt_kps) >= 3, "the pasted squares should create features without alpha"
    # Excluding samples changes which views a slice averages near the squares' edges,
    # which can shift a feature there: one such point is tolerated.
    assert spurious(weighted_kps) <= 1
    found_clean = lfhelpers.match_blobs(clean_kps, blobs)[0]
    found_weighted = lfhelpers.match_blobs(weighted_kps, blobs)[0]
    assert found_weighted.sum() >= found_clean.sum() - 1


def test_bgra_uint16_weights_scale_like_values(detector, blob_lf):
    """uint16 alpha is divided by 65535: full alpha is 'opaque' exactly."""
    lf16 = np.round(blob_lf * 65535).astype(np.uint16)
    bgr = np.repeat(lf16[..., None], 3, axis=-1)
    bgra = np.concatenate([bgr, np.full(lf16.shape + (1,), 65535, np.uint16)], axis=-1)
    lfhelpers.assert_same_keypoints(detector.detect(bgr), detector.detect(bgra))


def test_all_zero_alpha_finds_nothing(detector, blob_lf):
    kps, desc = detector.detectAndCompute(with_alpha(blob_lf, np.zeros(blob_lf.shape)), None)
    assert len(kps) == 0
    lfhelpers.assert_no_descriptors(desc)


@pytest.mark.parametrize("bad, word", [(-0.5, "negative"), (np.nan, "alpha"), (np.inf, "alpha")])
def test_bad_alpha_is_refused(detector, blob_lf, bad, word):
    alpha = np.ones(blob_lf.shape, np.float32)
    alpha[1, 2, 3, 4] = bad
    lf = with_alpha(blob_lf, alpha)
    before = lf.copy()
    with pytest.raises(ValueError, match=word):
        detector.detect(lf)
    np.testing.assert_array_equal(lf, before)


@pytest.mark.parametrize("scale", [1e-3, 1e-9, 1e-20])
def test_weights_are_relative(detector, blob_lf, scale):
    """Only ratios of weights matter (sum(a L) / sum(a)): alpha scaled by any positive
    constant, however small, finds the same features, with zero-weight samples still
    ignored (a third of the views' columns below)."""
    alpha = np.ones(blob_lf.shape, np.float32)
    alpha[:, :, :, ::3] = 0.0
    reference = detector.detect(with_alpha(blob_lf.astype(np.float32), alpha))
    assert len(reference) > 10
    scaled = detector.detect(with_alpha(blob_lf.astype(np.float32), alpha * np.float32(scale)))
    lfhelpers.assert_close_keypoints(reference, scaled, atol=1e-3)
