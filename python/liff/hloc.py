"""Features and matches in hloc's files, for its matchers, triangulation and mapping.

hloc (Sarlin et al., "From Coarse to Fine", CVPR 2019; github.com/cvg/Hierarchical-
Localization) keeps features in one HDF5 file, a group per image named by the image's
path relative to its image folder, and matches in another, a group per pair. Layout, as
hloc's ``extract_features`` writes and ``utils/io.py`` reads them:

* features: ``keypoints`` (N, 2) float32, pixel (x, y) with pixel centres at integers
  (OpenCV's convention: hloc adds 0.5 when it hands them to COLMAP); ``scores`` (N,)
  float32; ``descriptors`` (D, N) float32, one column per keypoint; ``image_size`` (2,)
  int, (width, height); for DoG features also ``scales`` (N,) and ``oris`` (N,),
  COLMAP's scale and orientation (degrees). liff adds ``slopes`` (N,) float32, pixels
  per view step, which hloc ignores.
* matches: the group ``names_to_pair(name0, name1)`` = ``name0/name1`` with each name's
  ``/`` replaced by ``-``, holding ``matches0`` (N0,) int32, the index in image 1 of
  each keypoint of image 0 or -1, and ``matching_scores0`` (N0,) float32.

A light field's features are its centre view's: write the centre view as the image hloc
(and COLMAP) is given, under the same name.
"""

from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from typing import Iterator, List, Optional, Sequence

import cv2
import numpy as np

from .colmap import grey_uint8_image, keypoints_to_colmap
from .io.images import write_image
from .keypoint_rows import keypoint_slopes
from .outputs import atomic_output


def names_to_pair(name0: str, name1: str) -> str:
    """hloc's key of the pair (name0, name1) in a matches file."""
    return "/".join((name0.replace("/", "-"), name1.replace("/", "-")))


def _write_group(path, key: str, what: str, datasets: dict, overwrite: bool) -> None:
    """Writes ``datasets`` as the group ``key`` of the HDF5 file ``path`` (made if
    missing); an existing group is replaced with ``overwrite``, else a ValueError."""
    import h5py  # (a dependency of liff)

    with h5py.File(path, "a") as f:
        if key in f:
            if not overwrite:
                raise ValueError(f"{os.fspath(path)} already holds {what} {key!r}; expected a "
                                 "new one, or overwrite=True")
            del f[key]
        group = f.create_group(key)
        for name, data in datasets.items():
            group.create_dataset(name, data=data)


def _check_name(name: str) -> str:
    if not isinstance(name, str) or not name or name.startswith("/") or "//" in name:
        raise ValueError(f"image name {name!r}; expected a relative path such as 'scene/0001.png'")
    return name


def write_features(path: "os.PathLike", name: str, keypoints: Sequence[cv2.KeyPoint],
                   descriptors: Optional[np.ndarray], image_size, overwrite: bool = False) -> None:
    """Adds one light field's features to the hloc features file ``path`` (made if missing).

    Parameters
    ----------
    path : path-like
        The HDF5 features file (``feats-*.h5`` in hloc's outputs).
    name : str
        The image's name relative to the image folder given to hloc (its centre view).
    keypoints : sequence of cv2.KeyPoint
        From :class:`liff.LiFF`, in centre-view pixels; their slopes go to ``slopes``.
    descriptors : ndarray, shape (N, D), or None when N == 0
        As ``detectAndCompute`` returns them; stored as float32 (D, N).
    image_size : (width, height) of the centre view, pixels.
    overwrite : bool
        Replace a group of the same name; otherwise that is a ValueError.

    Raises
    ------
    ValueError
        For a name that is not a relative path, descriptors whose rows do not match the
        keypoints, or an existing group (without ``overwrite``).
    """
    _check_name(name)
    n = len(keypoints)
    if descriptors is None:
        descriptors = np.zeros((0, 128), np.float32)
    descriptors = np.asarray(descriptors)
    if descriptors.ndim != 2 or descriptors.shape[0] != n:
        raise ValueError(f"descriptors of shape {descriptors.shape}; expected ({n}, D), one "
                         "row per keypoint")
    width, height = (int(v) for v in image_size)
    colmap = keypoints_to_colmap(keypoints)  # (x + 0.5, y + 0.5, scale, orientation)
    _write_group(path, name, "features of", {
        "keypoints": (colmap[:, :2] - 0.5).astype(np.float32),
        "scores": np.array([k.response for k in keypoints], np.float32),
        "descriptors": descriptors.astype(np.float32).T,
        "image_size": np.array([width, height]),
        "scales": colmap[:, 2].astype(np.float32),
        "oris": np.degrees(colmap[:, 3]).astype(np.float32),
        "slopes": keypoint_slopes(keypoints).astype(np.float32),
    }, overwrite)


def write_matches(path: "os.PathLike", name0: str, name1: str, matches: Sequence[cv2.DMatch],
                  num_keypoints0: int, overwrite: bool = False) -> None:
    """Adds the matches of one pair to the hloc matches file ``path`` (made if missing).

    Parameters
    ----------
    path : path-like
        The HDF5 matches file.
    name0, name1 : str
        The two images' names, as in the features file.
    matches : sequence of cv2.DMatch
        ``queryIdx`` in image 0, ``trainIdx`` in image 1 (as from ``BFMatcher.match``
        or liff.matching); each query keypoint at most once.
    num_keypoints0 : int
        Keypoints of image 0 (the length of ``matches0``).
    overwrite : bool
        Replace the pair's group; otherwise an existing pair is a ValueError.

    Notes
    -----
    ``matching_scores0`` is 1 / (1 + distance) for a match (higher is better, as hloc's
    scores are), 0 elsewhere.
    """
    _check_name(name0)
    _check_name(name1)
    matches0 = np.full(int(num_keypoints0), -1, np.int32)
    scores0 = np.zeros(int(num_keypoints0), np.float32)
    for m in matches:
        if not 0 <= m.queryIdx < num_keypoints0:
            raise ValueError(f"match queryIdx {m.queryIdx}; expected in [0, {num_keypoints0})")
        if matches0[m.queryIdx] != -1:
            raise ValueError(f"keypoint {m.queryIdx} of {name0!r} matched twice; expected "
                             "each at most once")
        matches0[m.queryIdx] = m.trainIdx
        scores0[m.queryIdx] = 1.0 / (1.0 + m.distance)
    _write_group(path, names_to_pair(name0, name1), "the pair",
                 {"matches0": matches0, "matching_scores0": scores0}, overwrite)


def image_name(feature_path: "os.PathLike") -> str:
    """The image name under which a liff feature file's light field goes into hloc's
    files (and whose centre view :func:`add_feature_files` writes): ``feats/pose00.npz``
    -> ``pose00.png``."""
    return os.path.splitext(os.path.basename(os.fspath(feature_path)))[0] + ".png"


@contextmanager
def updated(path: "os.PathLike") -> Iterator[str]:
    """Yields a temporary copy of the HDF5 file ``path`` (an empty name if it does not
    exist) to add groups to; it replaces ``path`` when the block ends without an
    exception (a run killed midway leaves the old file)."""
    with atomic_output(path) as partial:
        if os.path.exists(path):
            shutil.copyfile(path, partial)
        yield partial


def add_feature_files(path: "os.PathLike", feature_paths: Sequence["os.PathLike"],
                      image_dir: Optional["os.PathLike"] = None) -> List[str]:
    """Adds liff feature files (``.npz`` from ``liff detect``) to the hloc features file
    ``path``, each as the group :func:`image_name` (replaced if there; other groups are
    kept), and with ``image_dir`` writes each centre view there under that name (grey
    8-bit PNG, as COLMAP reads it), the image folder hloc's triangulation and
    reconstruction are given.

    Parameters
    ----------
    path : path-like
        The HDF5 features file; made if missing, else updated in a copy that replaces it.
    feature_paths : sequence of path-like
        Feature files; their names must differ.
    image_dir : path-like, optional
        Where to write the centre views.

    Returns
    -------
    names : list of str
        The image names, in the order of ``feature_paths``.

    Raises
    ------
    ValueError
        For two feature files of one name, or a file that is not a liff feature file
        with its centre view.
    """
    from .feature_file import load_features

    names = [image_name(p) for p in feature_paths]
    if len(set(names)) != len(names):
        raise ValueError(f"feature files give repeated image names {sorted(names)}; expected "
                         "distinct file names")
    with updated(path) as partial:
        for name, feature_path in zip(names, feature_paths):
            features = load_features(feature_path)
            view = features.centre_view
            if view is None:  # (its size is the image_size hloc needs)
                raise ValueError(f"{os.fspath(feature_path)}: holds no centre view; expected a "
                                 "feature file from liff detect")
            write_features(partial, name, features.keypoints, features.descriptors,
                           (view.shape[1], view.shape[0]), overwrite=True)
            if image_dir is not None:
                with atomic_output(os.path.join(image_dir, name)) as image:
                    write_image(image, grey_uint8_image(view))
    return names
