"""Keypoints as numeric rows, the form liff's core, feature files and COLMAP take.

A row is ``(x, y, size, angle, response, octave, class_id)``: position in centre-view
pixels (pixel centres at integers), ``size`` a diameter in pixels, ``angle`` in
degrees, ``response`` the |DoG| contrast, ``octave`` packed as cv2.SIFT packs it, and
``class_id = round(slope * SLOPE_SCALE)`` (docs/CONVENTIONS.md).
"""

from __future__ import annotations

from typing import Sequence, Tuple

import cv2
import numpy as np

from . import _core

SLOPE_SCALE = _core.SLOPE_SCALE
"""Fixed-point scale of the slope stored in ``cv2.KeyPoint.class_id`` (65536)."""

ROW_FIELDS = ("x", "y", "size", "angle", "response", "octave", "class_id")
"""Names of a row's columns, in order."""

KeyPoints = Tuple[cv2.KeyPoint, ...]


def keypoints_to_rows(keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
    """Keypoints as rows.

    Parameters
    ----------
    keypoints : sequence of cv2.KeyPoint

    Returns
    -------
    rows : ndarray of float64, shape (N, 7)
        One row per keypoint, columns :data:`ROW_FIELDS`.

    Raises
    ------
    TypeError
        If an element is not a ``cv2.KeyPoint`` (naming its index).
    """
    rows = []
    for i, k in enumerate(keypoints):
        if not isinstance(k, cv2.KeyPoint):
            raise TypeError(f"keypoints[{i}] is {type(k).__name__}; expected cv2.KeyPoint")
        rows.append((k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave, k.class_id))
    return np.asarray(rows, dtype=np.float64).reshape(-1, len(ROW_FIELDS))


def rows_to_keypoints(rows: np.ndarray) -> KeyPoints:
    """Rows (shape (N, 7), columns :data:`ROW_FIELDS`) as a tuple of cv2.KeyPoint."""
    rows = np.asarray(rows, dtype=np.float64).reshape(-1, 7)
    # Columns as Python lists, octave and class_id as ints: one map over them is about
    # 1.6x faster than a generator over rows (3 ms for 5700 keypoints here).
    reals = rows[:, :5].T.tolist()
    ints = rows[:, 5:].astype(np.int64).T.tolist()
    return tuple(map(cv2.KeyPoint, *reals, *ints))


def keypoint_slopes(keypoints: Sequence[cv2.KeyPoint], require: bool = False) -> np.ndarray:
    """Slopes of LiFF keypoints.

    Parameters
    ----------
    keypoints : sequence of cv2.KeyPoint
        Keypoints from :class:`liff.LiFF`; the slope is stored in ``class_id`` as
        ``round(slope * SLOPE_SCALE)`` with ``SLOPE_SCALE = 65536``.
    require : bool
        Refuse keypoints that carry no slope: every ``class_id`` at -1, OpenCV's
        default (as ``cv2.SIFT``'s keypoints have), which would read as slope
        -1.5e-5. For uses where the slope is the measurement (depth, 3-D points).

    Returns
    -------
    slopes : ndarray of float64, shape (N,)
        Pixels per view step: a point at (x, y) in the centre view appears at
        ``(x - slope*(s - s_c), y - slope*(t - t_c))`` in view (t, s).

    Raises
    ------
    ValueError
        With ``require``, if every keypoint's ``class_id`` is -1.
    """
    ids = np.fromiter((k.class_id for k in keypoints), dtype=np.float64)
    if require and len(ids) and np.all(ids == -1):
        raise ValueError(f"{len(ids)} keypoints all with class_id -1 (OpenCV's default): they "
                         "carry no slope; expected keypoints from liff.LiFF, which stores "
                         "each one's slope in class_id")
    return ids / SLOPE_SCALE
