"""Matching the pairs of a database: COLMAP's exhaustive matching and two-view
verification (:func:`match`), or, for light fields of a calibrated camera, each pair's
metric relative pose (:func:`match_by_pose`, :class:`PairPose`)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from itertools import combinations
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
import pycolmap

from .._pairs import pair_poses
from ..keypoint_rows import keypoint_slopes, keypoints_to_rows
from ..pose import check_seed, translation_length_sigma
from ..pose_graph import MIN_SIGMA_ROTATION, MIN_SIGMA_TRANSLATION, PairMeasurement
from .database import FeatureImage, PathLike, colmap_log, require_database


def matching_options(seed: int = 0) -> tuple:
    """COLMAP's default matching (ratio 0.8, distance 0.7, cross check) on the CPU by
    exact brute force, and two-view verification (RANSAC, 4 px, 15 inliers) with a fixed
    RANSAC seed. COLMAP's CPU default is an approximate nearest-neighbour index whose
    matches vary from run to run (a few % of putative matches); exact search makes the
    matches, and so every table built on them, repeatable."""
    matching = pycolmap.FeatureMatchingOptions()
    matching.use_gpu = False
    matching.sift.cpu_brute_force_matcher = True
    verification = pycolmap.TwoViewGeometryOptions()
    verification.ransac.random_seed = seed
    return matching, verification


def match(database_path: PathLike, matching=None, verification=None, seed: int = 0,
          verbose: bool = False) -> None:
    """Exhaustive matching and two-view geometric verification of every image pair.

    Parameters
    ----------
    matching : pycolmap.FeatureMatchingOptions, optional
    verification : pycolmap.TwoViewGeometryOptions, optional
        Default: :func:`matching_options` ``(seed)``.
    verbose : bool
        Show COLMAP's log (default: errors only; see :func:`colmap_log`).
    """
    default_matching, default_verification = matching_options(seed)
    with colmap_log(verbose):
        _match_exhaustive(database_path, default_matching if matching is None else matching,
                          default_verification if verification is None else verification)


def _match_exhaustive(database_path: PathLike, matching, verification) -> None:
    pycolmap.match_exhaustive(
        require_database(database_path), matching_options=matching, verification_options=verification,
        device=pycolmap.Device.cpu)


#: match_by_pose: a pose whose baseline is below this share of the scene's median depth
#: is a rotation about the centre view (panoramic), not a calibrated two-view geometry
PANORAMIC_BASELINE = 1e-6


@dataclass
class PairPose:
    """Metric relative pose of an image pair, as :func:`match_by_pose` measured it.

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
    translation : ndarray, shape (3,)
        Metres, ``X2 = rotation @ X1 + translation`` from the first image's centre-view
        camera frame to the second's (:func:`liff.estimate_relative_pose`).
    covariance : ndarray, shape (6, 6)
        First-order covariance of (rotation vector in radians, translation in metres),
        a lower bound (docs/METRIC.md).
    inliers : int
        Inlier matches, written to the database as the pair's matches.
    """

    rotation: np.ndarray
    translation: np.ndarray
    covariance: np.ndarray
    inliers: int

    @property
    def translation_sigma(self) -> float:
        """Standard deviation of ``|translation|``, metres."""
        return translation_length_sigma(self.translation, self.covariance)

    def measurement(self) -> PairMeasurement:
        """The pose graph's view of it: RMS standard deviations per axis, at least the pose
        graph's floors (a pose fitted without residual, the same light field twice, has a
        covariance of 0)."""
        sigma_R = np.sqrt(max(np.trace(self.covariance[:3, :3]), 0.0) / 3)
        sigma_t = np.sqrt(max(np.trace(self.covariance[3:, 3:]), 0.0) / 3)
        return PairMeasurement(self.rotation, self.translation, max(float(sigma_R), MIN_SIGMA_ROTATION),
                               max(float(sigma_t), MIN_SIGMA_TRANSLATION), self.inliers)


def match_by_pose(database_path: PathLike, images: Sequence[FeatureImage], camera,
                  ratio: float = 0.8, seed: int = 0, workers: int = 1,
                  progress=None) -> Dict[Tuple[str, str], Optional[PairPose]]:
    """Matching of calibrated light fields by their metric relative pose, for every pair.

    For light fields of one calibrated camera (:class:`liff.LightFieldCamera`) each pair's
    matches come from :func:`liff.estimate_relative_pose`: ratio test, RANSAC scored in
    the observations (x, y, slope), refinement, and guided matching with that pose, so
    matches lost to the ratio test (behind an occluding fence, 40-70 putative matches of
    which 10-40 right) come back, and wrong ones are removed by the 3-D geometry that
    the slopes fix. The inliers are written as the pair's matches and its verified
    two-view geometry (calibrated: the essential matrix and pose of the estimate, the
    translation of unit length as COLMAP stores it; panoramic, H = K R K^-1, when the
    baseline is nil); a pair without a pose
    (:class:`liff.PoseEstimationError`) gets no matches. Instead of :func:`match`, on a
    database from :func:`write_database` of the same ``images``. Costs a pose estimate
    per pair (0.15-0.4 s each with ~730 features an image, docs/BENCHMARKS.md): N (N - 1)
    / 2 of them for N images, spread over ``workers`` processes.

    Parameters
    ----------
    database_path : path
    images : sequence of FeatureImage
        The images written to the database (matched by name), keypoints from liff.LiFF
        (slopes in ``class_id``).
    camera : liff.LightFieldCamera
        The camera of every light field.
    ratio : float
        Lowe's ratio for the putative matches.
    seed : int in [0, 2**31)
        RANSAC's seed (repeatable: every pair gets it, so the result does not depend on
        ``workers``).
    workers : int >= 1
        Processes that estimate the pairs' poses (1: this one); the database is written
        here, in pair order.
    progress : callable, optional
        Called with no argument as each pair's pose is estimated (e.g. a tqdm bar's
        ``update``).

    Returns
    -------
    dict of (name1, name2) to PairPose or None
        Each pair's metric pose and inlier count (None where no pose was found; the
        translation 0 where the pair was written as panoramic), in
        COLMAP's pair order (the first name has the smaller image id); what
        :func:`metric_scale` takes as ``pair_poses``.

    Raises
    ------
    ValueError
        If an image is not in the database or its keypoint count differs from the
        database's, names repeat, the database already holds matches, the seed is
        outside [0, 2**31), or ``workers`` is not a positive integer.
    """
    check_seed(seed)
    if isinstance(workers, (bool, np.bool_)) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers = {workers!r}; expected a positive integer")
    names = [im.name for im in images]
    if len(set(names)) != len(names):
        raise ValueError(f"repeated image names {sorted(names)}; expected one image each")
    with colmap_log(), pycolmap.Database.open(require_database(database_path)) as db:
        ids = {image.name: image.image_id for image in db.read_all_images()}
        missing = [name for name in names if name not in ids]
        if missing:
            raise ValueError(f"{missing}: not in the database {os.fspath(database_path)}; expected "
                             "the images written by write_database")
        for im in images:
            stored = db.num_keypoints_for_image(ids[im.name])
            if stored != len(im.keypoints):
                raise ValueError(f"{im.name}: {len(im.keypoints)} keypoints given, {stored} in the "
                                 "database; expected the features written by write_database")
        if db.num_matched_image_pairs() or db.num_verified_image_pairs():
            raise ValueError(f"{os.fspath(database_path)} already holds matches; expected a fresh "
                             "database from write_database")
    ordered = sorted(images, key=lambda im: ids[im.name])  # COLMAP keeps pairs as (smaller id, larger)
    pairs = list(combinations(range(len(ordered)), 2))
    # The poses first (in worker processes, without the database open), then the writes.
    features = [(keypoints_to_rows(im.keypoints), im.descriptors) for im in ordered]
    estimates = pair_poses(features, pairs, camera, ratio, seed, int(workers), progress)
    poses: Dict[Tuple[str, str], Optional[PairPose]] = {}
    with colmap_log(), pycolmap.Database.open(require_database(database_path)) as db:
        for (a, b), estimate in zip(pairs, estimates):
            first, second = ordered[a], ordered[b]
            if estimate is None:
                poses[(first.name, second.name)] = None
                continue
            R, t, pairs_ab, covariance = estimate
            geometry = pycolmap.TwoViewGeometry()
            geometry.inlier_matches = pairs_ab
            depth = np.nanmedian(camera.depth(keypoint_slopes([first.keypoints[q] for q in pairs_ab[:, 0]])))
            if np.linalg.norm(t) <= PANORAMIC_BASELINE * (depth if np.isfinite(depth) else 1.0):
                # No baseline (a rotation about the centre view): nothing to triangulate;
                # COLMAP takes the pair as panoramic, related by H = K R K^-1.
                K = camera.matrix() + np.array([[0, 0, 0.5], [0, 0, 0.5], [0, 0, 0]])  # COLMAP's pixels
                geometry.config = pycolmap.TwoViewGeometryConfiguration.PANORAMIC
                geometry.H = K @ R @ np.linalg.inv(K)
                t = np.zeros(3)  # as written: no baseline, none to scale by (metric_scale)
                geometry.cam2_from_cam1 = pycolmap.Rigid3d(pycolmap.Rotation3d(R), t)
            else:
                direction = t / np.linalg.norm(t)
                tx, ty, tz = direction
                geometry.config = pycolmap.TwoViewGeometryConfiguration.CALIBRATED
                geometry.E = np.array([[0, -tz, ty], [tz, 0, -tx], [-ty, tx, 0]]) @ R  # [t]_x R
                geometry.cam2_from_cam1 = pycolmap.Rigid3d(pycolmap.Rotation3d(R), direction)
            db.write_matches(ids[first.name], ids[second.name], pairs_ab)
            db.write_two_view_geometry(ids[first.name], ids[second.name], geometry)
            poses[(first.name, second.name)] = PairPose(R, t, covariance, len(pairs_ab))
    return poses


def posed_pairs(pair_poses):
    """The ((name1, name2), PairPose) items of :func:`match_by_pose`'s result that have a
    pose, in its order; what :func:`liff.colmap.reconstruct_from_poses` and
    :func:`liff.colmap.metric_scale` read from it.

    Raises
    ------
    ValueError
        If ``pair_poses`` is not a dict, a key is not a pair of names, or a value is
        neither a :class:`PairPose` nor None.
    """
    if not isinstance(pair_poses, dict):
        raise ValueError(f"pair_poses is a {type(pair_poses).__name__}; expected the dict from "
                         "match_by_pose")
    for key, pose in pair_poses.items():
        if not (isinstance(key, tuple) and len(key) == 2):
            raise ValueError(f"pair_poses key {key!r}; expected a tuple (name1, name2)")
        a, b = key
        if pose is None:
            continue
        if not isinstance(pose, PairPose):
            raise ValueError(f"pair_poses[{a!r}, {b!r}] is a {type(pose).__name__}; expected a "
                             "liff.colmap.PairPose (from match_by_pose) or None")
        yield (a, b), pose
