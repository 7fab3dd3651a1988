"""Two-view matching as an ordinary OpenCV script does it: nearest neighbours with
Lowe's ratio test, then a RANSAC homography (or fundamental matrix) for inliers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import cv2
import numpy as np


@dataclass
class MatchResult:
    """``matches`` passed the ratio test (putative); ``inliers`` (bool, one per match)
    agree with ``model`` (3x3, or None when fewer than ``min_matches`` or RANSAC failed)."""

    matches: List[cv2.DMatch]
    inliers: np.ndarray
    model: Optional[np.ndarray]

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


def ratio_matches(descriptors_a: Optional[np.ndarray], descriptors_b: Optional[np.ndarray],
                  ratio: float = 0.75, metric_sizes: Optional[Tuple[np.ndarray, np.ndarray]] = None,
                  max_size_factor: Optional[float] = None) -> List[cv2.DMatch]:
    """Brute-force L2 matches a -> b kept when ``d1 < ratio * d2`` (Lowe's test),
    optionally scale-sensitive.

    Parameters
    ----------
    descriptors_a, descriptors_b : ndarray, shape (Na, 128) and (Nb, 128), float32 or uint8, or None
    ratio : float in (0, 1]
    metric_sizes : (ndarray, ndarray), shapes (Na,) and (Nb,), optional
        Physical size of every feature in metres
        (:meth:`liff.LightFieldCamera.metric_size`); NaN where unknown (a slope at or
        beyond infinity).
    max_size_factor : float > 1, optional
        Scale-sensitive matching (the paper's closing suggestion, Dansereau et al. 2019,
        Sec. 6): with ``metric_sizes``, a pair whose sizes differ by more than this
        factor (``max(sa, sb) / min(sa, sb) > max_size_factor``) is rejected before the
        nearest-neighbour search, so the ratio test compares only candidates of a
        plausible size. Pairs with an unknown size are kept. Needs both arguments.

    Returns
    -------
    list of cv2.DMatch
        queryIdx into a, trainIdx into b.

    Raises
    ------
    ValueError
        For a ratio outside (0, 1], a factor <= 1 or not finite, sizes of the wrong
        length or negative, only one of ``metric_sizes`` and ``max_size_factor``, or
        descriptors that are not 2-D real arrays of the same width with finite values.
    """
    if not 0 < ratio <= 1:
        raise ValueError(f"ratio = {ratio}; expected a value in (0, 1]")
    if max_size_factor is not None and not (np.isfinite(max_size_factor) and max_size_factor > 1):
        raise ValueError(f"max_size_factor = {max_size_factor}; expected a finite factor > 1")
    if (metric_sizes is None) != (max_size_factor is None):
        raise ValueError("scale-sensitive matching needs both metric_sizes and max_size_factor")
    if descriptors_a is None or descriptors_b is None or len(descriptors_a) == 0 or len(descriptors_b) < 2:
        return []
    a, b = _descriptor_matrix(descriptors_a, "a"), _descriptor_matrix(descriptors_b, "b")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"descriptors of widths {a.shape[1]} (a) and {b.shape[1]} (b); expected "
                         "the same width (128 for SIFT and LiFF)")
    mask = None
    if metric_sizes is not None and max_size_factor is not None:  # (both or neither)
        mask = size_mask(metric_sizes, len(a), len(b), max_size_factor)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    knn = matcher.knnMatch(a, b, k=2) if mask is None else matcher.knnMatch(a, b, k=2, mask=mask)
    return [pair[0] for pair in knn if len(pair) == 2 and pair[0].distance < ratio * pair[1].distance]


def _descriptor_matrix(descriptors, name: str) -> np.ndarray:
    """Descriptors as float32 (N, D), checked: 2-D, real, finite."""
    d = np.asarray(descriptors)
    if d.ndim != 2 or not (np.issubdtype(d.dtype, np.integer) or np.issubdtype(d.dtype, np.floating)):
        raise ValueError(f"descriptors_{name} of shape {d.shape} and dtype {d.dtype}; expected a "
                         "2-D (N, D) array of float32 or uint8")
    d = d.astype(np.float32, copy=False)
    if not np.isfinite(d).all():
        raise ValueError(f"descriptors_{name} hold NaN or infinite values; expected finite values")
    return d


def size_mask(metric_sizes, na: int, nb: int, factor: float) -> np.ndarray:
    """uint8 (na, nb): 1 where two features' metric sizes agree within ``factor`` (or
    either is unknown)."""
    try:
        sa, sb = (np.asarray(s, np.float64).reshape(-1) for s in metric_sizes)
    except (TypeError, ValueError):
        raise ValueError("metric_sizes must be two arrays of sizes in metres") from None
    if len(sa) != na or len(sb) != nb:
        raise ValueError(f"metric_sizes have {len(sa)} and {len(sb)} entries for {na} and {nb} "
                         "descriptors; expected one each")
    if (sa[np.isfinite(sa)] <= 0).any() or (sb[np.isfinite(sb)] <= 0).any():
        raise ValueError("metric_sizes hold values <= 0; expected positive sizes (or NaN)")
    with np.errstate(invalid="ignore", divide="ignore"):
        log_ratio = np.abs(np.log(sa)[:, None] - np.log(sb)[None, :])
    return (~(log_ratio > np.log(factor))).astype(np.uint8)  # NaN compares False: kept


def verify(keypoints_a: Sequence[cv2.KeyPoint], keypoints_b: Sequence[cv2.KeyPoint],
           matches: Sequence[cv2.DMatch], model: str = "homography",
           threshold: float = 3.0, min_matches: int = 8) -> MatchResult:
    """RANSAC on the matched positions: ``model`` is "homography" (planar scenes,
    rotations) or "fundamental" (general 3-D scenes); ``threshold`` in pixels."""
    if model not in ("homography", "fundamental"):
        raise ValueError(f"model = {model!r}; expected 'homography' or 'fundamental'")
    matches = list(matches)
    inliers = np.zeros(len(matches), bool)
    if len(matches) < min_matches:
        return MatchResult(matches, inliers, None)
    pa = np.array([keypoints_a[m.queryIdx].pt for m in matches], np.float32)
    pb = np.array([keypoints_b[m.trainIdx].pt for m in matches], np.float32)
    if model == "homography":
        estimate, mask = cv2.findHomography(pa, pb, cv2.RANSAC, threshold)
    else:
        estimate, mask = cv2.findFundamentalMat(pa, pb, cv2.FM_RANSAC, threshold, 0.999)
    if estimate is None or mask is None:
        return MatchResult(matches, inliers, None)
    return MatchResult(matches, mask.ravel().astype(bool), estimate[:3])


def chance_inliers(keypoints_a: Sequence[cv2.KeyPoint], keypoints_b: Sequence[cv2.KeyPoint],
                   matches: Sequence[cv2.DMatch], model: str = "homography",
                   threshold: float = 3.0, trials: int = 5, seed: int = 0) -> int:
    """How many inliers the same RANSAC finds by chance among these matches: the most
    it keeps over ``trials`` random re-pairings of the matched keypoints (each point of
    a with a random matched point of b), which share no geometry.

    An inlier count that is not well above this shows nothing about the two views
    (e.g. 7 homography inliers among 296 putative matches of two unrelated scenes,
    where re-pairings give about as many)."""
    matches = list(matches)
    rng = np.random.default_rng(seed)
    cv2.setRNGSeed(seed)  # RANSAC's sampling: the same answer every time
    most = 0
    for _ in range(trials):
        shuffled = rng.permutation([m.trainIdx for m in matches])
        pairs = [cv2.DMatch(m.queryIdx, int(j), 0.0) for m, j in zip(matches, shuffled)]
        most = max(most, verify(keypoints_a, keypoints_b, pairs, model, threshold).inlier_count)
    return most


def draw_inliers(image_a: np.ndarray, keypoints_a, image_b: np.ndarray, keypoints_b,
                 result: MatchResult) -> np.ndarray:
    """Side-by-side picture of the inlier matches (cv2.drawMatches)."""
    inlier_matches = [m for m, ok in zip(result.matches, result.inliers) if ok]
    return cv2.drawMatches(image_a, list(keypoints_a), image_b, list(keypoints_b), inlier_matches,
                           None, matchColor=(0, 255, 0), singlePointColor=(160, 160, 160),
                           flags=cv2.DrawMatchesFlags_DEFAULT)
