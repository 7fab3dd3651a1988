"""A first pose and its inliers: RANSAC (MSAC) over rigid motions of matched features'
3-D points, scored by where capture 1's features land in capture 2's observations
(:func:`observation_ransac`, :func:`transfer`), and a 3-D LO-RANSAC as COLMAP's
(:func:`ransac_pose`).

Part of :mod:`liff.pose` (the overview is there).
"""

from __future__ import annotations

from typing import Sequence, Tuple

import numpy as np

from .._rigid import TransferScorer, robust_rigid_fit, sample_triples
from .._rigid import rigid_fits as _rigid_fits
from ..camera import LightFieldCamera
from .model import CHI2_INLIER, MIN_MATCHES, PoseEstimationError, back_project, check_seed

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


def transfer(obs1: np.ndarray, sigma1: np.ndarray, camera1: LightFieldCamera,
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
    pred, cov = transfer(obs1, sigma1, camera1, camera2, rotation, translation)
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
