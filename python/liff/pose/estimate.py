"""The whole estimate: putative matches, RANSAC, refinement, then guided matching with
the refined pose and refinement again (:func:`estimate_relative_pose`,
:func:`guided_matches`).

Part of :mod:`liff.pose` (the overview is there).
"""

from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import cv2
import numpy as np

from ..camera import LightFieldCamera
from ..matching import ratio_matches, size_mask
from .model import (
    CHI2_INLIER,
    MIN_MATCHES,
    NoiseModel,
    PoseEstimationError,
    RelativePose,
    back_project,
    check_seed,
    observations,
)
from .ransac import observation_ransac, ransac_pose, transfer
from .refine import refine_relative_pose

#: rounds of guided matching and refinement after the first pose
GUIDED_ROUNDS = 2


def guided_matches(obs1: np.ndarray, descriptors1: np.ndarray, obs2: np.ndarray,
                   descriptors2: np.ndarray, camera1: LightFieldCamera, camera2: LightFieldCamera,
                   pose: RelativePose, covariates1: Optional[np.ndarray] = None,
                   covariates2: Optional[np.ndarray] = None, ratio: float = 0.8,
                   metric_sizes: Optional[Tuple[np.ndarray, np.ndarray]] = None,
                   max_size_factor: Optional[float] = None) -> List[cv2.DMatch]:
    """Matches consistent with a relative pose: nearest descriptors among the features
    of capture 2 where the pose predicts each feature of capture 1 (guided matching).

    Every feature of capture 1 is moved by the pose to a predicted (x, y, slope) in
    capture 2, with a covariance from both features' noise (``pose.noise``; capture 1's
    slope noise carried through the depth); candidates whose Mahalanobis distance to it
    exceeds the chi-square 99.9% quantile (3 degrees of freedom) are masked out of the
    nearest-neighbour search, Lowe's ratio test is applied among the rest (a lone
    candidate is kept), and a match must also be the feature of capture 2's best gated
    partner (cross check). Geometry, not appearance, then rules out most distractors,
    so matches that the plain ratio test lost come back.

    Parameters
    ----------
    obs1, obs2 : ndarray, shapes (N1, 3) and (N2, 3)
        (x, y, slope) of every feature (:func:`observations`).
    descriptors1, descriptors2 : ndarray, shapes (N1, 128) and (N2, 128)
    camera1, camera2 : LightFieldCamera
    pose : RelativePose
    covariates1, covariates2 : ndarray, shapes (N1, 2) and (N2, 2), optional
        The features' covariates for ``pose.noise`` (default 0).
    ratio : float in (0, 1]
    metric_sizes, max_size_factor : optional
        Scale-sensitive matching as :func:`liff.matching.ratio_matches`.

    Returns
    -------
    list of cv2.DMatch
    """
    n1, n2 = len(obs1), len(obs2)
    if n1 == 0 or n2 == 0:
        return []
    s1 = pose.noise.sigma(np.zeros((n1, 2)) if covariates1 is None else covariates1)
    s2 = pose.noise.sigma(np.zeros((n2, 2)) if covariates2 is None else covariates2)
    pred, cov1 = transfer(obs1, s1, camera1, camera2, pose.rotation, pose.translation)
    noise2 = np.column_stack([s2[:, 0], s2[:, 0], s2[:, 1]]) ** 2  # (n2, 3), diagonal
    # Candidates first by a lower bound of the distance (positions only, the covariance
    # bounded by its largest eigenvalue), then the exact distance of those.
    valid = np.isfinite(pred).all(axis=1)
    largest = np.where(valid, np.linalg.eigvalsh(np.where(valid[:, None, None], cov1, 0)[:, :2, :2])[:, -1], 0)
    p1 = np.where(valid[:, None], pred[:, :2], np.inf)
    dx, dy = obs2[None, :, 0] - p1[:, None, 0], obs2[None, :, 1] - p1[:, None, 1]  # (n1, n2)
    i, j = np.nonzero(dx * dx + dy * dy < CHI2_INLIER * (largest[:, None] + noise2[None, :, 0]))
    diff = obs2[j] - pred[i]
    cov = cov1[i] + noise2[j][:, :, None] * np.eye(3)
    distance = np.einsum("nj,nj->n", diff, np.linalg.solve(cov, diff[:, :, None])[:, :, 0])
    mask = np.zeros((n1, n2), np.uint8)
    mask[i[distance < CHI2_INLIER], j[distance < CHI2_INLIER]] = 1
    if max_size_factor is not None:
        mask &= size_mask(metric_sizes, n1, n2, max_size_factor)
    if not mask.any():
        return []
    a, b = np.asarray(descriptors1, np.float32), np.asarray(descriptors2, np.float32)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    forward = matcher.knnMatch(a, b, k=2, mask=mask)
    backward = {pair[0].queryIdx: pair[0].trainIdx  # best gated partner of each feature 2
                for pair in matcher.knnMatch(b, a, k=1, mask=np.ascontiguousarray(mask.T)) if pair}
    return [pair[0] for pair in forward
            if (len(pair) == 1 or (len(pair) == 2 and pair[0].distance < ratio * pair[1].distance))
            and backward.get(pair[0].trainIdx) == pair[0].queryIdx]


def _focus_hint(camera1: LightFieldCamera, camera2: LightFieldCamera, o1: np.ndarray,
                o2: np.ndarray) -> str:
    """When a camera focused at infinity leaves most matches without a depth: slopes <= 0
    are at or beyond infinity only if the focus distance really is infinite, so say that
    it may be missing ("" otherwise)."""
    at_infinity = [(camera, obs) for camera, obs in ((camera1, o1), (camera2, o2))
                   if np.isinf(camera.focus_distance)]
    if not at_infinity or not len(o1):
        return ""
    beyond = max(int(np.sum(obs[:, 2] <= 0)) for _, obs in at_infinity)
    if 2 * beyond < len(o1):
        return ""
    return (f"; {beyond} of the matches have slopes <= 0, at or beyond infinity for a camera "
            "focused at infinity (focus_distance = inf): if the captures were focused nearer, "
            "as lenslet cameras are, give the focus distance (--focus-distance M with --camera)")


def estimate_relative_pose(keypoints1: Sequence[cv2.KeyPoint], descriptors1: np.ndarray,
                           keypoints2: Sequence[cv2.KeyPoint], descriptors2: np.ndarray,
                           camera1: LightFieldCamera, camera2: Optional[LightFieldCamera] = None,
                           ratio: float = 0.8, max_size_factor: Optional[float] = None,
                           seed: int = 0, return_details: bool = False):
    """Metric relative pose of two light field captures from their LiFF features.

    Parameters
    ----------
    keypoints1, keypoints2 : sequence of cv2.KeyPoint
        LiFF keypoints of each capture (centre-view pixels, slope in ``class_id``).
    descriptors1, descriptors2 : ndarray, shape (N1, 128) and (N2, 128)
    camera1 : LightFieldCamera
    camera2 : LightFieldCamera, optional
        Default: ``camera1`` (the same camera took both).
    ratio : float in (0, 1]
        Lowe's ratio test for the putative matches (:func:`liff.matching.ratio_matches`).
    max_size_factor : float, optional
        Scale-sensitive matching: reject candidates whose metric sizes differ by more
        than this factor (see :func:`liff.matching.ratio_matches`).
    seed : int in [0, 2**31)
        RANSAC's random seed (results are repeatable).
    return_details : bool
        Also return the :class:`RelativePose` (noise model, covariance, points).

    Returns
    -------
    R : ndarray, shape (3, 3)
    t : ndarray, shape (3,)
        Metres, ``X2 = R @ X1 + t``: capture 1's centre-view camera frame (OpenCV: x
        right, y down, z forward) to capture 2's. ``-R.T @ t`` is capture 2's centre
        view in capture 1's frame.
    matches : list of cv2.DMatch
        The inlier matches (queryIdx into capture 1, trainIdx into capture 2).
    details : RelativePose
        Only with ``return_details``.

    Raises
    ------
    ValueError
        For malformed input (keypoint and descriptor counts, descriptor widths,
        non-finite keypoint positions, cameras, the seed, keypoints that carry no slope:
        every ``class_id`` -1, as ``cv2.SIFT``'s).
    PoseEstimationError (a ValueError)
        Fewer than 3 matches with a depth, no RANSAC solution, fewer than 3 inliers after
        refinement, or degenerate geometry (collinear points, all at infinity): never a
        made-up pose.

    Notes
    -----
    1. Putative matches: ratio test (optionally scale-sensitive).
    2. RANSAC (:func:`observation_ransac`): rigid motions of the 3-D points
       (:meth:`LightFieldCamera.points_3d`) of samples of 3 matches, and a 3-D
       LO-RANSAC as COLMAP's (:func:`ransac_pose`) on all of them (threshold 3% of
       their median depth), each scored by how far capture 2's observations (x, y, slope) lie from capture 1's features
       carried over, so that far points, whose depths are poor, still count; the best
       are re-fitted to their inliers. Only to find a starting pose and inliers.
    3. :func:`refine_relative_pose` from the RANSAC inliers: bundle adjustment of the
       pose and points in the observations (x, y, slope) of both captures, with a
       noise model fitted to the residuals and a chi-square inlier test.
    4. Twice: :func:`guided_matches` with that pose (every feature searched where the
       pose puts it, cross-checked), then :func:`refine_relative_pose` on them.
    5. A last check that the inliers are not collinear.

    Model, assumptions and limits: docs/METRIC.md.
    """
    camera2 = camera1 if camera2 is None else camera2
    check_seed(seed)
    for name, camera in (("camera1", camera1), ("camera2", camera2)):
        if not isinstance(camera, LightFieldCamera):
            raise ValueError(f"{name} is a {type(camera).__name__}; expected a liff.LightFieldCamera")
    obs1, obs2 = observations(keypoints1), observations(keypoints2)
    for name, obs, desc in (("1", obs1, descriptors1), ("2", obs2, descriptors2)):
        count = 0 if desc is None else np.shape(desc)[0]
        if count != len(obs):
            raise ValueError(f"capture {name}: {count} descriptors for {len(obs)} keypoints; "
                             "expected one each")
    sizes = None
    if max_size_factor is not None:
        sizes = (camera1.metric_size(keypoints1), camera2.metric_size(keypoints2))
    matches = ratio_matches(descriptors1, descriptors2, ratio, metric_sizes=sizes,
                            max_size_factor=max_size_factor)
    q = np.array([m.queryIdx for m in matches], int)
    tr = np.array([m.trainIdx for m in matches], int)
    o1, o2 = obs1[q].reshape(-1, 3), obs2[tr].reshape(-1, 3)
    X1, X2 = back_project(camera1, o1), back_project(camera2, o2)
    finite = np.isfinite(X1).all(axis=1) & np.isfinite(X2).all(axis=1)
    if finite.sum() < MIN_MATCHES:
        raise PoseEstimationError(f"{int(finite.sum())} putative matches with a depth in both "
                                  f"captures (of {len(matches)}); expected at least {MIN_MATCHES}"
                                  + _focus_hint(camera1, camera2, o1, o2))
    threshold = 0.03 * float(np.median(np.concatenate([X1[finite, 2], X2[finite, 2]])))
    try:  # a 3-D RANSAC as COLMAP's: one more hypothesis for the scoring in observations
        seeds = [ransac_pose(X1[finite], X2[finite], threshold, seed)[:2]]
    except PoseEstimationError:
        seeds = []
    R, t, inliers = observation_ransac(o1, o2, camera1, camera2, seeds=seeds, seed=seed)
    noise = NoiseModel.for_keypoints(list(keypoints1) + list(keypoints2))
    c1, c2 = noise.covariates(keypoints1), noise.covariates(keypoints2)
    pose = refine_relative_pose(o1, o2, camera1, camera2, R, t, inliers, noise, (c1[q], c2[tr]))
    # Guided matching with that pose and a refinement on those matches, twice: the
    # second round's gate comes from the better pose and noise of the first.
    for _ in range(GUIDED_ROUNDS):
        guided = guided_matches(obs1, descriptors1, obs2, descriptors2, camera1, camera2, pose,
                                c1, c2, ratio, sizes, max_size_factor)
        if len(guided) < MIN_MATCHES:
            break
        matches = guided
        q = np.array([m.queryIdx for m in matches], int)
        tr = np.array([m.trainIdx for m in matches], int)
        pose = refine_relative_pose(obs1[q], obs2[tr], camera1, camera2, pose.rotation,
                                    pose.translation, noise=pose.noise, covariates=(c1[q], c2[tr]))
    inlier_points = pose.points[pose.inliers]
    finite_points = inlier_points[np.isfinite(inlier_points).all(axis=1)]
    if len(finite_points) >= 3:
        spread = np.linalg.svd(finite_points - finite_points.mean(axis=0), compute_uv=False)
        if spread[1] <= 1e-6 * spread[0]:
            raise PoseEstimationError("degenerate geometry: the inlier points are collinear")
    inlier_matches = [m for m, ok in zip(matches, pose.inliers) if ok]
    if return_details:
        return pose.rotation, pose.translation, inlier_matches, pose
    return pose.rotation, pose.translation, inlier_matches
