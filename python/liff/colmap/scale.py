"""A model in metres: the scale of a COLMAP model of LiFF features from the slopes and
from the pairs' metric baselines (:func:`metric_scale`), and the model scaled
(:func:`scale_reconstruction`); docs/METRIC.md."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional, Tuple

import numpy as np
import pycolmap

from ..camera import LightFieldCamera
from .matching import PairPose, posed_pairs

#: metric_scale: a pair's baseline counts only when its relative standard deviation
#: (PairPose.translation_sigma / |t|) is below this; panoramic pairs have none
MAX_BASELINE_RELATIVE_SIGMA = 0.25


@dataclass
class MetricScale:
    """What :func:`metric_scale` returns.

    Attributes
    ----------
    scale : float
        Metres per reconstruction unit: multiply the model by it.
        ``scale_from_baselines`` where it could be measured, else ``scale_from_slopes``.
    source : str
        ``"baselines"`` or ``"slopes"``: which estimate ``scale`` is.
    scale_from_slopes : float
        The fit of the 3-D points' depths to their slopes; NaN with fewer than 3
        observations.
    observations : int
        Observations of 3-D points by LiFF features with a slope that the fit used.
    inliers : int
        Those within 3 robust standard deviations of the fit.
    sigma_slope : float
        Robust standard deviation of the slope residuals, pixels per view step (NaN
        without a fit).
    scale_from_baselines : float
        Weighted median over registered image pairs of ``|t| / d``: ``|t|`` the pair's
        metric baseline (:class:`PairPose`), d the distance of the model's camera
        centres; NaN without ``pair_poses`` or a usable pair.
    pairs : int
        Pairs behind ``scale_from_baselines``.
    baseline_spread : float
        Robust relative spread of the pairs' scales (1.4826 MAD / median; NaN with fewer
        than 2 pairs): how well the model's camera layout agrees with the pair poses.
    """

    scale: float
    source: str
    scale_from_slopes: float
    observations: int
    inliers: int
    sigma_slope: float
    scale_from_baselines: float = np.nan
    pairs: int = 0
    baseline_spread: float = np.nan

    @property
    def shape_disagreement(self) -> float:
        """``scale_from_slopes / scale_from_baselines - 1``: how far the model's points'
        depths disagree with its camera baselines (NaN unless both were measured)."""
        return self.scale_from_slopes / self.scale_from_baselines - 1.0


def metric_scale(reconstruction: "pycolmap.Reconstruction", slopes: Dict[str, np.ndarray],
                 camera, pair_poses: Optional[Dict[Tuple[str, str], Optional[PairPose]]] = None
                 ) -> MetricScale:
    """The scale that turns a COLMAP reconstruction from LiFF features into metres.

    COLMAP's structure from motion fixes everything but the scale; a calibrated light
    field fixes the scale too (docs/METRIC.md), two ways:

    - From the slopes: for every observation of a 3-D point by keypoint k of image I, z
      is the point's depth in I's camera frame (model units) and the camera predicts
      the slope ``f b (1 / (s z) - 1 / focus_distance)`` for scale s. The fit minimises
      the slope residuals (where the noise is, so far points weigh little) robustly
      (SciPy's least_squares, soft-L1 loss at 3 robust standard deviations); the model
      is linear in u = 1 / s. It rests on the points COLMAP triangulated, which may be
      few (tens in a two-image model) and sit on depth edges.
    - From the pair poses (``pair_poses``, :func:`match_by_pose`): each registered
      pair's metric baseline ``|t|`` over its camera distance in the model, combined by
      a median weighted by the baseline's inverse relative variance
      ``(|t| / translation_sigma)^2``. Each baseline comes from every inlier of the
      pair, through the bundle adjustment in the observations (x, y, slope) of
      :func:`liff.estimate_relative_pose`, so it is the better estimate of the
      quantity a model's scale is judged by, the distances of its cameras; used when
      at least one pair counts (``MAX_BASELINE_RELATIVE_SIGMA``).

    Parameters
    ----------
    reconstruction : pycolmap.Reconstruction
        Its images' keypoints must be the LiFF keypoints, in order.
    slopes : dict of str to ndarray, shape (N_I,)
        Per image name, the slope of each keypoint (:func:`liff.keypoint_slopes`).
    camera : liff.LightFieldCamera
        The light field camera of every image.
    pair_poses : dict of (str, str) to PairPose or None, optional
        What :func:`match_by_pose` returned; pairs missing from the model, or None,
        are skipped.

    Returns
    -------
    MetricScale

    Raises
    ------
    ValueError
        If an image's slope count differs from its keypoints, a pair pose is not a
        :class:`PairPose`, or neither estimate can be made (fewer than 3 observations
        with a positive depth and no usable pair), or the slopes put the model at or
        beyond infinity.
    """
    if not isinstance(slopes, dict):
        raise ValueError(f"slopes is a {type(slopes).__name__}; expected a dict of image name to "
                         "the slopes of its keypoints")
    if not isinstance(camera, LightFieldCamera):
        raise ValueError(f"camera is a {type(camera).__name__}; expected a liff.LightFieldCamera")
    if pair_poses is not None and not isinstance(pair_poses, dict):
        raise ValueError(f"pair_poses is a {type(pair_poses).__name__}; expected the dict from "
                         "match_by_pose, or None")
    if not isinstance(reconstruction, pycolmap.Reconstruction):
        raise ValueError(f"reconstruction is a {type(reconstruction).__name__}; expected a "
                         "pycolmap.Reconstruction")
    slope_fit = _scale_from_slopes(reconstruction, slopes, camera)
    baselines, pairs, spread = _scale_from_baselines(reconstruction, pair_poses or {})
    if np.isfinite(baselines):
        scale, source = baselines, "baselines"
    elif slope_fit[1] >= 3:
        scale, source = slope_fit[0], "slopes"
    else:
        raise ValueError(f"{slope_fit[1]} observations of 3-D points with a slope and no "
                         "registered pair with a metric pose; expected at least 3 observations "
                         "to measure the scale")
    return MetricScale(scale, source, *slope_fit, baselines, pairs, spread)


def _scale_from_slopes(reconstruction, slopes, camera) -> Tuple[float, int, int, float]:
    """(scale, observations, inliers, sigma_slope) of the slopes' fit (NaN scale and
    sigma with fewer than 3 observations)."""
    from scipy.optimize import least_squares

    depths, observed = [], []
    for image_id in reconstruction.reg_image_ids():
        image = reconstruction.image(image_id)
        if image.name not in slopes:
            continue
        m = np.asarray(slopes[image.name], np.float64).reshape(-1)
        if len(m) != image.num_points2D():
            raise ValueError(f"{image.name}: {len(m)} slopes for {image.num_points2D()} keypoints; "
                             "expected one each")
        pose = image.cam_from_world()
        R, t = np.asarray(pose.rotation.matrix()), np.asarray(pose.translation)
        for index, point2D in enumerate(image.points2D):
            if point2D.has_point3D():
                X = reconstruction.point3D(point2D.point3D_id).xyz
                depths.append((R @ X + t)[2])
                observed.append(m[index])
    z, m = np.asarray(depths), np.asarray(observed)
    keep = (z > 0) & np.isfinite(m)
    z, m = z[keep], m[keep]
    if len(z) < 3:
        return np.nan, len(z), 0, np.nan
    fb, offset = camera.slope_scale, camera.slope_scale / camera.focus_distance
    u_each = (m + offset) * z / fb  # 1/s from each observation alone
    u0 = float(np.median(u_each))
    residual = lambda u: fb * u[0] / z - offset - m  # noqa: E731
    sigma = max(1.4826 * float(np.median(np.abs(residual([u0])))), 1e-6)
    fit = least_squares(residual, [u0], loss="soft_l1", f_scale=3 * sigma)
    u = float(fit.x[0])
    if not u > 0:
        raise ValueError("the slopes put the reconstruction at or beyond infinity; expected "
                         "features with depth (check the camera)")
    final = residual([u])
    sigma = max(1.4826 * float(np.median(np.abs(final))), 1e-6)
    return 1.0 / u, len(z), int((np.abs(final) < 3 * sigma).sum()), sigma


def _scale_from_baselines(reconstruction, pair_poses) -> Tuple[float, int, float]:
    """(scale, pairs, spread): weighted median of |t| / d over registered pairs."""
    centres = {reconstruction.image(i).name: reconstruction.image(i).projection_center()
               for i in reconstruction.reg_image_ids()}
    scales, weights = [], []
    for (a, b), pose in posed_pairs(pair_poses):
        if a not in centres or b not in centres:
            continue
        baseline, distance = float(np.linalg.norm(pose.translation)), float(np.linalg.norm(centres[a] - centres[b]))
        relative_sigma = pose.translation_sigma / baseline if baseline > 0 else np.inf
        if not (distance > 0 and relative_sigma < MAX_BASELINE_RELATIVE_SIGMA):
            continue
        scales.append(baseline / distance)
        weights.append(1.0 / max(relative_sigma, 1e-6) ** 2)
    if not scales:
        return np.nan, 0, np.nan
    order = np.argsort(scales)
    sorted_scales, sorted_weights = np.asarray(scales)[order], np.asarray(weights)[order]
    cumulative = np.cumsum(sorted_weights)
    median = float(sorted_scales[np.searchsorted(cumulative, 0.5 * cumulative[-1])])
    spread = (1.4826 * float(np.median(np.abs(sorted_scales / median - 1)))
              if len(sorted_scales) >= 2 else np.nan)
    return median, len(sorted_scales), spread


def scale_reconstruction(reconstruction: "pycolmap.Reconstruction", scale: float) -> None:
    """Multiplies a reconstruction's coordinates (points and camera centres) by ``scale``,
    in place."""
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale = {scale}; expected a positive finite factor")
    reconstruction.transform(pycolmap.Sim3d(float(scale), pycolmap.Rotation3d(), np.zeros(3)))
