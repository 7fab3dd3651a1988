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
  each keypoint of image 0 or -1, and ``matching_scores0`` (N0,) float32 in [0, 1]
  (:func:`match_scores`). hloc finds a pair in either order; so does
  :func:`write_matches`.

Match files index keypoints, so they hold only as long as the features they were made
from. liff marks both (HDF5 attributes, which hloc's readers do not look at): a
features group's ``liff_digest`` is :func:`~liff.feature_file.content_digest` of its
datasets, and a pair group made with the digests of its two images' groups holds them
as ``liff_features0`` and ``liff_features1`` (and the names as ``liff_name0``,
``liff_name1``). Features of a name that differ from those written before are not
replaced without ``overwrite`` (:func:`add_feature_files` says which names changed),
and :func:`write_matches` refuses to add to a match file whose pairs of the same
images were made against other features.

A light field's features are its centre view's: write the centre view as the image hloc
(and COLMAP) is given, under the same name. :func:`add_feature_files` gives the keypoints
in that view's pixels (view (T // 2, S // 2); for even view counts LiFF's centre frame
lies between views, :func:`liff.feature_file.keypoints_in_centre_view`); to
:func:`write_features` give them so.
"""

from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from typing import Iterator, List, NamedTuple, Optional, Sequence, Tuple

import cv2
import numpy as np

from ._paths import PathLike
from .colmap import grey_uint8_image, keypoints_to_colmap
from .feature_file import content_digest, load_features
from .io.images import write_image
from .keypoint_rows import keypoint_slopes
from .outputs import atomic_output


def names_to_pair(name0: str, name1: str) -> str:
    """hloc's key of the pair (name0, name1) in a matches file."""
    return "/".join((name0.replace("/", "-"), name1.replace("/", "-")))


#: HDF5 attribute of a features group: the digest of its datasets
DIGEST_ATTR = "liff_digest"
#: HDF5 attributes of a pair group: its images' names and the digests of their features
PAIR_NAME_ATTRS = ("liff_name0", "liff_name1")
PAIR_DIGEST_ATTRS = ("liff_features0", "liff_features1")


def _write_group(path, key: str, what: str, datasets: dict, overwrite: bool,
                 attrs: Optional[dict] = None, aliases: Sequence[str] = ()) -> None:
    """Writes ``datasets`` (and the HDF5 attributes ``attrs``) as the group ``key`` of
    the HDF5 file ``path`` (made if missing); an existing group, under ``key`` or one of
    ``aliases`` (other keys of the same thing), is replaced with ``overwrite``, else a
    ValueError."""
    import h5py  # (a dependency of liff)

    with h5py.File(path, "a") as f:
        for existing in dict.fromkeys((key,) + tuple(aliases)):
            if existing not in f:
                continue
            if not overwrite:
                raise ValueError(f"{os.fspath(path)} already holds {what} {existing!r}; "
                                 "expected a new one, or overwrite=True")
            del f[existing]
        group = f.create_group(key)
        for name, data in datasets.items():
            group.create_dataset(name, data=data)
        group.attrs.update(attrs or {})


def _check_name(name: str) -> str:
    """Raises ValueError unless ``name`` is a relative image path that hloc's files and
    its pairs.txt (read with ``str.split()``) hold as it is."""
    if (not isinstance(name, str) or not name or name.startswith("/") or name.endswith("/")
            or "//" in name or "\\" in name):
        raise ValueError(f"image name {name!r}; expected a relative path with '/' between "
                         "folders and a file name at the end, such as 'scene/0001.png'")
    if any(c.isspace() for c in name):
        raise ValueError(f"image name {name!r} holds whitespace; expected a name without spaces, "
                         "tabs or newlines (hloc reads pairs.txt split at whitespace)")
    if any(part in (".", "..") for part in name.split("/")):
        raise ValueError(f"image name {name!r} holds a '.' or '..' part; expected a path inside "
                         "the image folder such as 'scene/0001.png'")
    return name


def feature_datasets(keypoints: Sequence[cv2.KeyPoint], descriptors: Optional[np.ndarray],
                     image_size) -> dict:
    """The datasets of one image's group in an hloc features file (see the module
    docstring), as :func:`write_features` writes them.

    Parameters
    ----------
    keypoints : sequence of cv2.KeyPoint
        In the pixels of the image hloc is given; their slopes go to ``slopes``.
    descriptors : ndarray, shape (N, D), or None when N == 0
        As ``detectAndCompute`` returns them; stored as float32 (D, N).
    image_size : (width, height) of the image, pixels.

    Returns
    -------
    datasets : dict of str to ndarray

    Raises
    ------
    ValueError
        For descriptors whose rows do not match the keypoints, keypoints that are not
        finite, or an image_size that is not two whole pixel counts > 0.
    """
    n = len(keypoints)
    if descriptors is None:
        descriptors = np.zeros((0, 128), np.float32)
    descriptors = np.asarray(descriptors)
    if descriptors.ndim != 2 or descriptors.shape[0] != n:
        raise ValueError(f"descriptors of shape {descriptors.shape}; expected ({n}, D), one "
                         "row per keypoint")
    try:
        size = np.asarray(image_size, np.float64)
    except (TypeError, ValueError):
        size = np.zeros(0)
    if (size.shape != (2,) or not np.all(np.isfinite(size)) or np.any(size <= 0)
            or np.any(size != np.round(size))):
        raise ValueError(f"image_size {image_size!r}; expected (width, height), two whole "
                         "pixel counts > 0")
    width, height = (int(v) for v in size)
    colmap = keypoints_to_colmap(keypoints)  # (x + 0.5, y + 0.5, scale, orientation)
    bad = np.flatnonzero(~np.isfinite(colmap).all(axis=1)) if n else np.zeros(0, int)
    if len(bad):
        raise ValueError(f"keypoint {bad[0]} at {keypoints[bad[0]].pt} (size "
                         f"{keypoints[bad[0]].size}); expected finite coordinates and sizes")
    return {
        "keypoints": (colmap[:, :2] - 0.5).astype(np.float32),
        "scores": np.array([k.response for k in keypoints], np.float32),
        "descriptors": descriptors.astype(np.float32).T,
        "image_size": np.array([width, height], np.int64),
        "scales": colmap[:, 2].astype(np.float32),
        "oris": np.degrees(colmap[:, 3]).astype(np.float32),
        "slopes": keypoint_slopes(keypoints).astype(np.float32),
    }


def write_features(path: "os.PathLike", name: str, keypoints: Sequence[cv2.KeyPoint],
                   descriptors: Optional[np.ndarray], image_size, overwrite: bool = False) -> str:
    """Adds one light field's features to the hloc features file ``path`` (made if missing).

    Parameters
    ----------
    path : path-like
        The HDF5 features file (``feats-*.h5`` in hloc's outputs).
    name : str
        The image's name relative to the image folder given to hloc (its centre view).
    keypoints : sequence of cv2.KeyPoint
        From :class:`liff.LiFF`, in the pixels of that image; their slopes go to ``slopes``.
    descriptors : ndarray, shape (N, D), or None when N == 0
        As ``detectAndCompute`` returns them; stored as float32 (D, N).
    image_size : (width, height) of the centre view, pixels.
    overwrite : bool
        Replace a group of the same name; otherwise that is a ValueError.

    Returns
    -------
    digest : str
        The group's digest (its attribute ``liff_digest``), to give
        :func:`write_matches` with this image's matches.

    Raises
    ------
    ValueError
        For a name that is not a relative path, descriptors whose rows do not match the
        keypoints, or an existing group (without ``overwrite``).
    """
    _check_name(name)
    check_file_kind(path, "features")
    return _write_features_group(path, name, feature_datasets(keypoints, descriptors, image_size),
                                 overwrite)


def _write_features_group(path, name: str, datasets: dict, overwrite: bool) -> str:
    """Writes a features group with its digest attribute; returns the digest. A name
    that is a folder of other images' names, or lies under another image's name, is a
    ValueError (even with ``overwrite``: it would replace or nest in other images)."""
    _refuse_nesting(path, name)
    digest = content_digest(datasets)
    _write_group(path, name, "features of", datasets, overwrite, {DIGEST_ATTR: digest})
    return digest


def _refuse_nesting(path, name: str) -> None:
    """Raises ValueError if the features file ``path`` has ``name`` as a folder of other
    images' groups, or an image's group at a folder of ``name``."""
    if not os.path.exists(path):
        return
    import h5py

    with h5py.File(path, "r") as f:
        group = f.get(name)
        if isinstance(group, h5py.Group) and "keypoints" not in group:
            inside = []
            group.visititems(lambda key, item: inside.append(f"{name}/{key}")
                             if isinstance(item, h5py.Group) and "keypoints" in item else None)
            raise ValueError(f"{os.fspath(path)}: {name!r} is a folder of other images' names "
                             f"there ({', '.join(inside[:3]) or 'no features'}); expected an "
                             "image name that is not the folder of others")
        parts = name.split("/")
        for end in range(1, len(parts)):
            folder = "/".join(parts[:end])
            if isinstance(f.get(folder), h5py.Group) and "keypoints" in f[folder]:
                raise ValueError(f"{os.fspath(path)}: {folder!r} holds an image's features; "
                                 f"expected {name!r} not under another image's name")


def features_digest(path: "os.PathLike", name: str) -> str:
    """The digest of the features of ``name`` in the hloc features file ``path``: its
    ``liff_digest`` attribute, or for a group written without one (by hloc, or an older
    liff) the digest of its datasets.

    Raises
    ------
    ValueError
        If ``path`` holds no features of ``name``.
    """
    import h5py

    with h5py.File(path, "r") as f:
        group = f.get(name)
        if not isinstance(group, h5py.Group) or "keypoints" not in group:
            raise ValueError(f"{os.fspath(path)} holds no features of {name!r}; expected a "
                             "name written by write_features or liff detect --hloc")
        return _group_digest(group)


def check_file_kind(path: PathLike, kind: str) -> None:
    """Raises ValueError if the HDF5 file ``path`` (when it exists) holds groups of the
    other kind than ``kind``: pair groups (holding ``matches0``) in what should be a
    features file, or image groups (holding ``keypoints``) in what should be a matches
    file; adding to it would give a file that hloc's readers fail on.

    Parameters
    ----------
    path : path-like
        An HDF5 file, or a path where none exists yet (nothing to check).
    kind : {"features", "matches"}
        What ``path`` is given as.
    """
    if kind not in ("features", "matches"):
        raise ValueError(f"kind {kind!r}; expected 'features' or 'matches'")
    if not os.path.exists(path):
        return
    import h5py

    other, marker = ("matches", "matches0") if kind == "features" else ("features", "keypoints")
    found = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda key, item: found.append(key) if isinstance(item, h5py.Group)
                     and marker in item else None)
    if found:
        raise ValueError(f"{os.fspath(path)} is an hloc {other} file (it holds "
                         f"{', '.join(repr(k) for k in found[:3])}"
                         f"{', ...' if len(found) > 3 else ''}, groups with {marker!r}); "
                         f"expected an hloc {kind} file, or a new path")


def features_in(path, names: Sequence[str]) -> List[Tuple[str, int]]:
    """The (digest, keypoint count) of the features of each of ``names`` in the hloc
    features file ``path``.

    Raises
    ------
    ValueError
        If ``path`` does not exist, is a matches file, or holds no features of some of
        ``names`` (naming them).
    """
    import h5py

    if not os.path.exists(path):
        raise ValueError(f"features file {os.fspath(path)} does not exist; expected the hloc "
                         "features file the matches index (liff detect --hloc writes it)")
    if os.path.isdir(path) or not h5py.is_hdf5(path):
        raise ValueError(f"features file {os.fspath(path)} is "
                         f"{'a folder' if os.path.isdir(path) else 'not an HDF5 file'}; expected "
                         "the hloc features file the matches index (liff detect --hloc writes it)")
    check_file_kind(path, "features")
    with h5py.File(path, "r") as f:
        groups = [f.get(name) for name in names]
        missing = [name for name, group in zip(names, groups)
                   if not isinstance(group, h5py.Group) or "keypoints" not in group]
        if missing:
            raise ValueError(f"{os.fspath(path)} holds no features of {', '.join(map(repr, missing))}; "
                             "expected the features file those images were exported to (liff "
                             "detect --hloc FEATS.h5 on their feature files)")
        return [(_group_digest(group), len(group["keypoints"])) for group in groups]


def _group_digest(group) -> str:
    """A features group's digest (see :func:`features_digest`)."""
    if DIGEST_ATTR in group.attrs:
        return str(group.attrs[DIGEST_ATTR])
    return content_digest({key: group[key][()] for key in group if key != DIGEST_ATTR})


#: the norm of SIFT's descriptors (cv2.SIFT's and liff's, float or uint8): 512
DESCRIPTOR_NORM = 512.0


def match_scores(distances) -> np.ndarray:
    """hloc's ``matching_scores0`` for L2 descriptor distances: the cosine similarity of
    two descriptors of SIFT's norm 512, ``1 - d^2 / (2 * 512^2)``, clipped to [0, 1]; what
    hloc's nearest-neighbour matcher scores normalised descriptors with (their dot
    product), so that hloc's ``min_match_score`` thresholds mean the same.

    Parameters
    ----------
    distances : array-like of float
        L2 distances (``cv2.DMatch.distance``), finite and at least 0.

    Returns
    -------
    scores : ndarray of float32
    """
    d = np.asarray(distances, np.float64) / DESCRIPTOR_NORM
    return np.clip(1.0 - d * d / 2.0, 0.0, 1.0).astype(np.float32)


def write_matches(path: PathLike, name0: str, name1: str, matches: Sequence[cv2.DMatch],
                  num_keypoints0: int, num_keypoints1: int, overwrite: bool = False,
                  digests: Optional[Tuple[str, str]] = None,
                  features: Optional["os.PathLike"] = None) -> None:
    """Adds the matches of one pair to the hloc matches file ``path`` (made if missing).

    Parameters
    ----------
    path : path-like
        The HDF5 matches file.
    name0, name1 : str
        The two images' names, as in the features file.
    matches : sequence of cv2.DMatch
        ``queryIdx`` in image 0, ``trainIdx`` in image 1 (as from ``BFMatcher.match``
        or liff.matching), ``distance`` the descriptors' L2 distance; each query
        keypoint at most once.
    num_keypoints0, num_keypoints1 : int
        Keypoints of image 0 (the length of ``matches0``) and of image 1.
    overwrite : bool
        Replace the pair's group, in either order (hloc's ``find_pair`` finds
        ``name1/name0`` too); otherwise an existing pair is a ValueError.
    digests : (str, str), optional
        The digests of the two images' features (:func:`write_features` returns them,
        :func:`features_digest` reads them back), recorded with the pair; the file's
        other pairs of either image must have been made against the same features.
    features : path-like, optional
        The hloc features file the matches index: it must hold both names, with these
        ``digests`` (when given; otherwise its digests are recorded) and
        ``num_keypoints0``/``num_keypoints1`` keypoints.

    Raises
    ------
    ValueError
        For a bad name, a match whose indices are outside the keypoints or whose
        distance is negative or not finite, an existing pair (without ``overwrite``),
        or pairs of ``name0`` or ``name1`` in the file that were made against other
        features (their indices would not be those of the features now); with
        ``features``, names it holds no features of, or features there whose digest or
        keypoint count is not that given (stale: the matches would index other keypoints).
        Also for a pair of one image with itself, or a features file given as ``path``.

    Notes
    -----
    ``matching_scores0`` is :func:`match_scores` of the distance for a match (the
    descriptors' cosine similarity, in [0, 1]), 0 elsewhere.
    """
    check_pair_names(name0, name1)
    counts = []
    for what, count in (("num_keypoints0", num_keypoints0), ("num_keypoints1", num_keypoints1)):
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
            raise ValueError(f"{what} {count!r}; expected a keypoint count, an int >= 0")
        counts.append(int(count))
    if digests is not None and (isinstance(digests, str) or len(digests) != 2
                                or not all(isinstance(d, str) for d in digests)):
        raise ValueError(f"digests {digests!r}; expected two strings, the digests of "
                         f"{name0!r}'s and {name1!r}'s features (write_features returns them)")
    check_file_kind(path, "matches")
    if features is not None:
        digests = _check_features(features, (name0, name1), digests, counts)
    matches0 = np.full(counts[0], -1, np.int32)
    distances = np.zeros(counts[0], np.float64)
    for m in matches:
        if not isinstance(m, cv2.DMatch):
            raise TypeError(f"matches holds {m!r}; expected cv2.DMatch objects (queryIdx, "
                            "trainIdx, distance)")
        if not 0 <= m.queryIdx < counts[0]:
            raise ValueError(f"match queryIdx {m.queryIdx}; expected in [0, {counts[0]}), a "
                             f"keypoint of {name0!r}")
        if not 0 <= m.trainIdx < counts[1]:
            raise ValueError(f"match trainIdx {m.trainIdx}; expected in [0, {counts[1]}), a "
                             f"keypoint of {name1!r}")
        if not (np.isfinite(m.distance) and m.distance >= 0):
            raise ValueError(f"match distance {m.distance}; expected a descriptor distance, "
                             "finite and >= 0")
        if matches0[m.queryIdx] != -1:
            raise ValueError(f"keypoint {m.queryIdx} of {name0!r} matched twice; expected "
                             "each at most once")
        matches0[m.queryIdx] = m.trainIdx
        distances[m.queryIdx] = m.distance
    scores0 = np.where(matches0 != -1, match_scores(distances), 0).astype(np.float32)
    key, reverse = names_to_pair(name0, name1), names_to_pair(name1, name0)
    attrs = {}
    if digests is not None:
        attrs = dict(zip(PAIR_NAME_ATTRS + PAIR_DIGEST_ATTRS, (name0, name1) + tuple(digests)))
        _refuse_stale_pairs(path, {name0: digests[0], name1: digests[1]}, {key, reverse},
                            features)
    _write_group(path, key, "the pair", {"matches0": matches0, "matching_scores0": scores0},
                 overwrite, attrs, aliases=(reverse,))


def check_pair_names(name0: str, name1: str) -> None:
    """Raises ValueError unless ``name0`` and ``name1`` are image names hloc's files hold
    (see :func:`write_features`) and differ (a pair of an image with itself is no pair)."""
    _check_name(name0)
    _check_name(name1)
    if name0 == name1:
        raise ValueError(f"both images are named {name0!r}; expected two images of different "
                         "names (a pair of an image with itself; two feature files of the same "
                         "file name go into hloc's files under the same name)")


def _check_features(features, names: Sequence[str], digests: Optional[Sequence[str]],
                    counts: Sequence[int]) -> Tuple[str, str]:
    """The digests of ``names``' features in the hloc features file ``features``;
    ValueError where they are not ``digests`` (when given) or have not ``counts``
    keypoints: the matches would index other keypoints than the file's."""
    found = features_in(features, names)
    stale = []
    for i, (name, (digest, count)) in enumerate(zip(names, found)):
        if count != counts[i]:
            stale.append(f"{name} ({count} keypoints there, {counts[i]} matched)")
        elif digests is not None and digest != digests[i]:
            stale.append(f"{name} (other features there)")
    if stale:
        raise ValueError(f"{os.fspath(features)} holds other features of {', '.join(stale)} "
                         "than those matched: the matches would index keypoints that are not "
                         "there (stale); expected the features file they were exported to: "
                         "re-run liff detect --hloc on their feature files, or give the right "
                         "features file")
    return found[0][0], found[1][0]


def _pair_groups(f) -> Iterator:
    """The pair groups (two levels down, holding ``matches0``) of an open matches file."""
    for first in f.values():
        for group in getattr(first, "values", lambda: ())():
            if hasattr(group, "keys") and "matches0" in group:
                yield group


def _refuse_stale_pairs(path, digests: dict, replaced: set, features=None) -> None:
    """Raises ValueError if the matches file ``path`` holds a pair (other than the groups
    ``replaced``) matched against other features than the current ones: those of
    ``digests`` (name -> digest) and, with the features file ``features``, those it holds
    of every image a recorded pair joins (a re-detection of one image leaves every pair
    of it stale, whichever pair is added now)."""
    if not os.path.exists(path):
        return
    import h5py

    recorded = []  # (pair, image name, digest it was matched against)
    with h5py.File(path, "r") as f:
        for group in _pair_groups(f):
            pair = group.name.lstrip("/")
            if pair in replaced:
                continue
            for name_attr, digest_attr in zip(PAIR_NAME_ATTRS, PAIR_DIGEST_ATTRS):
                if name_attr in group.attrs and digest_attr in group.attrs:
                    recorded.append((pair, str(group.attrs[name_attr]),
                                     str(group.attrs[digest_attr])))
    current = dict(digests)
    if features is not None and recorded:
        with h5py.File(features, "r") as f:
            for _, name, _ in recorded:
                if name not in current:
                    group = f.get(name)
                    current[name] = (_group_digest(group) if isinstance(group, h5py.Group)
                                     and "keypoints" in group else None)
    stale = sorted({f"{pair} ({name} changed)" for pair, name, digest in recorded
                    if name in current and current[name] != digest})
    if stale:
        raise ValueError(f"{os.fspath(path)}: its pairs {', '.join(stale)} were matched against "
                         "other features than the current ones (the features were replaced "
                         "since, so their indices are stale); expected a matches file made "
                         "against the current features: match into a new file, or remove "
                         "that one and match every pair again")


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


class Added(NamedTuple):
    """What :func:`add_feature_files` did: the image names, in the order of the feature
    files, those of them whose features were replaced by other ones (matches made from
    the old ones are stale), and the paths of the files in the image folder it replaced
    that were not images exported with the features file (``overwrite``)."""

    names: List[str]
    replaced: List[str]
    replaced_images: List[str] = []


def feature_file_group(features) -> Tuple[dict, np.ndarray]:
    """The hloc datasets of a liff feature file's light field (:func:`feature_datasets`)
    and its centre view, the image they go with: the keypoints in that view's pixels
    (:meth:`~liff.feature_file.Features.centre_view_keypoints`; for even view counts
    the centre frame lies between views).

    Parameters
    ----------
    features : liff.feature_file.Features
        As :func:`liff.feature_file.load_features` reads them, with a centre view.

    Returns
    -------
    datasets : dict of str to ndarray
    view : ndarray
        The centre view.

    Raises
    ------
    ValueError
        If the features hold no centre view.
    """
    view = features.centre_view
    if view is None:  # (its size is the image_size hloc needs)
        raise ValueError("holds no centre view; expected a feature file from liff detect")
    return feature_datasets(features.centre_view_keypoints(), features.descriptors,
                            (view.shape[1], view.shape[0])), view


def check_export(path: "os.PathLike", feature_paths: Sequence["os.PathLike"],
                 image_dir: Optional["os.PathLike"] = None, overwrite: bool = False) -> List[str]:
    """What :func:`add_feature_files` checks before it reads the feature files, so that a
    command can check it before it writes them: ``path`` is no matches file, the image
    names (:func:`image_name`) are distinct names hloc's files hold, and no file at
    ``image_dir``/name is an image that ``path`` holds no features of (an image liff did
    not export there; replaced only with ``overwrite``).

    Parameters
    ----------
    path : path-like
        The hloc features file (it need not exist).
    feature_paths : sequence of path-like
        The feature files to add (they need not exist yet).
    image_dir : path-like, optional
        Where the centre views go.
    overwrite : bool
        Replace unrelated files in ``image_dir``.

    Returns
    -------
    names : list of str
        The image names.

    Raises
    ------
    ValueError
        For any of those, naming the file or names.
    """

    check_file_kind(path, "features")
    names = [image_name(p) for p in feature_paths]
    if len(set(names)) != len(names):
        raise ValueError(f"feature files give repeated image names {sorted(names)}; expected "
                         "distinct file names")
    for name, feature_path in zip(names, feature_paths):
        try:
            _check_name(name)
        except ValueError as error:
            raise ValueError(f"{os.fspath(feature_path)}: {error}") from None
    if image_dir is not None and not overwrite:
        foreign = foreign_images(path, names, image_dir)
        if foreign:
            raise ValueError(f"{', '.join(foreign)} exist(s) and {os.fspath(path)} holds no "
                             "features of them (not images liff exported with it); expected "
                             "new image names in the --hloc-images folder, or --overwrite "
                             "(overwrite=True) to replace them")
    return names


def foreign_images(path: "os.PathLike", names: Sequence[str], image_dir: "os.PathLike") -> List[str]:
    """The paths ``image_dir``/name of ``names`` where a file exists that the features
    file ``path`` holds no features of: not an image liff exported with it (another
    features file's, or the user's own)."""
    import h5py

    held = set()
    if os.path.exists(path):
        with h5py.File(path, "r") as f:
            held = {name for name in names if name in f}
    return [os.path.join(image_dir, name) for name in names if name not in held
            and os.path.lexists(os.path.join(image_dir, name))]


def add_feature_files(path: "os.PathLike", feature_paths: Sequence["os.PathLike"],
                      image_dir: Optional["os.PathLike"] = None, overwrite: bool = False) -> Added:
    """Adds liff feature files (``.npz`` from ``liff detect``) to the hloc features file
    ``path``, each as the group :func:`image_name` (other groups are kept), and with
    ``image_dir`` writes each centre view there under that name (grey 8-bit PNG, as
    COLMAP reads it), the image folder hloc's triangulation and reconstruction are given.

    A group already there with the same content is kept; one with other content (new
    settings, or another capture of the same file name) is replaced only with
    ``overwrite``, since match files made from it index its old keypoints.

    Parameters
    ----------
    path : path-like
        The HDF5 features file; made if missing, else updated in a copy that replaces it.
    feature_paths : sequence of path-like
        Feature files; their names must differ.
    image_dir : path-like, optional
        Where to write the centre views.
    overwrite : bool
        Replace groups whose content differs.

    Returns
    -------
    added : Added
        The image names, those whose features were replaced, and the files of
        ``image_dir`` replaced that were not images exported with ``path`` (only with
        ``overwrite``: else refused).

    Raises
    ------
    ValueError
        For what :func:`check_export` refuses, a file that is not a liff feature file
        with its centre view, or groups of other content (without ``overwrite``); nothing
        is written then.
    """
    import h5py

    names = check_export(path, feature_paths, image_dir, overwrite)
    groups = []
    for feature_path in feature_paths:
        try:
            groups.append(feature_file_group(load_features(feature_path)))
        except ValueError as error:
            raise ValueError(f"{os.fspath(feature_path)}: {error}") from None
    replaced = []
    if os.path.exists(path):
        with h5py.File(path, "r") as f:
            replaced = [name for name, (datasets, _) in zip(names, groups)
                        if name in f and _group_digest(f[name]) != content_digest(datasets)]
    if replaced and not overwrite:
        raise ValueError(f"{os.fspath(path)} holds other features of {', '.join(replaced)} "
                         "(other settings, or another capture of the same name); replacing "
                         "them would leave the matches made from them stale; expected the "
                         "same features, or --overwrite (overwrite=True) to replace them and "
                         "then match those images again; nothing was written to it"
                         + (" or to the images folder" if image_dir is not None else ""))
    foreign = [] if image_dir is None else foreign_images(path, names, image_dir)
    with updated(path) as partial:
        for name, (datasets, view) in zip(names, groups):
            _write_features_group(partial, name, datasets, True)
            if image_dir is not None:
                with atomic_output(os.path.join(image_dir, name)) as image:
                    write_image(image, grey_uint8_image(view))
    return Added(names, replaced, foreign)
