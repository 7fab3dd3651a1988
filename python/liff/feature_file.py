"""Features on disk: one ``.npz`` per light field, written by ``liff detect``.

Arrays in the file:

============== ============== ==================================================
``keypoints``  (N, 6) float64 x, y, size, angle, response, octave (cv2.KeyPoint
                              fields; x, y in centre-view pixels, OpenCV centres)
``slopes``     (N,) float64   slope of each feature, pixels per view step
``descriptors`` (N, 128)      float32 or uint8 (SIFT integers in [0, 255])
``centre_view`` (V, U[, 3])   uint8, the picture the features are drawn on
``meta``       str            JSON: source file, light field shape, parameters
============== ============== ==================================================
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Optional, Sequence, Tuple, Union

import cv2
import numpy as np

from ._detector import SLOPE_SCALE, keypoint_slopes
from .plot import to_display

PathLike = Union[str, os.PathLike]
KEYPOINT_COLUMNS = ("x", "y", "size", "angle", "response", "octave")


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


def save_features(path: PathLike, features: Features) -> None:
    """Writes ``features`` to ``path`` (.npz, compressed); see the module docstring."""
    rows = np.array([(k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave)
                     for k in features.keypoints], dtype=np.float64).reshape(-1, 6)
    descriptors = features.descriptors
    if descriptors is None:
        descriptors = np.zeros((0, 128), np.float32)
    if len(descriptors) != len(rows):
        raise ValueError(f"{os.fspath(path)}: {len(rows)} keypoints but {len(descriptors)} "
                         "descriptors; expected one descriptor row per keypoint")
    arrays = dict(keypoints=rows, slopes=features.slopes, descriptors=descriptors,
                  meta=np.array(json.dumps(features.meta)))
    if features.centre_view is not None:
        arrays["centre_view"] = to_display(features.centre_view)
    np.savez_compressed(path, **arrays)


def load_features(path: PathLike) -> Features:
    """Reads a file written by :func:`save_features`.

    Raises
    ------
    ValueError
        Naming the file: not an npz, a missing array, or arrays of inconsistent shapes.
    """
    path = os.fspath(path)
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
            rows, slopes, descriptors = data["keypoints"], data["slopes"], data["descriptors"]
            view = data["centre_view"] if "centre_view" in data.files else None
            meta = json.loads(str(data["meta"])) if "meta" in data.files else {}
        except Exception as error:
            raise ValueError(f"{path}: damaged feature file ({type(error).__name__}: {error}); "
                             "expected one written by `liff detect`") from None
    n = len(rows) if getattr(rows, "ndim", 0) >= 1 else -1
    if n < 0 or rows.ndim != 2 or rows.shape[1] != 6 or slopes.shape != (n,) or descriptors.shape != (n, 128):
        raise ValueError(f"{path}: keypoints {rows.shape}, slopes {slopes.shape}, descriptors "
                         f"{descriptors.shape}; expected (N, 6), (N,) and (N, 128)")
    keypoints = tuple(
        cv2.KeyPoint(float(x), float(y), float(size), float(angle), float(response), int(octave),
                     int(round(slope * SLOPE_SCALE)))
        for (x, y, size, angle, response, octave), slope in zip(rows.tolist(), slopes.tolist()))
    return Features(keypoints, descriptors if n else None, view, meta)


def features_from_light_field(detector, light_field: np.ndarray, mask=None,
                              meta: Optional[dict] = None) -> Features:
    """Runs ``detector.detectAndCompute`` and packs the result with the centre view."""
    keypoints, descriptors = detector.detectAndCompute(light_field, mask)
    return Features(tuple(keypoints), descriptors, centre_view(light_field), dict(meta or {}))
