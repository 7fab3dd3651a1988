"""Closed-form pieces of :func:`liff.pose.observation_ransac`, vectorised over hypotheses.

* :func:`rigid_fits`: the minimal solver, a least-squares rigid motion of point sets (the
  3-D points that the slopes give; Kabsch's SVD method), for many samples at once.
* :func:`sample_triples`: minimal samples of 3 distinct matches, drawn in one call.
* :class:`TransferScorer`: MSAC scores of many poses against all matches in array
  operations: capture 1's features carried to capture 2 by each pose, their distance to
  capture 2's observations (x, y, slope) under the carried-over noise, and a Gauss-Newton
  fit of a pose to its inliers with an analytic Jacobian (local optimisation).

* :func:`robust_rigid_fit`: a 3-D LO-RANSAC as COLMAP's ``estimate_rigid3d_robust``,
  whose hypothesis :func:`liff.pose.estimate_relative_pose` scores as one more.

Why not a library's robust estimator alone: OpenCV's ``estimateAffine3D`` and COLMAP's
``estimate_rigid3d_robust`` (or :func:`robust_rigid_fit`) threshold residuals in metres,
and a light field's depth noise grows as Z^2 / (f b) times its slope noise, so a 3-D
threshold drops the right far matches or admits wrong near ones; these scores are in each
capture's observations instead.

The model is :func:`liff.pose.refine_relative_pose`'s: a feature of capture 1 at pixel
(x, y) with inverse depth w (from its slope) is the point whose direction is
``d = ((x - cx) / f, (y - cy) / f, 1)``; capture 2 sees ``p = R d + w t`` (w times the
point in capture 2's frame, finite at infinity) at ``(f p_x / p_z + cx, f p_y / p_z + cy)``
with slope ``f b (w / p_z - 1 / focus_distance)`` (docs/METRIC.md).
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

#: a point with p_z at or below this (capture 2's image plane or behind it) is not seen
MIN_DEPTH = 1e-9
#: a prediction whose covariance has an entry above this (px^2, or (px/view)^2) is no
#: prediction: its match is not an inlier (as :func:`liff.pose.ransac._transfer_distances`)
MAX_VARIANCE = 1e12
#: the residual of a match whose point a pose puts behind capture 2, in the local fit
#: (as SciPy's least_squares saw it before: far off, no gradient)
_BEHIND = 1e6


def rigid_fits(X1: np.ndarray, X2: np.ndarray, weights: Optional[np.ndarray] = None
               ) -> Tuple[np.ndarray, np.ndarray]:
    """Least-squares rigid motions ``X2 = R X1 + t`` of point sets, all at once.

    Kabsch's method (W. Kabsch, Acta Cryst. A32, 1976; the SVD form of S. Umeyama, IEEE
    PAMI 13(4), 1991, without scale): with centroids c1, c2 and the cross-covariance
    ``H = sum_k w_k (X1_k - c1)(X2_k - c2)^T = U S V^T``, ``R = V diag(1, 1, det(V U^T)) U^T``
    and ``t = c2 - R c1``. Exact for noise-free points that are not collinear; 3 points
    are the minimal sample.

    Parameters
    ----------
    X1, X2 : ndarray, shape (..., k, 3)
        Matched points, metres; k >= 3.
    weights : ndarray, shape (..., k), optional
        Non-negative weights (default equal).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
    t : ndarray, shape (..., 3)
        Metres.
    """
    if weights is None:
        weights = np.ones(X1.shape[:-1])
    weights = weights / weights.sum(axis=-1, keepdims=True)
    c1 = np.einsum("...k,...ki->...i", weights, X1)
    c2 = np.einsum("...k,...ki->...i", weights, X2)
    cross = np.einsum("...k,...ki,...kj->...ij", weights, X1 - c1[..., None, :], X2 - c2[..., None, :])
    U, _, Vt = np.linalg.svd(cross)
    sign = np.sign(np.linalg.det(np.swapaxes(Vt, -1, -2) @ np.swapaxes(U, -1, -2)))
    fix = np.ones(U.shape[:-2] + (3,))
    fix[..., 2] = np.where(sign == 0, 1.0, sign)
    R = np.swapaxes(Vt, -1, -2) @ (fix[..., :, None] * np.swapaxes(U, -1, -2))
    return R, c2 - np.einsum("...ij,...j->...i", R, c1)


def sample_triples(rng: np.random.Generator, m: int, count: int) -> np.ndarray:
    """``count`` samples of 3 distinct indices in [0, m), each uniform over the ordered
    triples, as an (count, 3) int array: the second drawn from m - 1 values and shifted
    past the first, the third from m - 2 and shifted past both."""
    if m < 3:
        raise ValueError(f"m = {m}; expected at least 3 to draw 3 distinct indices")
    i = rng.integers(0, m, count)
    j = rng.integers(0, m - 1, count)
    j += j >= i
    k = rng.integers(0, m - 2, count)
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    k += k >= lo
    k += k >= hi
    return np.column_stack([i, j, k])


def robust_rigid_fit(X1: np.ndarray, X2: np.ndarray, max_error: float, rng: np.random.Generator,
                     confidence: float = 0.99, max_trials: int = 4096, batch: int = 256,
                     local_rounds: int = 10) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """LO-RANSAC of a rigid motion ``X2 = R X1 + t`` between 3-D points, as COLMAP's
    ``estimate_rigid3d_robust`` does it (an inlier's distance ``|R X1 + t - X2|`` at most
    ``max_error``; support = inlier count, ties to the smaller sum of squared inlier
    distances; the best model so far re-fitted to its inliers while its support grows;
    trials until an all-inlier sample of 3 is drawn with ``confidence``, times 3 as
    COLMAP's ``dyn_num_trials_multiplier``), with :func:`rigid_fits` over ``batch``
    samples at once. Here so that the pose need not import pycolmap (0.06 s) for one
    starting hypothesis.

    Parameters
    ----------
    X1, X2 : ndarray, shape (N, 3)
        Matched points, metres; N >= 3.
    max_error : float
        Inlier distance, metres (> 0).
    rng : numpy.random.Generator
    confidence : float in (0, 1)
    max_trials : int
        Most samples drawn (rounded up to whole batches).

    Returns
    -------
    R : ndarray, shape (3, 3)
    t : ndarray, shape (3,)
        Metres.
    inliers : ndarray of bool, shape (N,)

    Raises
    ------
    ValueError
        For fewer than 3 matches, shapes that differ, non-finite points or a
        ``max_error`` that is not positive.
    """
    X1, X2 = np.asarray(X1, np.float64), np.asarray(X2, np.float64)
    if X1.ndim != 2 or X1.shape[1] != 3 or X1.shape != X2.shape:
        raise ValueError(f"points of shapes {X1.shape} and {X2.shape}; expected two (N, 3) arrays")
    if not (np.isfinite(X1).all() and np.isfinite(X2).all()):
        raise ValueError("non-finite 3-D points; expected finite coordinates")
    if not max_error > 0:
        raise ValueError(f"max_error = {max_error}; expected > 0 (metres)")
    n = len(X1)
    if n < 3:
        raise ValueError(f"{n} matches; expected at least 3")
    limit = float(max_error) ** 2

    def support(R, t):  # (inlier masks (H, N), counts (H,), sums of squared inlier distances (H,))
        d2 = np.sum((X1 @ np.swapaxes(R, -1, -2) + t[:, None, :] - X2) ** 2, axis=-1)
        inside = d2 <= limit
        return inside, inside.sum(axis=1), np.where(inside, d2, 0.0).sum(axis=1)

    best: Optional[tuple] = None  # (count, sum, R, t, inliers)
    drawn, needed = 0, max_trials
    while drawn < min(needed, max_trials):
        sample = sample_triples(rng, n, batch)
        R, t = rigid_fits(X1[sample], X2[sample])
        drawn += batch
        inside, count, total = support(R, t)
        h = int(np.lexsort((total, -count))[0])
        if best is not None and (count[h], -total[h]) <= (best[0], -best[1]):
            continue
        best = (count[h], total[h], R[h], t[h], inside[h])
        for _ in range(local_rounds):  # local optimisation: re-fit to the inliers
            if best[0] < 3:
                break
            R2, t2 = rigid_fits(X1[best[4]], X2[best[4]])
            inside2, count2, total2 = support(R2[None], t2[None])
            if (count2[0], -total2[0]) <= (best[0], -best[1]):
                break
            best = (count2[0], total2[0], R2, t2, inside2[0])
        miss = 1.0 - (best[0] / n) ** 3  # chance that a sample holds an outlier
        if miss <= 0:
            needed = 0
        elif miss < 1:
            needed = int(np.ceil(3 * np.log(1 - confidence) / np.log(miss)))
    if best is None:  # (max_trials < 1: no sample drawn)
        raise ValueError(f"max_trials = {max_trials}; expected at least 1")
    return best[2], best[3], best[4]


def rotations(rvecs: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3), radians (Rodrigues'
    formula, with its series near 0)."""
    rvecs = np.asarray(rvecs, np.float64)
    theta2 = np.einsum("...i,...i->...", rvecs, rvecs)
    theta = np.sqrt(theta2)
    small = theta2 < 1e-12
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - theta2 / 6, np.sin(safe) / safe)
    b = np.where(small, 0.5 - theta2 / 24, (1.0 - np.cos(safe)) / np.where(small, 1.0, theta2))
    K = np.zeros(rvecs.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -rvecs[..., 2], rvecs[..., 1], -rvecs[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = rvecs[..., 2], -rvecs[..., 1], rvecs[..., 0]
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def _mahalanobis(entries, u: np.ndarray) -> np.ndarray:
    """u^T C^-1 u for symmetric positive definite C given by its entries (c00, c01, c02,
    c11, c12, c22), each (m,), and u (m, 3), from the adjugate (C is whitened to I + J J^T
    by the callers: well conditioned from below)."""
    a, b, c, d, e, f = entries
    A11, A12, A13 = d * f - e * e, c * e - b * f, b * e - c * d
    A22, A23, A33 = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * A11 + b * A12 + c * A13
    x, y, z = u[:, 0], u[:, 1], u[:, 2]
    q = (A11 * x * x + A22 * y * y + A33 * z * z
         + 2.0 * (A12 * x * y + A13 * x * z + A23 * y * z))
    return q / det


def inverse_spd3(C: np.ndarray) -> np.ndarray:
    """Inverses of (m, 3, 3) symmetric positive definite matrices, from the adjugate over
    the determinant (vectorised; no check of definiteness): a covariance's information
    here, and the bundle adjustment's point blocks (:mod:`liff._bundle`)."""
    a, b, c = C[:, 0, 0], C[:, 0, 1], C[:, 0, 2]
    d, e, f = C[:, 1, 1], C[:, 1, 2], C[:, 2, 2]
    A = np.empty_like(C)
    A[:, 0, 0], A[:, 0, 1], A[:, 0, 2] = d * f - e * e, c * e - b * f, b * e - c * d
    A[:, 1, 1], A[:, 1, 2], A[:, 2, 2] = a * f - c * c, b * c - a * e, a * d - b * b
    A[:, 1, 0], A[:, 2, 0], A[:, 2, 1] = A[:, 0, 1], A[:, 0, 2], A[:, 1, 2]
    det = a * A[:, 0, 0] + b * A[:, 0, 1] + c * A[:, 0, 2]
    return A / det[:, None, None]


class TransferScorer:
    """MSAC scoring and local fitting of poses against fixed matches (see the module).

    Parameters
    ----------
    obs1, obs2 : ndarray, shape (n, 3)
        Matched observations (x, y, slope): pixels, pixels per view step.
    sigma1, sigma2 : ndarray, shape (n, 2)
        Each feature's position (pixels) and slope (pixels per view step) noise.
    camera1, camera2 : liff.LightFieldCamera
    threshold : float
        Squared Mahalanobis distance (3 degrees of freedom) below which a match is an
        inlier and at which its MSAC cost is capped.
    """

    def __init__(self, obs1, obs2, sigma1, sigma2, camera1, camera2, threshold: float):
        obs1, obs2 = np.asarray(obs1, np.float64), np.asarray(obs2, np.float64)
        sigma1 = np.broadcast_to(np.asarray(sigma1, np.float64), (len(obs1), 2))
        sigma2 = np.broadcast_to(np.asarray(sigma2, np.float64), (len(obs1), 2))
        self.n, self.threshold = len(obs1), float(threshold)
        self.camera1, self.camera2 = camera1, camera2
        self.f1, self.f2 = camera1.focal_length, camera2.focal_length
        cx1, cy1 = camera1.principal_point
        cx2, cy2 = camera2.principal_point
        self.w = camera1.inverse_depth(obs1[:, 2])
        self.D = np.column_stack([(obs1[:, 0] - cx1) / self.f1, (obs1[:, 1] - cy1) / self.f1,
                                  np.ones(self.n)])  # (n, 3): the directions d
        self.uv2 = np.column_stack([(obs2[:, 0] - cx2) / self.f2, (obs2[:, 1] - cy2) / self.f2])
        self.obs2 = obs2
        self.D32, self.w32, self.uv2_32 = (v.astype(np.float32) for v in (self.D, self.w, self.uv2))
        # capture 1's noise on (x, y, w) and capture 2's on (x, y, slope), as standard deviations
        self.sd1 = np.column_stack([sigma1[:, 0], sigma1[:, 0], sigma1[:, 1] / camera1.slope_scale])
        self.sd2 = np.column_stack([sigma2[:, 0], sigma2[:, 0], sigma2[:, 1]])

    # --- predictions ------------------------------------------------------------------
    def _p(self, R, t, h=None, i=None):
        """p = R d + w t: (H, 3, n) for all, or (m, 3) for the pairs (h, i)."""
        if h is None:
            return R @ self.D.T + t[:, :, None] * self.w
        return np.einsum("mij,mj->mi", R[h], self.D[i]) + t[h] * self.w[i, None]

    def _jacobian_and_error(self, R, t, h, i, p, projection: bool = False):
        """For the pairs (h, i): the prediction's Jacobian on capture 1's (x, y, w), whitened
        (columns times capture 1's noise, rows divided by capture 2's), as three (m, 3)
        rows; the whitened error of capture 2's observation (m, 3); None; and the error
        (m, 3). With ``projection``: None, None, the projection's Jacobian d prediction /
        d p (m, 3, 3) and the error."""
        f2, ss2 = self.f2, self.camera2.slope_scale
        w = self.w[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            iz = 1.0 / p[:, 2]
        a, b = p[:, 0] * iz, p[:, 1] * iz
        error = np.column_stack([f2 * (self.uv2[i, 0] - a), f2 * (self.uv2[i, 1] - b),
                                 self.obs2[i, 2] - ss2 * (w * iz - 1.0 / self.camera2.focus_distance)])
        if projection:  # the local fit needs only these
            G = np.zeros((len(h), 3, 3))
            G[:, 0, 0] = G[:, 1, 1] = f2 * iz
            G[:, 0, 2] = -f2 * a * iz
            G[:, 1, 2] = -f2 * b * iz
            G[:, 2, 2] = -ss2 * w * iz * iz
            return None, None, G, error
        # dp/d(x, y, w) of each pose, rows p_x, p_y, p_z, gathered per pair
        Dp = np.concatenate([R[:, :, :2] / self.f1, t[:, :, None]], axis=2).transpose(1, 0, 2)[:, h]
        sd1, sd2 = self.sd1[i], self.sd2[i]
        J0 = ((f2 * iz / sd2[:, 0])[:, None] * (Dp[0] - a[:, None] * Dp[2])) * sd1
        J1 = ((f2 * iz / sd2[:, 1])[:, None] * (Dp[1] - b[:, None] * Dp[2])) * sd1
        J2 = (-ss2 * w * iz * iz / sd2[:, 2])[:, None] * Dp[2]
        J2[:, 2] += ss2 * iz / sd2[:, 2]  # slope2 = f b (w / p_z - 1/F): direct term in w
        J2 *= sd1
        return (J0, J1, J2), error / sd2, None, error

    @staticmethod
    def _whitened_covariance(J) -> np.ndarray:
        """I + J J^T (m, 3, 3) from the rows J = (J0, J1, J2)."""
        J0, J1, J2 = J
        C = np.empty((len(J0), 3, 3))
        C[:, 0, 0] = 1.0 + np.einsum("mi,mi->m", J0, J0)
        C[:, 1, 1] = 1.0 + np.einsum("mi,mi->m", J1, J1)
        C[:, 2, 2] = 1.0 + np.einsum("mi,mi->m", J2, J2)
        C[:, 0, 1] = C[:, 1, 0] = np.einsum("mi,mi->m", J0, J1)
        C[:, 0, 2] = C[:, 2, 0] = np.einsum("mi,mi->m", J0, J2)
        C[:, 1, 2] = C[:, 2, 1] = np.einsum("mi,mi->m", J1, J2)
        return C

    def distances(self, R, t, h, i, p=None) -> np.ndarray:
        """Squared Mahalanobis distances (m,) of the pairs (hypothesis h, match i): capture
        2's observation against capture 1's feature carried over, covariance ``J N1 J^T +
        N2`` (first order); inf where the point is not in front of capture 2 or its
        prediction's variance exceeds ``MAX_VARIANCE``."""
        p = self._p(R, t, h, i) if p is None else p
        front = p[:, 2] > MIN_DEPTH
        (J0, J1, J2), u, _, _ = self._jacobian_and_error(R, t, h, i, np.where(front[:, None], p, 1.0))
        dot = lambda x, y: np.einsum("mi,mi->m", x, y)  # noqa: E731
        entries = (1.0 + dot(J0, J0), dot(J0, J1), dot(J0, J2), 1.0 + dot(J1, J1), dot(J1, J2),
                   1.0 + dot(J2, J2))
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            d = _mahalanobis(entries, u)
            variance = self.sd2[i] ** 2  # each diagonal entry back in capture 2's units
            valid = (front & np.isfinite(d) & (entries[0] * variance[:, 0] < MAX_VARIANCE)
                     & (entries[3] * variance[:, 1] < MAX_VARIANCE) & (entries[5] * variance[:, 2] < MAX_VARIANCE))
        return np.where(valid, d, np.inf)

    def scores(self, R: np.ndarray, t: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """MSAC costs and inliers of poses.

        Parameters
        ----------
        R : ndarray, shape (H, 3, 3)
        t : ndarray, shape (H, 3)

        Returns
        -------
        cost : ndarray, shape (H,)
            ``sum_i min(d_i, threshold)`` over all n matches.
        inliers : ndarray of bool, shape (H, n)
            ``d_i < threshold``.

        Notes
        -----
        Exact, and cheap for the many far-off matches: d is at least the distance of the
        position alone under its marginal (2 x 2) covariance, and that covariance is at most
        ``G P G^T + s2^2 I`` with G the projection's Jacobian on p (rows ``f2 / p_z (1, 0,
        -a)`` and ``f2 / p_z (0, 1, -b)``, a, b = p_x / p_z, p_y / p_z), P the covariance of
        p, ``(s1 / f1)^2 (r1 r1^T + r2 r2^T) + sw^2 t t^T`` (r_k R's columns; sw capture 1's
        inverse-depth noise), and s1, sw, s2 the largest noise among the matches (the
        distance can only shrink as the covariance grows). Matches whose bound is at
        least ``threshold`` cost exactly ``threshold``; the others get their exact distance
        (:meth:`distances`). With RANSAC's constant noise the bound is the position's own
        distance.
        """
        R, t = np.asarray(R, np.float64), np.asarray(t, np.float64)
        H, n, k = len(R), self.n, self.threshold
        # The bound in float32 (half the memory traffic), with a 1% margin for its rounding
        # (relative errors ~1e-4 where a match is near the threshold); NaN: exact test.
        f4 = np.float32
        P = R.astype(f4) @ self.D32.T + t.astype(f4)[:, :, None] * self.w32
        pz = P[:, 2]
        front = pz > MIN_DEPTH
        s1, sw, s2 = self.sd1[:, 0].max() / self.f1, self.sd1[:, 2].max(), self.sd2[:, 0].max() / self.f2
        cov = ((s1 * s1) * (R[:, :, :2] @ np.swapaxes(R[:, :, :2], 1, 2))
               + (sw * sw) * (t[:, :, None] * t[:, None, :]))
        p00, p01, p02, p11, p12, p22 = (cov[:, r, c, None].astype(f4)
                                        for r, c in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)))
        s22 = f4(s2 * s2)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            iz = f4(1.0) / np.where(front, pz, f4(1.0))
            a, b = P[:, 0] * iz, P[:, 1] * iz
            ea, eb = self.uv2_32[:, 0] - a, self.uv2_32[:, 1] - b
            iz2 = iz * iz
            c00 = iz2 * (p00 - a * (f4(2.0) * p02 - a * p22)) + s22
            c11 = iz2 * (p11 - b * (f4(2.0) * p12 - b * p22)) + s22
            c01 = iz2 * (p01 - a * p12 - b * (p02 - a * p22))
            position = ea * ea * c11 - f4(2.0) * ea * eb * c01 + eb * eb * c00
            near = front & ~(position >= f4(k * 1.01) * (c00 * c11 - c01 * c01))
        h, i = np.nonzero(near)
        d = self.distances(R, t, h, i)
        close = d < k
        inliers = np.zeros((H, n), bool)
        inliers[h[close], i[close]] = True
        cost = k * n - np.bincount(h, weights=k - np.minimum(d, k), minlength=H)
        return cost, inliers

    # --- local optimisation ---------------------------------------------------------------
    def error_and_pose_jacobian(self, R, t, h, i) -> Tuple[np.ndarray, np.ndarray]:
        """For the pairs (hypothesis h, match i): capture 2's observation less the
        prediction, e (m, 3: pixels, pixels, pixels per view step), and its Jacobian on a
        pose update (m, 3, 6), columns (dtheta, dt) with ``R <- exp([dtheta]_x) R`` and
        ``t <- t + dt``: ``dp / d dtheta = -[R d]_x``, ``dp / dt = w I``, ``de / dp = -G``
        with G the projection's Jacobian. Where the point is not in front of capture 2:
        e = 1e6 and no gradient (far off, as SciPy's least_squares saw it before)."""
        p = self._p(R, t, h, i)
        front = p[:, 2] > MIN_DEPTH
        _, _, G, e = self._jacobian_and_error(R, t, h, i, np.where(front[:, None], p, 1.0), True)
        w = self.w[i]
        rd = p - t[h] * w[:, None]  # R d
        dp = np.zeros((len(h), 3, 6))
        dp[:, 0, 1], dp[:, 0, 2] = rd[:, 2], -rd[:, 1]  # -[R d]_x
        dp[:, 1, 0], dp[:, 1, 2] = -rd[:, 2], rd[:, 0]
        dp[:, 2, 0], dp[:, 2, 1] = rd[:, 1], -rd[:, 0]
        dp[:, 0, 3] = dp[:, 1, 4] = dp[:, 2, 5] = w
        Jm = -(G @ dp)
        return (np.where(front[:, None], e, _BEHIND), np.where(front[:, None, None], Jm, 0.0))

    def fit(self, R: np.ndarray, t: np.ndarray, chosen: np.ndarray, iterations: int = 4
            ) -> Tuple[np.ndarray, np.ndarray]:
        """Poses minimising the chosen matches' squared transfer distances, covariances held
        at the start poses (each pose's own), by Gauss-Newton with Levenberg damping.

        Parameters
        ----------
        R : ndarray, shape (H, 3, 3)
        t : ndarray, shape (H, 3)
            Start poses.
        chosen : ndarray of bool, shape (H, n)
            The matches each pose is fitted to (its inliers: finite distances).
        iterations : int

        Returns
        -------
        R, t : the fitted poses, shapes (H, 3, 3) and (H, 3); a pose whose chosen matches
        have no finite covariance is returned as it came.

        Notes
        -----
        Cost ``sum_i e_i^T C_i^-1 e_i``, e_i capture 2's observation less the prediction,
        C_i its covariance at the start pose; the analytic Jacobian of
        :meth:`error_and_pose_jacobian`.
        """
        R, t = np.array(R, np.float64), np.array(t, np.float64)
        h, i = np.nonzero(chosen)
        H = len(R)
        if not len(h):
            return R, t
        p = self._p(R, t, h, i)
        J, _, _, _ = self._jacobian_and_error(R, t, h, i, p)
        C = self._whitened_covariance(J)
        scale = 1.0 / self.sd2[i]
        info = inverse_spd3(C) * scale[:, :, None] * scale[:, None, :]  # C^-1 in capture 2's units
        bad = np.bincount(h, weights=~np.isfinite(info).all(axis=(1, 2)), minlength=H) > 0
        keep = ~bad[h]
        h, i, info = h[keep], i[keep], info[keep]
        starts = np.flatnonzero(np.r_[True, h[1:] != h[:-1]]) if len(h) else np.zeros(0, int)
        groups = h[starts]

        def residual(R, t):
            e, Jm = self.error_and_pose_jacobian(R, t, h, i)
            return e, Jm, np.bincount(h, weights=np.einsum("mi,mij,mj->m", e, info, e), minlength=H)

        e, Jm, cost = residual(R, t)
        damping = np.full(H, 1e-6)
        active = ~bad & (np.bincount(h, minlength=H) > 0)
        for _ in range(iterations):
            if not active.any():
                break
            JtI = np.swapaxes(Jm, 1, 2) @ info
            normal, gradient = np.zeros((H, 6, 6)), np.zeros((H, 6))
            normal[groups] = np.add.reduceat(JtI @ Jm, starts, axis=0)  # h is sorted
            gradient[groups] = np.add.reduceat(np.einsum("mij,mj->mi", JtI, e), starts, axis=0)
            diagonal = np.einsum("hii->hi", normal)
            system = normal + (damping[:, None] * np.maximum(diagonal, 1e-12))[:, :, None] * np.eye(6)
            system[~active] = np.eye(6)
            step = -np.linalg.solve(system, gradient[:, :, None])[:, :, 0]
            step[~active] = 0.0
            R_new = rotations(step[:, :3]) @ R
            t_new = t + step[:, 3:]
            e_new, J_new, cost_new = residual(R_new, t_new)
            better = active & (cost_new < cost)
            R[better], t[better] = R_new[better], t_new[better]
            moved = better[h]
            e[moved], Jm[moved] = e_new[moved], J_new[moved]
            small = np.abs(cost - cost_new) <= 1e-8 * np.maximum(cost, 1e-300)
            tiny = np.linalg.norm(step, axis=1) <= 1e-8 * (1.0 + np.linalg.norm(t, axis=1))
            cost = np.where(better, cost_new, cost)
            damping = np.where(better, damping / 10, damping * 10)
            active &= ~((better & small) | tiny | (damping > 1e8))
        return R, t
