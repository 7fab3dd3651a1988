"""Refinement of a relative pose where the noise lives: a two-capture bundle adjustment
in the observations (x, y, slope) of both captures, the features' noise fitted to its
residuals, the inlier test and the pose's covariance (:func:`refine_relative_pose`).

Part of :mod:`liff.pose` (the overview is there).
"""

from __future__ import annotations

from typing import Optional, Tuple

import cv2
import numpy as np

from .. import _bundle
from ..camera import LightFieldCamera
from .model import CHI2_INLIER, MIN_MATCHES, SIGMA_FLOOR, NoiseModel, PoseEstimationError, RelativePose

#: median of log |z| for a standard normal z: log(0.6745)
_MEDIAN_LOG_ABS_NORMAL = -0.3937
#: matches below which the noise model keeps one level per kind (no size or contrast terms)
_MIN_FOR_TERMS = 100


def _rotation(rvec: np.ndarray) -> np.ndarray:
    return cv2.Rodrigues(np.asarray(rvec, np.float64).reshape(3, 1))[0]


class _Problem:
    """The two-capture bundle adjustment: residuals, Jacobian and its per-match blocks.

    params = [rotation vector (3), translation (3), (x, y, w) per match], x, y the
    point's pixel in capture 1 and w = 1/Z its inverse depth. Residuals per match, each
    divided by its noise (n, 6): (x1, y1, slope1, x2, y2, slope2) predicted - observed.
    """

    def __init__(self, obs1, obs2, cam1: LightFieldCamera, cam2: LightFieldCamera, noise):
        self.obs1, self.obs2, self.cam1, self.cam2 = obs1, obs2, cam1, cam2
        self.n = len(obs1)
        self.scale = 1.0 / np.asarray(noise, np.float64)  # (n, 6): 1 / noise of each residual
        self.observed = np.hstack([obs1, obs2])

    def _geometry(self, params):
        R, dR = cv2.Rodrigues(np.asarray(params[:3], np.float64).reshape(3, 1))
        t = params[3:6]
        pts = params[6:].reshape(self.n, 3)
        c1 = self.cam1
        cx1, cy1 = c1.principal_point
        d = np.column_stack([(pts[:, 0] - cx1) / c1.focal_length, (pts[:, 1] - cy1) / c1.focal_length,
                             np.ones(self.n)])
        p = d @ R.T + np.outer(pts[:, 2], t)  # w * X2: finite for points at infinity
        pz = np.maximum(p[:, 2], 1e-9)  # behind capture 2: clamped (such a match is an outlier)
        return R, dR, t, pts, d, p, pz

    def residuals(self, params) -> np.ndarray:
        """(n, 6) normalised residuals."""
        _, _, _, pts, _, p, pz = self._geometry(params)
        c1, c2 = self.cam1, self.cam2
        cx2, cy2 = c2.principal_point
        pred = np.column_stack([
            pts[:, 0], pts[:, 1], c1.slope_scale * (pts[:, 2] - 1 / c1.focus_distance),
            c2.focal_length * p[:, 0] / pz + cx2, c2.focal_length * p[:, 1] / pz + cy2,
            c2.slope_scale * (pts[:, 2] / pz - 1 / c2.focus_distance)])
        return (pred - self.observed) * self.scale

    def blocks(self, params):
        """Jacobian blocks of the normalised residuals: (n, 6, 6) on the pose and
        (n, 6, 3) on each match's own point."""
        R, dR, t, pts, d, p, pz = self._geometry(params)
        n, c1, c2 = self.n, self.cam1, self.cam2
        f2, w = c2.focal_length, pts[:, 2]
        # d(prediction 2)/dp: rows x2, y2, slope2
        dproj = np.zeros((n, 3, 3))
        dproj[:, 0, 0] = f2 / pz
        dproj[:, 0, 2] = -f2 * p[:, 0] / pz ** 2
        dproj[:, 1, 1] = f2 / pz
        dproj[:, 1, 2] = -f2 * p[:, 1] / pz ** 2
        dproj[:, 2, 2] = -c2.slope_scale * w / pz ** 2
        dp_pose = np.empty((n, 3, 6))
        dp_pose[:, :, :3] = np.einsum("kij,nj->nik", dR.reshape(3, 3, 3), d)
        dp_pose[:, :, 3:] = w[:, None, None] * np.eye(3)
        dp_point = np.empty((n, 3, 3))
        dp_point[:, :, 0] = R[:, 0] / c1.focal_length
        dp_point[:, :, 1] = R[:, 1] / c1.focal_length
        dp_point[:, :, 2] = t
        pose = np.zeros((n, 6, 6))
        pose[:, 3:] = dproj @ dp_pose
        point = np.zeros((n, 6, 3))
        point[:, 0, 0] = point[:, 1, 1] = 1.0
        point[:, 2, 2] = c1.slope_scale
        point[:, 3:] = dproj @ dp_point
        point[:, 5, 2] += c2.slope_scale / pz  # slope2 = f b (w / p_z - 1/F): direct term
        return pose * self.scale[:, :, None], point * self.scale[:, :, None]

    def solve_points(self, params):
        """params with every point fitted to its observations, the pose held."""
        return _bundle.solve_points(self, params)

    def solve(self, params0, loss: str):
        """Pose and points by Levenberg-Marquardt on the Schur complement
        (:func:`liff._bundle.solve`; analytic Jacobian, :meth:`blocks`)."""
        return _bundle.solve(self, params0, loss, f_scale=3.0)


def _leverage(pose_blocks: np.ndarray, point_blocks: np.ndarray) -> np.ndarray:
    """Diagonal of the whole problem's hat matrix J (J^T J)^-1 J^T, (n, 6): each
    residual's share absorbed by its match's point plus the pose's share (the pose
    columns with the points' part projected out, the Schur complement). With few
    matches the pose absorbs a good part of the residuals; leaving it out makes the
    fitted noise shrink round after round."""
    Bt = np.swapaxes(point_blocks, 1, 2)
    BI = point_blocks @ np.linalg.pinv(Bt @ point_blocks)  # (n, 6, 3): B (B^T B)^+
    reduced = pose_blocks - BI @ (Bt @ pose_blocks)
    flat = reduced.reshape(-1, reduced.shape[2])
    schur = flat.T @ flat
    return (np.einsum("nri,nri->nr", BI, point_blocks)
            + np.einsum("nri,nri->nr", reduced @ np.linalg.pinv(schur), reduced))


def _pose_covariance(pose_blocks: np.ndarray, point_blocks: np.ndarray) -> np.ndarray:
    """(J^T J)^-1 of the pose, the points eliminated by the Schur complement."""
    A = np.einsum("nri,nrj->ij", pose_blocks, pose_blocks)
    B = np.einsum("nri,nrj->nij", pose_blocks, point_blocks)  # (n, 6, 3)
    C = np.einsum("nri,nrj->nij", point_blocks, point_blocks)  # (n, 3, 3)
    schur = A - np.einsum("nij,njk,nlk->il", B, np.linalg.pinv(C), B)
    eigenvalues = np.linalg.eigvalsh(schur)
    if not np.isfinite(eigenvalues).all() or eigenvalues[0] <= 1e-12 * max(eigenvalues[-1], 1e-300):
        raise PoseEstimationError("degenerate geometry: the matched points do not fix the pose "
                                  "(too few, collinear, or all at infinity)")
    return np.linalg.inv(schur)


def _residual_noise(model: NoiseModel, cov1: np.ndarray, cov2: np.ndarray) -> np.ndarray:
    """(n, 6) noise of each residual (x1, y1, slope1, x2, y2, slope2)."""
    s1, s2 = model.sigma(cov1), model.sigma(cov2)
    return np.column_stack([s1[:, 0], s1[:, 0], s1[:, 1], s2[:, 0], s2[:, 0], s2[:, 1]])


def _update_noise(model: NoiseModel, e: np.ndarray, redundancy: np.ndarray, cov1: np.ndarray,
                  cov2: np.ndarray) -> NoiseModel:
    """Refits the noise model to inliers' normalised residuals ``e`` (n, 6).

    Each residual divided by the root of its redundancy (the share of it that the
    match's own point does not absorb) has unit variance if the model is right, so
    log |u| estimates log(sigma_true / sigma_model) + log |z|: it is regressed on the
    features' covariates (least squares, for the exponents, from 100 matches on) and the
    level set by the median (minus the median of log |z|, robust to the worst inliers);
    the correction is added to the model.
    """
    coefficients = model.coefficients.copy()
    terms = len(e) >= _MIN_FOR_TERMS
    for row, columns in ((0, [0, 1, 3, 4]), (1, [2, 5])):
        r = redundancy[:, columns]
        keep = r > 0.1
        if not keep.any():
            continue
        u = np.abs(e[:, columns][keep]) / np.sqrt(r[keep])
        y = np.log(np.maximum(u, 1e-6))
        covariates = np.stack([cov1 if c < 3 else cov2 for c in columns], axis=1)[keep]  # (m, 2)
        delta = np.zeros(3)
        if terms:
            delta = np.linalg.lstsq(np.column_stack([np.ones(len(y)), covariates]), y, rcond=None)[0]
        # The level by the median (robust to the inliers' worst), E: median log |z|.
        delta[0] = np.median(y - covariates @ delta[1:]) - _MEDIAN_LOG_ABS_NORMAL
        coefficients[row] += delta
        coefficients[row, 1:] = np.clip(coefficients[row, 1:], -2.0, 2.0)
    return NoiseModel(coefficients, model.reference)


def refine_relative_pose(obs1: np.ndarray, obs2: np.ndarray, camera1: LightFieldCamera,
                         camera2: LightFieldCamera, rotation: np.ndarray, translation: np.ndarray,
                         inliers: Optional[np.ndarray] = None,
                         noise: Optional[NoiseModel] = None,
                         covariates: Optional[Tuple[np.ndarray, np.ndarray]] = None,
                         iterations: int = 4) -> RelativePose:
    """Refines a relative pose in the captures' observations (x, y, slope).

    Parameters
    ----------
    obs1, obs2 : ndarray, shape (N, 3)
        Matched observations (x, y, slope) in captures 1 and 2 (:func:`observations`).
    camera1, camera2 : LightFieldCamera
    rotation : ndarray, shape (3, 3)
    translation : ndarray, shape (3,)
        Initial pose, ``X2 = rotation @ X1 + translation`` (metres).
    inliers : ndarray of bool, shape (N,), optional
        Matches believed right (e.g. RANSAC's), for the first noise estimate; default all.
    noise : NoiseModel, optional
        Starting noise model (its reference names the covariates' units); NaN levels, or
        none given, are estimated from capture 2's residuals of the initial pose over
        ``inliers``, alike for all features.
    covariates : (ndarray, ndarray), shapes (N, 2), optional
        The matched features' covariates in capture 1 and 2
        (:meth:`NoiseModel.covariates`); default 0 (all features alike).
    iterations : int
        Rounds of (robust fit of every match, noise model fit, inlier test) before the
        final fit.

    Returns
    -------
    RelativePose

    Raises
    ------
    PoseEstimationError
        If fewer than 3 matches remain inliers or the geometry is degenerate.

    Notes
    -----
    Minimises sum_i rho(|r_i|^2) over the pose and every point, r_i the six residuals
    (x, y, slope in captures 1 and 2) of match i, each divided by its feature's noise.
    The point is (x, y, w) in capture 1 (w = 1/Z); capture 2 sees ``p = R d + t w``, d =
    ((x - cx) / f, (y - cy) / f, 1), at (f p_x / p_z + cx, f p_y / p_z + cy) with slope
    ``f b (w / p_z - 1 / focus_distance)`` (the camera model, docs/METRIC.md).

    Each round fits the pose and points of the current inliers with a Cauchy loss
    (soft beyond 3 sigma), refits the noise model to their residuals
    (:class:`NoiseModel`: position and slope noise as power laws of the features'
    size and contrast), fits every match's point for that pose, and keeps the matches
    whose chi-square (6 residuals less 3 point parameters: 3 degrees of freedom) is
    below its 99.9% quantile. The final fit uses the inliers and plain
    least squares, whose Jacobian gives the covariance, scaled by the a-posteriori
    variance factor.
    """
    obs1, obs2 = np.asarray(obs1, np.float64), np.asarray(obs2, np.float64)
    n = len(obs1)
    if n < MIN_MATCHES:
        raise PoseEstimationError(f"{n} matches; expected at least {MIN_MATCHES}")
    inliers = np.ones(n, bool) if inliers is None else np.asarray(inliers, bool).copy()
    if covariates is None:
        cov1 = cov2 = np.zeros((n, 2))
    else:
        cov1, cov2 = (np.asarray(c, np.float64).reshape(n, 2) for c in covariates)
    rvec = cv2.Rodrigues(np.asarray(rotation, np.float64))[0].ravel()
    w0 = camera1.inverse_depth(obs1[:, 2])
    params = np.concatenate([rvec, np.asarray(translation, np.float64).ravel(),
                             np.column_stack([obs1[:, :2], w0]).ravel()])
    noise = NoiseModel(np.full((2, 3), np.nan), np.ones(2)) if noise is None else noise
    if np.isnan(noise.coefficients[:, 0]).any():  # from capture 2's residuals of the initial pose
        r = _Problem(obs1, obs2, camera1, camera2, np.ones((n, 6))).residuals(params)[inliers, 3:]
        noise = NoiseModel(np.array([[np.log(max(_mad(r[:, :2]), SIGMA_FLOOR[0])), 0, 0],
                                     [np.log(max(_mad(r[:, 2]), SIGMA_FLOOR[1])), 0, 0]]),
                           noise.reference)
    for _ in range(iterations):
        if inliers.sum() < MIN_MATCHES:
            break
        # Pose and points of the current inliers, robustly; the noise from them.
        problem = _Problem(obs1[inliers], obs2[inliers], camera1, camera2,
                           _residual_noise(noise, cov1[inliers], cov2[inliers]))
        sub = problem.solve(np.concatenate([params[:6], params[6:].reshape(n, 3)[inliers].ravel()]),
                            "cauchy").x
        params[:6] = sub[:6]
        params[6:].reshape(n, 3)[inliers] = sub[6:].reshape(-1, 3)
        redundancy = 1.0 - _leverage(*problem.blocks(sub))
        noise = _update_noise(noise, problem.residuals(sub), redundancy, cov1[inliers], cov2[inliers])
        # Every match's point for that pose, then the chi-square test.
        problem = _Problem(obs1, obs2, camera1, camera2, _residual_noise(noise, cov1, cov2))
        params = problem.solve_points(params)
        inliers = np.square(problem.residuals(params)).sum(axis=1) < CHI2_INLIER
    k = int(inliers.sum())
    if k < MIN_MATCHES:
        raise PoseEstimationError(f"{k} of {n} matches agree with a pose; expected at least "
                                  f"{MIN_MATCHES}")
    problem = _Problem(obs1[inliers], obs2[inliers], camera1, camera2,
                       _residual_noise(noise, cov1[inliers], cov2[inliers]))
    sub = np.concatenate([params[:6], params[6:].reshape(n, 3)[inliers].ravel()])
    result = problem.solve(sub, "linear")
    params[:6] = result.x[:6]
    pts = params[6:].reshape(n, 3)
    pts[inliers] = result.x[6:].reshape(-1, 3)
    covariance = _pose_covariance(*problem.blocks(result.x))
    dof = max(1.0 - (3 * k + 6) / (6 * k), 0.1)
    covariance *= 2 * result.cost / (6 * k * dof)  # a-posteriori variance factor
    with np.errstate(divide="ignore"):
        points = camera1.back_project(pts[:, :2], np.where(pts[:, 2] > 0, 1.0 / pts[:, 2], np.inf))
    return RelativePose(_rotation(params[:3]), params[3:6].copy(), inliers, points, covariance, noise)


def _mad(values: np.ndarray) -> float:
    """1.4826 x the median absolute value (a robust standard deviation about 0)."""
    return float(1.4826 * np.median(np.abs(values))) if values.size else 1.0
