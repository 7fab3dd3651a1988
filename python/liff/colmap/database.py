"""The COLMAP database: images and their features written into a fresh one
(:func:`write_database`), and what every step that opens one shares: COLMAP's log
kept quiet (:func:`colmap_log`) and a missing database named (:func:`require_database`)."""

from __future__ import annotations

import os
from contextlib import contextmanager
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple, Union

import cv2
import numpy as np
import pycolmap

from ..io.images import IMAGE_SUFFIXES, write_image
from ..outputs import atomic_output
from .conversions import descriptors_to_colmap, grey_uint8_image, keypoints_to_colmap

PathLike = Union[str, os.PathLike]


@dataclass
class FeatureImage:
    """One image and its features, as a detector returned them.

    Attributes
    ----------
    name : str
        File name inside the image folder, e.g. ``"pose00.png"``, with an image ending
        (``.png``, ``.tif``, ``.jpg``, ...).
    image : ndarray, shape (V, U) or (V, U, 3)
        Grey or BGR image, uint8, uint16 or float nominally in [0, 1]; written as an
        8-bit grey image (see :func:`liff.plot.to_display`).
    keypoints : sequence of cv2.KeyPoint
        OpenCV pixel coordinates (centre of the top-left pixel at (0, 0)).
    descriptors : ndarray, shape (N, 128), uint8 or float
        On SIFT's integer scale, ``round(512 * d)`` in [0, 255], as cv2.SIFT and liff
        return them; N = len(keypoints). None is taken as no features (N must be 0).
    """

    name: str
    image: np.ndarray
    keypoints: Sequence[cv2.KeyPoint]
    descriptors: Optional[np.ndarray]


def describe_sizes(names: Sequence[str], shapes: Sequence[Tuple[int, ...]], limit: int = 3) -> str:
    """"a.png, b.png 320x240; c.png 256x256": the names of each size (height, width, ...),
    the most common size first, at most ``limit`` names a size (then "and N more")."""
    groups: dict = {}
    for name, shape in zip(names, shapes):
        groups.setdefault(tuple(shape[:2]), []).append(name)
    parts = []
    for (height, width), members in sorted(groups.items(), key=lambda item: -len(item[1])):
        shown = ", ".join(members[:limit]) + (f" and {len(members) - limit} more"
                                              if len(members) > limit else "")
        parts.append(f"{shown} {width}x{height}")
    return "; ".join(parts)


def write_database(
    database_path: PathLike,
    image_dir: PathLike,
    images: Sequence[FeatureImage],
    focal: Optional[float] = None,
    principal_point: Optional[Tuple[float, float]] = None,
) -> List[int]:
    """Writes images (as PNGs) and their features into a new COLMAP database.

    All images share one camera: SIMPLE_PINHOLE with the given focal length (pixels)
    marked as a prior, or, without ``focal``, SIMPLE_RADIAL with COLMAP's default guess
    of 1.2 * max(width, height). ``principal_point`` is in OpenCV pixels (default: the
    image centre, ((U - 1) / 2, (V - 1) / 2)).

    Returns
    -------
    image_ids : list of int, in the order of ``images``

    Raises
    ------
    ValueError
        If the database already exists (COLMAP's matcher skips pairs it has already
        matched, so every run needs a fresh one), no images are given, names repeat or
        lack an image ending, images are not grey or BGR, sizes differ, features are
        malformed (see :func:`descriptors_to_colmap`), or an image cannot be written.
        Nothing is written to the database unless everything is valid.
    """
    database_path, image_dir = os.fspath(database_path), os.fspath(image_dir)
    if os.path.exists(database_path):
        raise ValueError(f"database '{database_path}' exists; each run needs a fresh one")
    if not images:
        raise ValueError("no images to write")
    names = [im.name for im in images]
    if len(set(names)) != len(names):
        raise ValueError(f"image names repeat: {names}")
    for name in names:
        if os.path.splitext(name)[1].lower() not in IMAGE_SUFFIXES:
            raise ValueError(f"image name '{name}' has no image ending; expected one of "
                             f"{', '.join(IMAGE_SUFFIXES)}")
    grey = [grey_uint8_image(im.image) for im in images]
    if len({g.shape for g in grey}) != 1:
        raise ValueError(f"images differ in size: {describe_sizes(names, [g.shape for g in grey])}; "
                         "expected one size (all images share one camera)")
    features = [(keypoints_to_colmap(im.keypoints), descriptors_to_colmap(im.descriptors, len(im.keypoints)))
                for im in images]  # validate everything before writing anything
    height, width = grey[0].shape
    cx, cy = principal_point if principal_point is not None else ((width - 1) / 2, (height - 1) / 2)
    if focal is None:
        camera = pycolmap.Camera.create_from_model_name(
            1, "SIMPLE_RADIAL", 1.2 * max(width, height), width, height)
        camera.params = [1.2 * max(width, height), cx + 0.5, cy + 0.5, 0.0]
    else:
        camera = pycolmap.Camera.create_from_model_name(1, "SIMPLE_PINHOLE", float(focal), width, height)
        camera.params = [float(focal), cx + 0.5, cy + 0.5]
        camera.has_prior_focal_length = True
    for im, g in zip(images, grey):  # before the database, so a failure leaves none behind
        with atomic_output(os.path.join(image_dir, im.name)) as partial:
            write_image(partial, g)
    with atomic_output(database_path) as partial:  # complete, or not there at all
        return _write_features(partial, camera, images, features)


def _write_features(database_path: str, camera, images, features) -> List[int]:
    """Writes the camera and every image's keypoints and descriptors into a new database."""
    ids = []
    with colmap_log():
        with pycolmap.Database.open(database_path) as db:
            camera_id = db.write_camera(camera)
            for im, (keypoints, descriptors) in zip(images, features):
                image_id = db.write_image(pycolmap.Image(name=im.name, camera_id=camera_id))
                db.write_keypoints(image_id, keypoints)
                db.write_descriptors(image_id, pycolmap.FeatureDescriptors(
                    pycolmap.FeatureExtractorType.SIFT, descriptors))
                ids.append(image_id)
    return ids


@contextmanager
def colmap_log(verbose: bool = False):
    """COLMAP's log (glog, on stderr) for the duration of a block: errors only unless
    ``verbose`` (its INFO and WARNING lines, hundreds per run, drown what liff prints)."""
    previous = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = 0 if verbose else 2
    try:
        yield
    finally:
        pycolmap.logging.minloglevel = previous


def require_database(database_path: PathLike) -> str:
    """The path as a string, if a database file is there; every step that opens a
    database checks it first (pycolmap's own error for a missing one is "No registered
    database factory succeeded").

    Raises
    ------
    ValueError
        If no file is at ``database_path``, naming it.
    """
    path = os.fspath(database_path)
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such COLMAP database; expected one written by write_database")
    return path
