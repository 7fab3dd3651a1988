"""What every step of a metric relative pose shares: its error, the features' noise
model (:class:`NoiseModel`), the result (:class:`RelativePose`), the seed check, and the
observations (x, y, slope) of LiFF keypoints with their 3-D points (:func:`back_project`).

Part of :mod:`liff.pose` (the overview is there).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

from ..camera import LightFieldCamera, keypoint_geometry

#: chi-square (3 degrees of freedom: 6 residuals, 3 point parameters) below which a
#: match is an inlier of the refined pose; its 99.9% quantile.
CHI2_INLIER = 16.27
MIN_MATCHES = 3
#: lower bounds of the estimated noise: positions (pixels), slopes (pixels per view step)
SIGMA_FLOOR = (1e-3, 1e-4)


class PoseEstimationError(ValueError):
    """No trustworthy pose: too few matches, too few inliers, or degenerate geometry."""


@dataclass
class NoiseModel:
    """Noise of a LiFF feature's position and slope, fitted to the residuals of a pose.

    ``log sigma_k = c_k0 + c_k1 log(size / size_ref) + c_k2 log(response / response_ref)``
    for k = position (pixels) and slope (pixels per view step): features differ a lot
    (a thin occluder's edge moves by a pixel where a blob on a wall moves by 1/30 px; a
    low-contrast feature in noise is found less precisely), and a fit that weighs them
    alike is no better than its worst features.

    Attributes
    ----------
    coefficients : ndarray, shape (2, 3)
        Rows position, slope; columns intercept, size exponent, response exponent.
    reference : ndarray, shape (2,)
        size_ref (pixels) and response_ref, the medians of the features.
    """

    coefficients: np.ndarray
    reference: np.ndarray

    def covariates(self, keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
        """(N, 2): log(size / size_ref), log(response / response_ref); 0 where a keypoint
        has no positive size or response."""
        values = np.array([(k.size, k.response) for k in keypoints], np.float64).reshape(-1, 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log(values / self.reference)
        return np.where(np.isfinite(out), out, 0.0)

    def sigma(self, covariates: np.ndarray) -> np.ndarray:
        """(N, 2): position and slope noise of features with these covariates."""
        x = np.column_stack([np.ones(len(covariates)), covariates])
        return np.maximum(np.exp(x @ self.coefficients.T), SIGMA_FLOOR)

    @classmethod
    def for_keypoints(cls, keypoints: Sequence[cv2.KeyPoint], sigma_xy: float = np.nan,
                      sigma_slope: float = np.nan) -> "NoiseModel":
        """Equal noise for all features, with the keypoints' medians as reference (NaN
        levels: :func:`refine_relative_pose` estimates them)."""
        values = np.array([(k.size, k.response) for k in keypoints], np.float64).reshape(-1, 2)
        reference = np.ones(2)
        for j in range(2):
            positive = values[:, j][values[:, j] > 0]
            if positive.size:
                reference[j] = np.median(positive)
        coefficients = np.array([[np.log(sigma_xy), 0, 0], [np.log(sigma_slope), 0, 0]], np.float64)
        return cls(coefficients, reference)


@dataclass
class RelativePose:
    """What :func:`refine_relative_pose` returns.

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
    translation : ndarray, shape (3,)
        Metres; ``X2 = rotation @ X1 + translation`` maps the centre view's camera frame
        of capture 1 to that of capture 2.
    inliers : ndarray of bool, shape (N,)
        Matches whose observations agree with the pose (chi-square test, 99.9%).
    points : ndarray, shape (N, 3)
        Refined 3-D points in capture 1's frame, metres (inf where the inverse depth
        is <= 0).
    covariance : ndarray, shape (6, 6)
        Covariance of (rotation vector in radians, translation in metres) from the
        inliers' observations and the fitted noise (first order).
    noise : NoiseModel
        The fitted noise of the features' positions and slopes.
    """

    rotation: np.ndarray
    translation: np.ndarray
    inliers: np.ndarray
    points: np.ndarray
    covariance: np.ndarray
    noise: NoiseModel

    @property
    def sigma_xy(self) -> float:
        """Position noise of a median feature, pixels."""
        return float(self.noise.sigma(np.zeros((1, 2)))[0, 0])

    @property
    def sigma_slope(self) -> float:
        """Slope noise of a median feature, pixels per view step."""
        return float(self.noise.sigma(np.zeros((1, 2)))[0, 1])

    @property
    def translation_sigma(self) -> float:
        """Standard deviation of the translation's length, metres (first order)."""
        return translation_length_sigma(self.translation, self.covariance)

    @property
    def rotation_sigma_degrees(self) -> float:
        """Root of the rotation vector's total variance, degrees."""
        return float(np.degrees(np.sqrt(np.trace(self.covariance[:3, :3]))))


def translation_length_sigma(translation: np.ndarray, covariance: np.ndarray) -> float:
    """First-order standard deviation of ``|translation|`` from the (6, 6) covariance of
    (rotation vector, translation): its variance along the translation's direction."""
    direction = translation / max(np.linalg.norm(translation), 1e-300)
    return float(np.sqrt(direction @ covariance[3:, 3:] @ direction))


def check_seed(seed) -> None:
    """Checks a RANSAC seed: what numpy and COLMAP both take, an integer in [0, 2**31).

    Every estimate here checks its seed with it, and so does
    :func:`liff.colmap.match_by_pose`, before any pair is estimated.

    Raises
    ------
    ValueError
        For anything else (a bool, a float, a negative or too large integer), naming it.
    """
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) \
            or not 0 <= seed < 2 ** 31:
        raise ValueError(f"seed = {seed!r}; expected an integer in [0, 2**31)")


def observations(keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
    """(x, y, slope) of LiFF keypoints, float64 (N, 3): centre-view pixels and pixels
    per view step."""
    xy, _, slopes = keypoint_geometry(keypoints)
    return np.column_stack([xy, slopes])


def back_project(camera: LightFieldCamera, obs: np.ndarray) -> np.ndarray:
    """3-D points (N, 3) of observations (x, y, slope); NaN at or beyond infinity.

    The points of :meth:`LightFieldCamera.back_project` at the slopes' depths
    (:meth:`LightFieldCamera.depth`), metres in ``camera``'s centre-view frame: what
    RANSAC (:mod:`liff.pose.ransac`) and the putative matches of
    :func:`liff.pose.estimate_relative_pose` take as 3-D matches.
    """
    return camera.back_project(obs[:, :2], camera.depth(obs[:, 2]))
