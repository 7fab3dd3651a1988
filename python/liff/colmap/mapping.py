"""Models from a matched database: COLMAP's incremental mapper (:func:`reconstruct`),
or a metric model from the pairs' metric poses (:func:`reconstruct_from_poses`: pose
graph, then COLMAP's triangulator)."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple, cast

import numpy as np
import pycolmap

from ..pose_graph import PairMeasurement, absolute_poses
from .database import PathLike, colmap_log, require_database
from .matching import PairPose, posed_pairs


@dataclass
class SfmResult:
    """What :func:`reconstruct` returns.

    Attributes
    ----------
    reconstructions : dict of int to pycolmap.Reconstruction
        COLMAP's models, empty if mapping failed.
    num_images : int
        Images in the database.
    """

    reconstructions: Dict[int, "pycolmap.Reconstruction"] = field(default_factory=dict)
    num_images: int = 0

    @property
    def success(self) -> bool:
        """True if COLMAP produced at least one model (the paper's "pass")."""
        return len(self.reconstructions) > 0

    @property
    def best(self) -> Optional["pycolmap.Reconstruction"]:
        """The model with the most registered images (then the most points), or None."""
        if not self.reconstructions:
            return None
        return max(self.reconstructions.values(), key=lambda r: (r.num_reg_images(), r.num_points3D()))


def mapper_options(kind: str = "default", seed: int = 0,
                   fixed_intrinsics: bool = False) -> "pycolmap.IncrementalPipelineOptions":
    """COLMAP's incremental mapper options.

    ``"default"`` is COLMAP's defaults. ``"permissive"`` relaxes what the paper names
    (minimum inlier counts, minimum track length, minimum model size) for small sets of
    small images: pairs need 10 matches (default 15); the initial pair 30 inliers (100)
    and a triangulation angle of 8 degrees (16); a new image 15 inliers (30) at an inlier
    ratio of 0.15 (0.25); two-view tracks are kept (ignored by default); a further model
    needs 3 images (10, or 80% of the images if fewer). COLMAP keeps its first model
    whatever its size, so with either setting two registered images make a model. Both
    fix the random seed and run on one thread: with several, bundle adjustment's sums
    come in a varying order and the 3-D point counts vary from run to run.
    ``fixed_intrinsics`` keeps the camera's focal length, principal point and
    distortion as written to the database (a calibrated camera): bundle adjustment
    then refines only poses and points.
    """
    options = pycolmap.IncrementalPipelineOptions()
    options.num_threads = 1
    options.random_seed = seed
    options.mapper.random_seed = seed
    options.triangulation.random_seed = seed
    if kind == "permissive":
        options.min_num_matches = 10
        options.min_model_size = 3
        options.mapper.init_min_num_inliers = 30
        options.mapper.init_min_tri_angle = 8.0
        options.mapper.abs_pose_min_num_inliers = 15
        options.mapper.abs_pose_min_inlier_ratio = 0.15
        options.triangulation.ignore_two_view_tracks = False
    elif kind != "default":
        raise ValueError(f"mapper = {kind!r}; expected 'default' or 'permissive'")
    if fixed_intrinsics:
        options.ba_refine_focal_length = False
        options.ba_refine_principal_point = False
        options.ba_refine_extra_params = False
    return options


def reconstruct(database_path: PathLike, image_dir: PathLike, out_dir: PathLike,
                mapper: str = "default", seed: int = 0, fixed_intrinsics: bool = False,
                verbose: bool = False) -> SfmResult:
    """COLMAP's incremental mapping on a matched database (see :func:`mapper_options`).

    Models are written to ``out_dir/0``, ``out_dir/1``, ...; the result holds them.
    COLMAP's log shows errors only unless ``verbose``.
    """
    options = mapper_options(mapper, seed, fixed_intrinsics)
    require_database(database_path)
    os.makedirs(out_dir, exist_ok=True)
    with colmap_log(verbose):
        models = pycolmap.incremental_mapping(os.fspath(database_path), os.fspath(image_dir),
                                              os.fspath(out_dir), options)
    with pycolmap.Database.open(require_database(database_path)) as db:
        num_images = db.num_images()
    return SfmResult(dict(models), num_images)


def _check_against_database(db, id1: int, id2: int, pair, pose: PairMeasurement) -> None:
    """The pair's pose must be the two-view geometry match_by_pose wrote for it (catches
    reversed pairs and the poses of another database)."""
    geometry = db.read_two_view_geometry(id1, id2)  # COLMAP inverts it for (larger, smaller)
    expected = (pycolmap.TwoViewGeometryConfiguration.CALIBRATED,
                pycolmap.TwoViewGeometryConfiguration.PANORAMIC)
    stored = geometry.cam2_from_cam1 if geometry.config in expected else None
    if stored is not None:
        R = np.asarray(stored.rotation.matrix())
        t = np.asarray(stored.translation)
        direction = pose.translation / max(np.linalg.norm(pose.translation), 1e-300)
        angle = np.arccos(np.clip((np.trace(R.T @ pose.rotation) - 1) / 2, -1, 1))
        if angle < 1e-4 and (np.linalg.norm(t) < 0.5 or direction @ t > 1 - 1e-4):
            return
    raise ValueError(f"pair_poses[{pair[0]!r}, {pair[1]!r}] is not the pose match_by_pose wrote "
                     "to this database for that pair (reversed names, or another database's "
                     "poses?); expected match_by_pose's result for this database")


def reconstruct_from_poses(database_path: PathLike, image_dir: PathLike, out_dir: PathLike,
                           pair_poses: Dict[Tuple[str, str], Optional[PairPose]],
                           seed: int = 0, verbose: bool = False) -> SfmResult:
    """A metric model from the pairs' metric poses: pose graph, then COLMAP's triangulator.

    For light fields of a calibrated camera matched by :func:`match_by_pose`. The
    cameras' poses are the absolute poses that agree best with every pair's metric
    relative pose (:func:`liff.pose_graph.absolute_poses`; the world is the camera
    frame of the image with the most inliers, in metres); COLMAP's point triangulator
    (``pycolmap.triangulate_points``) then triangulates the database's matches with
    those poses held fixed and refines the points, the camera's intrinsics kept as
    written. Every image connected to the reference by pairs with a pose is
    registered; COLMAP's incremental mapper may register fewer (behind an occluding
    fence, 2 of 4 images) and its rotations can be a degree off where the slopes fix
    them within 0.2 degrees (docs/METRIC.md). The model is written to ``out_dir/0``.

    Parameters
    ----------
    database_path, image_dir, out_dir : path
    pair_poses : dict of (str, str) to PairPose or None
        What :func:`match_by_pose` returned for this database.
    seed : int
        The triangulator's random seed.
    verbose : bool
        Show COLMAP's log.

    Returns
    -------
    SfmResult
        One model (``reconstructions[0]``), or none if no pair has a pose.

    Raises
    ------
    ValueError
        If a pair names an image that is not in the database, a pose is not a
        :class:`PairPose`, or a pair's pose differs from the two-view geometry that
        :func:`match_by_pose` wrote for it (names reversed, another database's poses).
    """
    measurements = {pair: pose.measurement() for pair, pose in posed_pairs(pair_poses)}
    with pycolmap.Database.open(require_database(database_path)) as db:
        images = {image.name: image for image in db.read_all_images()}
        cameras = {camera.camera_id: camera for camera in db.read_all_cameras()}
        num_images = len(images)
        missing = sorted({name for pair in measurements for name in pair} - set(images))
        if missing:
            raise ValueError(f"pair_poses name {missing}, not in the database "
                             f"{os.fspath(database_path)}; expected its images")
        for (a, b), pose in measurements.items():
            _check_against_database(db, images[a].image_id, images[b].image_id, (a, b), pose)
        keypoints = {name: db.read_keypoints(image.image_id)[:, :2] for name, image in images.items()}
    if not measurements:
        return SfmResult({}, num_images)
    # (keyed by the image names the measurements carry)
    poses = cast(Dict[str, Tuple[np.ndarray, np.ndarray]], absolute_poses(measurements))
    model = pycolmap.Reconstruction()
    for camera_id in sorted({images[name].camera_id for name in poses}):
        model.add_camera_with_trivial_rig(cameras[camera_id])
    for name, (R, t) in sorted(poses.items()):
        stored = images[name]
        image = pycolmap.Image(name=name, keypoints=keypoints[name].astype(np.float64),
                               camera_id=stored.camera_id, image_id=stored.image_id)
        model.add_image_with_trivial_frame(image, pycolmap.Rigid3d(pycolmap.Rotation3d(R), t))
    options = mapper_options("default", seed, fixed_intrinsics=True)
    # The poses are fixed and metric, so a point seen by two images is as well placed as
    # by more: keep two-view tracks (the incremental mapper drops them by default).
    options.triangulation.ignore_two_view_tracks = False
    path = os.path.join(os.fspath(out_dir), "0")
    os.makedirs(path, exist_ok=True)
    with colmap_log(verbose):
        model = pycolmap.triangulate_points(model, os.fspath(database_path), os.fspath(image_dir),
                                            path, clear_points=True, options=options)
    return SfmResult({0: model}, num_images)
