"""Metric relative pose between two light field captures from matched LiFF features.

A calibrated light field gives every feature a 3-D position (:class:`LightFieldCamera`),
so two captures of a scene fix their relative pose *with absolute scale*, which no pair
of 2-D images does. :func:`estimate_relative_pose` matches the features, finds a rigid
motion robustly by RANSAC (hypotheses from 3-D-3-D matches, scored in the observations;
:func:`observation_ransac`), then refines it where the noise lives: in each capture's
observations (x, y, slope).
The 3-D points themselves are poor measurements: depth noise grows as Z^2 / (f b) times
the slope noise, so far points dominate a fit in 3-D (a plain Umeyama fit) and the
inverse of a noisy slope is biased. The refinement is a two-capture bundle adjustment
(Levenberg-Marquardt with the points eliminated by the Schur complement, analytic
Jacobian: :mod:`liff._bundle`) over the pose and each matched
point, parameterised in capture 1 by its pixel and inverse depth (points at or near
infinity stay finite), each residual divided by its feature's noise from a model
fitted to the residuals themselves (:class:`NoiseModel`). Guided matching with the
refined pose then recovers the matches that the ratio test lost. See docs/METRIC.md
for the model, its assumptions and limits.
"""

from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import cv2
import numpy as np

from .._rigid import TransferScorer, robust_rigid_fit, sample_triples
from .._rigid import rigid_fits as _rigid_fits
from ..camera import LightFieldCamera
from ..matching import ratio_matches, size_mask
from .model import (
    CHI2_INLIER,
    MIN_MATCHES,
    SIGMA_FLOOR,
    NoiseModel,
    PoseEstimationError,
    RelativePose,
    back_project,
    check_seed,
    observations,
    translation_length_sigma,
)
from .refine import refine_relative_pose

#: rounds of guided matching and refinement after the first pose
GUIDED_ROUNDS = 2
#: a-priori noise of a feature's position (pixels) and slope (pixels per view step) that
#: scores RANSAC's hypotheses, before the refinement estimates the noise itself
RANSAC_SIGMA = (0.5, 0.05)
#: hypotheses scored per batch, at most in all, and local-optimisation rounds
RANSAC_BATCH = 256
RANSAC_MAX_HYPOTHESES = 4096
RANSAC_LOCAL_ROUNDS = 5
#: best hypotheses that get local optimisation
RANSAC_LOCAL_POOL = 16
#: random re-pairings of the matches whose best inlier count is chance, and the factor by
#: which a pose's inliers must exceed it
RANSAC_CHANCE_TRIALS = 2
RANSAC_CHANCE_FACTOR = 1.5


def _transfer(obs1: np.ndarray, sigma1: np.ndarray, camera1: LightFieldCamera,
              camera2: LightFieldCamera, rotation: np.ndarray, translation: np.ndarray,
              covariance: bool = True):
    """Where capture 2 sees capture 1's features under a pose, and how uncertain that is.

    ``rotation`` (..., 3, 3) and ``translation`` (..., 3) may hold a batch of poses.
    Returns the predicted (x, y, slope) in capture 2, shape (..., n, 3) (NaN for points
    behind it), and the first-order covariance of that prediction from capture 1's
    noise ``sigma1`` (n, 2: position, slope) carried through the pixel and the inverse
    depth w, shape (..., n, 3, 3), or None when ``covariance`` is False. The point is
    (x, y, w) in capture 1; capture 2 sees
    ``p = R d + t w``, d = ((x - cx) / f, (y - cy) / f, 1) (the model of
    :func:`refine_relative_pose`).
    """
    R, t = np.asarray(rotation, np.float64), np.asarray(translation, np.float64)
    f1, f2 = camera1.focal_length, camera2.focal_length
    cx1, cy1 = camera1.principal_point
    cx2, cy2 = camera2.principal_point
    n = len(obs1)
    w = camera1.inverse_depth(obs1[:, 2])
    d = np.column_stack([(obs1[:, 0] - cx1) / f1, (obs1[:, 1] - cy1) / f1, np.ones(n)])
    p = np.einsum("...ij,nj->...ni", R, d) + w[:, None] * t[..., None, :]
    pz = np.where(p[..., 2] > 1e-9, p[..., 2], np.nan)  # in front of capture 2 only
    pred = np.stack([f2 * p[..., 0] / pz + cx2, f2 * p[..., 1] / pz + cy2,
                     camera2.slope_scale * (w / pz - 1 / camera2.focus_distance)], axis=-1)
    if not covariance:
        return pred, None
    # d p / d (x1, y1, w): the same (3, 3) for every feature of a pose.
    dp = np.stack([R[..., :, 0] / f1, R[..., :, 1] / f1, t], axis=-1)[..., None, :, :]
    z2 = pz[..., None] ** 2
    J = np.empty(pred.shape + (3,))
    J[..., 0, :] = f2 * (dp[..., 0, :] * pz[..., None] - p[..., 0:1] * dp[..., 2, :]) / z2
    J[..., 1, :] = f2 * (dp[..., 1, :] * pz[..., None] - p[..., 1:2] * dp[..., 2, :]) / z2
    J[..., 2, :] = -camera2.slope_scale * w[:, None] * dp[..., 2, :] / z2
    J[..., 2, 2] += camera2.slope_scale / pz
    noise1 = np.column_stack([sigma1[:, 0], sigma1[:, 0], sigma1[:, 1] / camera1.slope_scale]) ** 2
    return pred, np.einsum("...nij,nj,...nkj->...nik", J, noise1, J)


#: _transfer_distances: a prediction whose covariance has an entry above this (px^2, or
#: (px/view)^2) is no prediction: its match is not an inlier
MAX_TRANSFER_VARIANCE = 1e12


def _transfer_distances(obs1, obs2, sigma1, sigma2, camera1, camera2, rotation, translation):
    """Squared Mahalanobis distance (3 degrees of freedom) of each match i, capture 2's
    observation against capture 1's prediction under the pose(s): shape (..., n); inf
    where capture 2 sees the point behind it."""
    pred, cov = _transfer(obs1, sigma1, camera1, camera2, rotation, translation)
    cov = cov + (np.column_stack([sigma2[:, 0], sigma2[:, 0], sigma2[:, 1]]) ** 2)[:, :, None] * np.eye(3)
    diff = obs2 - pred
    # A point almost in capture 2's image plane is predicted with a variance that float64
    # cannot invert (1e32 px^2 seen); such a prediction says nothing: no match there.
    valid = np.isfinite(diff).all(axis=-1) & (np.abs(cov) < MAX_TRANSFER_VARIANCE).all(axis=(-2, -1))
    diff = np.where(valid[..., None], diff, 0.0)
    cov = np.where(valid[..., None, None], cov, np.eye(3))
    try:
        solved = np.linalg.solve(cov, diff[..., None])[..., 0]
    except np.linalg.LinAlgError:  # still singular in float64: the pseudo-inverse
        solved = (np.linalg.pinv(cov, hermitian=True) @ diff[..., None])[..., 0]
    distance = np.einsum("...j,...j->...", diff, solved)
    return np.where(valid, distance, np.inf)


def observation_ransac(obs1: np.ndarray, obs2: np.ndarray, camera1: LightFieldCamera,
                       camera2: LightFieldCamera, sigma: Tuple[float, float] = RANSAC_SIGMA,
                       seeds: Sequence[Tuple[np.ndarray, np.ndarray]] = (), seed: int = 0,
                       confidence: float = 0.999, max_hypotheses: int = RANSAC_MAX_HYPOTHESES):
    """Rigid motion from matched observations by MSAC scored where the noise is.

    Hypotheses come from minimal samples of 3 matches (:func:`_rigid_fits` of their
    3-D points) and from ``seeds``; each is scored by the matches' distances between
    capture 2's observations (x, y, slope) and capture 1's features carried over by
    the pose, with capture 1's noise carried through (:func:`_transfer_distances`,
    a-priori noise ``sigma``), each distance capped at the chi-square 99.9% quantile
    (3 degrees of freedom; MSAC). A 3-D threshold cannot do this: a far point's depth
    is Z^2 / (f b) times its slope noise, so a threshold in metres either rejects the
    far half of a scene's right matches or admits gross errors near the camera. The
    best 16 hypotheses are then re-fitted to their inliers (Gauss-Newton on those
    distances, analytic Jacobian) while their scores improve (local optimisation).
    Sampling stops when ``confidence`` that an all-inlier sample was drawn is reached,
    or at ``max_hypotheses``. Sampling, fitting (Kabsch on 3 points) and scoring are
    vectorised over a batch of 256 hypotheses (:mod:`liff._rigid`).

    Parameters
    ----------
    obs1, obs2 : ndarray, shape (N, 3)
        Matched observations (x, y, slope).
    camera1, camera2 : LightFieldCamera
    sigma : (float, float)
        A-priori noise of a feature's position (pixels) and slope (pixels per view step)
        for the scoring (the refinement estimates the actual noise afterwards).
    seeds : sequence of (R, t)
        Further hypotheses to score (e.g. a 3-D RANSAC's).
    seed : int in [0, 2**31)
        Sampling seed (results are repeatable).

    Returns
    -------
    R : ndarray, shape (3, 3)
    t : ndarray, shape (3,)
    inliers : ndarray of bool, shape (N,)

    Raises
    ------
    ValueError
        For a seed outside [0, 2**31).
    PoseEstimationError
        If no hypothesis has at least 3 inliers, or the best has fewer than 1.5 times the
        inliers that the same search, with as many hypotheses, finds on the matches
        re-paired at random (``RANSAC_CHANCE_TRIALS`` re-pairings): when every match is
        wrong, some motion still agrees with a few of them.
    """
    check_seed(seed)
    obs1, obs2 = np.asarray(obs1, np.float64), np.asarray(obs2, np.float64)
    n = len(obs1)
    s = np.broadcast_to(np.asarray(sigma, np.float64), (n, 2))
    X1, X2 = back_project(camera1, obs1), back_project(camera2, obs2)
    usable = np.flatnonzero(np.isfinite(X1).all(axis=1) & np.isfinite(X2).all(axis=1))
    if len(usable) < MIN_MATCHES:
        raise PoseEstimationError(f"{len(usable)} matches with a depth in both captures; expected "
                                  f"at least {MIN_MATCHES}")

    best, drawn = _msac(obs1, obs2, X1, X2, usable, s, camera1, camera2, seeds,
                        np.random.default_rng(seed), confidence, max_hypotheses)
    if best is None or best[2].sum() < MIN_MATCHES:
        raise PoseEstimationError(f"RANSAC found no rigid motion among {n} matches")
    # Significance: the same search on capture 2's features re-paired at random, which
    # share no motion with capture 1's, must find far fewer inliers; else the "best"
    # motion is one that any set of matches this size offers (all matches wrong). It
    # draws as many hypotheses as the search above did (the best of as many tries).
    rng = np.random.default_rng(seed + 1)
    chance = 0
    for _ in range(RANSAC_CHANCE_TRIALS):
        order = rng.permutation(n)
        found, _ = _msac(obs1, obs2[order], X1, X2[order], usable[np.isfinite(X2[order][usable]).all(axis=1)],
                         s, camera1, camera2, (), rng, confidence, max(drawn, RANSAC_BATCH))
        chance = max(chance, 0 if found is None else int(found[2].sum()))
    k = int(best[2].sum())
    if k < RANSAC_CHANCE_FACTOR * chance:
        raise PoseEstimationError(f"{k} of {n} matches agree with the best rigid motion, and {chance} "
                                  f"with one among the same matches re-paired at random; expected at "
                                  f"least {RANSAC_CHANCE_FACTOR}x as many as chance gives (are the "
                                  "captures of the same scene, and is the camera right?)")
    return best


def _msac(obs1, obs2, X1, X2, usable, s, camera1, camera2, seeds, rng, confidence, max_hypotheses):
    """:func:`observation_ransac`'s search: ((R, t, inliers) of the best hypothesis after
    local optimisation, or None; the number of hypotheses drawn). Hypotheses are drawn,
    fitted (:func:`_rigid_fits`) and scored (:class:`liff._rigid.TransferScorer`) a batch
    at a time in array operations."""
    if len(usable) < MIN_MATCHES:
        return None, 0
    scorer = TransferScorer(obs1, obs2, s, s, camera1, camera2, CHI2_INLIER)
    pool_cost, pool_R, pool_t = np.zeros(0), np.zeros((0, 3, 3)), np.zeros((0, 3))
    best_share, drawn, needed = 0.0, 0, max_hypotheses
    candidates = [(np.asarray(R, np.float64)[None], np.asarray(t, np.float64)[None]) for R, t in seeds]
    while candidates or drawn < min(needed, max_hypotheses):
        if candidates:
            R, t = candidates.pop()
        else:
            batch = min(RANSAC_BATCH, max_hypotheses - drawn)
            sample = usable[sample_triples(rng, len(usable), batch)]
            drawn += batch
            R, t = _rigid_fits(X1[sample], X2[sample])
        cost, inliers = scorer.scores(R, t)
        share = float(inliers[:, usable].mean(axis=1).max())
        if share > best_share:  # samples needed for an all-inlier one at this confidence
            best_share = share
            miss = 1.0 - share ** 3
            if miss <= 0:
                needed = 0
            elif miss < 1:
                needed = int(np.ceil(np.log(1 - confidence) / np.log(miss)))
        # Keep the best few for local optimisation.
        pool_cost = np.concatenate([pool_cost, cost])
        pool_R, pool_t = np.concatenate([pool_R, R]), np.concatenate([pool_t, t])
        keep = np.argsort(pool_cost, kind="stable")[:RANSAC_LOCAL_POOL]
        pool_cost, pool_R, pool_t = pool_cost[keep], pool_R[keep], pool_t[keep]
    # Local optimisation of each of the best, all at once: the pose that minimises its
    # inliers' distances, while the score improves (a hypothesis from three noisy 3-D
    # points is only near the pose its sample's matches support).
    R, t = pool_R.copy(), pool_t.copy()
    cost, inliers = scorer.scores(R, t)
    active = np.ones(len(R), bool)
    for _ in range(RANSAC_LOCAL_ROUNDS):
        active &= inliers.sum(axis=1) >= MIN_MATCHES
        if not active.any():
            break
        R2, t2 = scorer.fit(R[active], t[active], inliers[active])
        cost2, inliers2 = scorer.scores(R2, t2)
        better = cost2 < cost[active]
        index = np.flatnonzero(active)[better]
        R[index], t[index] = R2[better], t2[better]
        cost[index], inliers[index] = cost2[better], inliers2[better]
        active[np.flatnonzero(active)[~better]] = False
    if not len(cost):
        return None, drawn
    b = int(np.argmin(cost))
    return (R[b], t[b], inliers[b]), drawn


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
    pred, cov1 = _transfer(obs1, s1, camera1, camera2, pose.rotation, pose.translation)
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


def ransac_pose(points1: np.ndarray, points2: np.ndarray, max_error: float,
                seed: int = 0) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rigid motion ``X2 = R X1 + t`` from 3-D-3-D matches by LO-RANSAC as COLMAP's
    ``estimate_rigid3d_robust`` (:func:`liff._rigid.robust_rigid_fit`, in numpy: no
    pycolmap import); ``max_error`` in metres. Returns (R, t, inlier mask).

    Raises
    ------
    PoseEstimationError
        If RANSAC finds no motion with at least 3 inliers.
    ValueError
        For a seed outside [0, 2**31), or points :func:`robust_rigid_fit` refuses.
    """
    check_seed(seed)
    if len(points1) < MIN_MATCHES:
        raise PoseEstimationError(f"{len(points1)} 3-D matches; expected at least {MIN_MATCHES}")
    R, t, inliers = robust_rigid_fit(points1, points2, max_error, np.random.default_rng(seed))
    if inliers.sum() < MIN_MATCHES:
        raise PoseEstimationError(f"RANSAC found no rigid motion among {len(points1)} 3-D matches")
    return R, t, inliers


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
                                  f"captures (of {len(matches)}); expected at least {MIN_MATCHES}")
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


__all__ = [
    "check_seed",
    "estimate_relative_pose",
    "guided_matches",
    "observation_ransac",
    "observations",
    "ransac_pose",
    "refine_relative_pose",
    "translation_length_sigma",
    "CHI2_INLIER",
    "GUIDED_ROUNDS",
    "MAX_TRANSFER_VARIANCE",
    "MIN_MATCHES",
    "NoiseModel",
    "PoseEstimationError",
    "RANSAC_BATCH",
    "RANSAC_CHANCE_FACTOR",
    "RANSAC_CHANCE_TRIALS",
    "RANSAC_LOCAL_POOL",
    "RANSAC_LOCAL_ROUNDS",
    "RANSAC_MAX_HYPOTHESES",
    "RANSAC_SIGMA",
    "RelativePose",
    "SIGMA_FLOOR",
]
