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

Its modules, one step each (every name here is one of theirs; imports point one way:
``refine`` and ``ransac`` use ``model``, ``estimate`` uses all three):

- :mod:`~liff.pose.model`: what every step shares: :class:`PoseEstimationError`,
  :class:`NoiseModel`, :class:`RelativePose`, :func:`check_seed`, the observations
  (x, y, slope) of keypoints (:func:`observations`) and their 3-D points
  (:func:`~liff.pose.model.back_project`);
- :mod:`~liff.pose.refine`: the bundle adjustment, the noise fit, the inlier test and the
  covariance (:func:`refine_relative_pose`);
- :mod:`~liff.pose.ransac`: a first pose by RANSAC scored in the observations
  (:func:`observation_ransac`; where capture 1's features land in capture 2:
  :func:`~liff.pose.ransac.transfer`) or in 3-D (:func:`ransac_pose`);
- :mod:`~liff.pose.estimate`: the whole estimate (:func:`estimate_relative_pose`) and
  guided matching (:func:`guided_matches`).
"""

from .estimate import GUIDED_ROUNDS, estimate_relative_pose, guided_matches
from .model import (
    CHI2_INLIER,
    MIN_MATCHES,
    SIGMA_FLOOR,
    NoiseModel,
    PoseEstimationError,
    RelativePose,
    check_seed,
    observations,
    translation_length_sigma,
)
from .ransac import (
    MAX_TRANSFER_VARIANCE,
    RANSAC_BATCH,
    RANSAC_CHANCE_FACTOR,
    RANSAC_CHANCE_TRIALS,
    RANSAC_LOCAL_POOL,
    RANSAC_LOCAL_ROUNDS,
    RANSAC_MAX_HYPOTHESES,
    RANSAC_SIGMA,
    observation_ransac,
    ransac_pose,
)
from .refine import refine_relative_pose

__all__ = [
    "CHI2_INLIER", "GUIDED_ROUNDS", "MAX_TRANSFER_VARIANCE", "MIN_MATCHES", "NoiseModel",
    "PoseEstimationError", "RANSAC_BATCH", "RANSAC_CHANCE_FACTOR", "RANSAC_CHANCE_TRIALS",
    "RANSAC_LOCAL_POOL", "RANSAC_LOCAL_ROUNDS", "RANSAC_MAX_HYPOTHESES", "RANSAC_SIGMA",
    "RelativePose", "SIGMA_FLOOR", "check_seed", "estimate_relative_pose", "guided_matches",
    "observation_ransac", "observations", "ransac_pose", "refine_relative_pose",
    "translation_length_sigma",
]
