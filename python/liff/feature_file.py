"""Features on disk: one ``.npz`` per light field, written by ``liff detect``.

Arrays in the file:

============== ============== ==================================================
``keypoints``  (N, 6) float64 x, y, size, angle, response, octave (cv2.KeyPoint
                              fields; x, y in the centre frame's pixels, OpenCV
                              centres: for even view counts ``centre_view``'s
                              frame differs, :func:`keypoints_in_centre_view`)
``slopes``     (N,) float64   slope of each feature, pixels per view step
``descriptors`` (N, 128)      float32 or uint8 (SIFT integers in [0, 255])
``centre_view`` (V, U[, 3])   uint8, the picture the features are drawn on
``meta``       str            JSON: how the file was made (source, reader options,
                              preprocessing, detector parameters, liff version) and
                              the light field's shape; :func:`read_meta` reads it alone
``digest``     str            ``sha256:<hex>`` of the other arrays (name, dtype,
                              shape and bytes; :func:`content_digest`), so that a
                              file whose arrays were changed is told from the one
                              written (:func:`content_problem`, :func:`load_features`)
============== ============== ==================================================
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from dataclasses import dataclass, field
from typing import Optional, Tuple, Union

import cv2
import numpy as np

from ._paths import refuse_special, special_kind
from .keypoint_rows import SLOPE_SCALE, keypoint_slopes, keypoints_to_rows, rows_to_keypoints
from .plot import to_display

PathLike = Union[str, os.PathLike]
KEYPOINT_COLUMNS = ("x", "y", "size", "angle", "response", "octave")
_INT32 = np.iinfo(np.int32)
_FLOAT32_MAX = float(np.finfo(np.float32).max)
#: zlib level of the members of a feature file. Level 1 writes an Illum-size light
#: field's 5701 features in 0.066 s against numpy's savez_compressed (level 6) 0.347 s,
#: for a file 22% larger (benchmarks/batch.py; docs/BENCHMARKS.md, "Batches and Dask").
COMPRESSION_LEVEL = 1
#: the member holding the digest of the others
DIGEST_KEY = "digest"


@dataclass
class Features:
    """Keypoints (tuple of cv2.KeyPoint, slope in class_id), descriptors (N, 128),
    the centre view they were found on (uint8, or None) and free-form metadata."""

    keypoints: Tuple[cv2.KeyPoint, ...]
    descriptors: Optional[np.ndarray]
    centre_view: Optional[np.ndarray] = None
    meta: dict = field(default_factory=dict)

    @property
    def slopes(self) -> np.ndarray:
        return keypoint_slopes(self.keypoints)

    def centre_view_keypoints(self) -> Tuple[cv2.KeyPoint, ...]:
        """The keypoints in the pixels of :attr:`centre_view` (see
        :func:`keypoints_in_centre_view`), for the light field shape in ``meta``; as
        they are when ``meta`` holds no shape (files written before liff recorded it)."""
        shape = self.meta.get("shape")
        return tuple(self.keypoints) if shape is None else keypoints_in_centre_view(self.keypoints, shape)


def centre_view(light_field: np.ndarray) -> np.ndarray:
    """The view (T // 2, S // 2) of a (T, S, V, U[, C]) light field without its alpha
    channel (a 2-D or 3-D image is returned as is, minus alpha)."""
    lf = np.asarray(light_field)
    has_channels = lf.ndim in (3, 5)
    view = lf[lf.shape[0] // 2, lf.shape[1] // 2] if lf.ndim >= 4 else lf
    if has_channels and view.shape[-1] in (2, 4):
        view = view[..., :-1]
    if view.ndim == 3 and view.shape[-1] == 1:
        view = view[..., 0]
    return view


def keypoints_in_centre_view(keypoints, shape) -> Tuple[cv2.KeyPoint, ...]:
    """LiFF keypoints moved into the frame of the view :func:`centre_view` returns.

    LiFF gives positions in the centre frame ``(s_c, t_c) = ((S - 1) / 2, (T - 1) / 2)``
    (docs/CONVENTIONS.md), which for an even view count lies between views; a keypoint
    at ``(x, y)`` with slope ``m`` is seen in view ``(T // 2, S // 2)`` at
    ``(x - m (S // 2 - s_c), y - m (T // 2 - t_c))``, that is ``m / 2`` pixels off along
    each even axis. Exports and pictures that pair keypoints with that view's image use
    this.

    Parameters
    ----------
    keypoints : sequence of cv2.KeyPoint
        LiFF keypoints (slope in class_id).
    shape : sequence of int
        The light field's shape, (T, S, V, U[, C]); a 2-D or 3-D shape is one view.

    Returns
    -------
    keypoints : tuple of cv2.KeyPoint
        New keypoints, other fields unchanged; for odd view counts the keypoints given,
        untouched.
    """
    shape = tuple(int(v) for v in shape)
    rows_of_views, views = shape[:2] if len(shape) >= 4 else (1, 1)
    dt, ds = rows_of_views // 2 - (rows_of_views - 1) / 2, views // 2 - (views - 1) / 2
    if dt == 0 and ds == 0:
        return tuple(keypoints)
    rows = keypoints_to_rows(keypoints)
    slopes = keypoint_slopes(keypoints)
    rows[:, 0] -= slopes * ds
    rows[:, 1] -= slopes * dt
    return rows_to_keypoints(rows)


def save_features(path: PathLike, features: Features) -> None:
    """Writes ``features`` to ``path`` (.npz, compressed, read by ``np.load``); see the
    module docstring.

    Raises
    ------
    ValueError
        Naming the file: a keypoint that is not a cv2.KeyPoint, descriptors that are not
        an (N, 128) array of numbers, or not one descriptor row per keypoint.
    """
    try:
        rows = np.ascontiguousarray(keypoints_to_rows(features.keypoints)[:, :6])  # no class_id
    except TypeError as error:
        raise ValueError(f"{os.fspath(path)}: {error}") from None
    descriptors = features.descriptors
    if descriptors is None:
        descriptors = np.zeros((0, 128), np.float32)
    descriptors = np.asarray(descriptors)
    if descriptors.ndim != 2 or descriptors.shape[1] != 128 or descriptors.dtype.kind not in "biuf":
        raise ValueError(f"{os.fspath(path)}: descriptors of shape {descriptors.shape} and dtype "
                         f"{descriptors.dtype}; expected an (N, 128) array of numbers (float32 "
                         "or uint8), one row per keypoint")
    if len(descriptors) != len(rows):
        raise ValueError(f"{os.fspath(path)}: {len(rows)} keypoints but {len(descriptors)} "
                         "descriptors; expected one descriptor row per keypoint")
    arrays = dict(keypoints=rows, slopes=features.slopes, descriptors=descriptors,
                  meta=np.array(json.dumps(features.meta)))
    if features.centre_view is not None:
        arrays["centre_view"] = to_display(features.centre_view)
    arrays = {name: np.asanyarray(array) for name, array in arrays.items()}
    arrays[DIGEST_KEY] = np.array(content_digest(arrays))
    _write_npz(path, arrays)


def content_digest(arrays: dict) -> str:
    """``sha256:<hex>`` of a feature file's arrays but ``digest``: each one's name,
    dtype, shape and bytes, in name order."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        if name == DIGEST_KEY:
            continue
        array = np.asarray(arrays[name])
        digest.update(f"{name}:{array.dtype.str}:{array.shape};".encode())
        digest.update(array.tobytes())
    return "sha256:" + digest.hexdigest()


def content_problem(path: PathLike) -> Optional[str]:
    """Why the feature file ``path`` is not the one liff wrote (its arrays do not match
    the digest written with them, it has no digest, or an array cannot be read), or
    None when its content checks."""
    try:
        with np.load(os.fspath(path), allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except Exception as error:  # numpy/zipfile raise many kinds on a damaged file
        return f"its arrays cannot be read ({type(error).__name__}: {error})"
    return _digest_problem(arrays)


def _digest_problem(arrays: dict) -> Optional[str]:
    """Why ``arrays`` (a feature file's, read) do not check against their digest, or None."""
    if DIGEST_KEY not in arrays:
        return "it has no content digest (written by an older liff)"
    if str(arrays[DIGEST_KEY]) != content_digest(arrays):
        return "its arrays do not match the digest written with them (changed since)"
    return None


def _write_npz(path: PathLike, arrays: dict) -> None:
    """``arrays`` to ``path`` as numpy's savez_compressed does (one deflated ``.npy`` per
    array; ``.npz`` appended to a name without it), at zlib level COMPRESSION_LEVEL."""
    path = os.fspath(path)
    if not path.endswith(".npz"):
        path += ".npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED,
                         compresslevel=COMPRESSION_LEVEL) as archive:
        for name, array in arrays.items():
            with archive.open(name + ".npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(array), allow_pickle=False)


def load_features(path: PathLike) -> Features:
    """Reads a file written by :func:`save_features`.

    Raises
    ------
    ValueError
        Naming the file: not an npz, a missing or damaged array (not a numeric array,
        NaN or infinity, an octave or slope beyond what cv2.KeyPoint holds), arrays
        of inconsistent shapes, or arrays that do not match the digest written with
        them (a file without a digest, from an older liff, is read as it is).
    """
    path = os.fspath(path)
    refuse_special(path, "a liff feature file (.npz)")
    try:
        data = np.load(path, allow_pickle=False)
    except Exception as error:  # numpy/zipfile raise many kinds on a damaged file
        raise ValueError(f"{path}: cannot read ({error}); expected a liff feature file (.npz)") from None
    with data:
        missing = [k for k in ("keypoints", "slopes", "descriptors") if k not in data.files]
        if missing:
            raise ValueError(f"{path}: no {', '.join(missing)} array; expected a liff feature "
                             "file written by `liff detect`")
        try:  # members are read (and parsed) only now
            arrays = {name: data[name] for name in data.files}
            rows, slopes, descriptors = arrays["keypoints"], arrays["slopes"], arrays["descriptors"]
            view = arrays.get("centre_view")
            meta = json.loads(str(arrays["meta"])) if "meta" in arrays else {}
        except Exception as error:
            raise ValueError(f"{path}: damaged feature file ({type(error).__name__}: {error}); "
                             "expected one written by `liff detect`") from None
    problem = _digest_problem(arrays) if DIGEST_KEY in arrays else None  # none: older liff
    if problem:
        raise ValueError(f"{path}: {problem}; expected the feature file `liff detect` wrote")
    _check_arrays(path, rows, slopes, descriptors, view, meta)
    n = len(rows)
    # class_id: the slope packed as round(slope * SLOPE_SCALE), as the detector does
    class_ids = np.round(slopes.astype(np.float64) * SLOPE_SCALE)
    keypoints = rows_to_keypoints(np.column_stack([rows.astype(np.float64), class_ids]))
    return Features(keypoints, descriptors if n else None, view, meta)


def read_meta(path: PathLike) -> Optional[dict]:
    """The ``meta`` record of a liff feature file, without reading its arrays; None if
    ``path`` is not a readable feature file (another kind of file, or a damaged one,
    or a FIFO, socket or device, which it does not open)."""
    if special_kind(path) is not None:
        return None
    try:
        with np.load(os.fspath(path), allow_pickle=False) as data:
            if not {"keypoints", "descriptors", "meta"} <= set(data.files):
                return None
            meta = json.loads(str(data["meta"]))
    except Exception:  # numpy/zipfile/json raise many kinds on a foreign or damaged file
        return None
    return meta if isinstance(meta, dict) else None


def _check_arrays(path: str, rows, slopes, descriptors, view, meta) -> None:
    """Raises ValueError naming ``path`` unless the arrays make valid keypoints."""
    def damaged(what: str) -> ValueError:
        return ValueError(f"{path}: {what}; expected a liff feature file written by "
                          "`liff detect`")

    arrays = {"keypoints": rows, "slopes": slopes, "descriptors": descriptors}
    for name, array in arrays.items():
        if not isinstance(array, np.ndarray):  # a member that is not a .npy: bytes
            raise damaged(f"{name} is {type(array).__name__}, not an array")
        if array.dtype.kind not in "biuf":
            raise damaged(f"{name} has dtype {array.dtype}, not numbers")
    n = len(rows) if rows.ndim >= 1 else -1
    if n < 0 or rows.ndim != 2 or rows.shape[1] != 6 or slopes.shape != (n,) or descriptors.shape != (n, 128):
        raise ValueError(f"{path}: keypoints {rows.shape}, slopes {slopes.shape}, descriptors "
                         f"{descriptors.shape}; expected (N, 6), (N,) and (N, 128)")
    for name, array in arrays.items():
        if not np.isfinite(array).all():
            raise damaged(f"{name} holds NaN or infinity")
    if n:
        # cv2.KeyPoint holds x, y, size, angle, response as float32, octave and class_id
        # (round(slope * SLOPE_SCALE)) as int32
        values = np.abs(rows[:, :5].astype(np.float64))
        if values.max() > _FLOAT32_MAX:
            raise damaged(f"keypoints hold {values.max():g}, beyond float32")
        octave = np.trunc(rows[:, 5].astype(np.float64))  # int(octave) truncates
        if octave.min() < _INT32.min or octave.max() > _INT32.max:
            raise damaged(f"keypoint octaves span {octave.min():g} .. {octave.max():g}, beyond int32")
        class_ids = np.round(slopes.astype(np.float64) * SLOPE_SCALE)
        if class_ids.min() < _INT32.min or class_ids.max() > _INT32.max:
            raise damaged(f"slopes span {slopes.min():g} .. {slopes.max():g}; expected "
                          f"|slope| < {(_INT32.max + 1) / SLOPE_SCALE:g} (int32 class_id)")
    if view is not None and not (isinstance(view, np.ndarray) and view.dtype == np.uint8
                                 and view.ndim in (2, 3) and 0 not in view.shape):
        raise damaged(f"centre_view is {type(view).__name__} {getattr(view, 'dtype', '')} "
                      f"{getattr(view, 'shape', '')}, not a uint8 image")
    if not isinstance(meta, dict):
        raise damaged(f"meta is {type(meta).__name__}, not a JSON object")


def features_from_light_field(detector, light_field: np.ndarray, mask=None,
                              meta: Optional[dict] = None) -> Features:
    """Runs ``detector.detectAndCompute`` and packs the result with the centre view."""
    keypoints, descriptors = detector.detectAndCompute(light_field, mask)
    meta = dict(meta or {})
    meta.setdefault("shape", list(np.shape(light_field)))  # (Features.centre_view_keypoints)
    return Features(tuple(keypoints), descriptors, centre_view(light_field), meta)
