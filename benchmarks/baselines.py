"""Baselines LiFF is compared with: SIFT on one view and repeated SIFT over all views.

"SIFT" here is LiFF's own 2-D path (a 1x1 light field), which equals cv::SIFT (the
tests check keypoints and descriptors against cv2.SIFT) but, unlike pip's cv2.SIFT,
accepts float images, so noise is not clipped to [0, 255] before detection.
"""

from __future__ import annotations

from typing import List, Sequence, Tuple

import cv2
import numpy as np

from liff import SLOPE_SCALE, LiFF


def sift_on_views(lf: np.ndarray, detector: LiFF) -> List[Tuple[int, int, tuple]]:
    """SIFT keypoints of every view: a list of (t, s, keypoints)."""
    T, S = lf.shape[:2]
    return [(t, s, detector.detect(lf[t, s])) for t in range(T) for s in range(S)]


def consolidate(
    detections: Sequence[Tuple[int, int, Sequence[cv2.KeyPoint]]],
    shape: Tuple[int, int],
    fraction: float,
    slopes: np.ndarray = np.linspace(-1.2, 1.2, 49),
    radius: float = 1.5,
) -> Tuple[cv2.KeyPoint, ...]:
    """Repeated SIFT's consolidation: keeps features found in at least ``fraction`` of the
    views consistently with a plane through the views.

    For every slope of ``slopes``, each view's detections are moved to where a point at
    that slope would sit in the centre view, ``(x + slope*(s - s_c), y + slope*(t - t_c))``.
    A feature is a cell of width 2 * ``radius`` (on four half-shifted grids) that holds
    detections from at least ``fraction`` of the views; overlapping features (closer
    than 3 px) keep the one with most views and, among those, the tightest cluster
    (which picks the slope). Returned keypoints are in centre-view
    pixels with the mean size and response of their members and the slope in class_id.

    Parameters
    ----------
    detections : sequence of (t, s, keypoints)
    shape : (T, S) view grid
    fraction : float in (0, 1]
    """
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction = {fraction}; expected a value in (0, 1]")
    if radius <= 0:
        raise ValueError(f"radius = {radius}; expected a positive number of pixels")
    T, S = shape
    rows = [(t, s, k.pt[0], k.pt[1], k.size, k.response) for t, s, kps in detections for k in kps]
    if not rows:
        return ()
    a = np.array(rows, dtype=np.float64)
    view = (a[:, 0] * S + a[:, 1]).astype(np.int64)
    need = max(1, int(np.ceil(fraction * T * S - 1e-9)))
    cell = 2.0 * radius  # cells of this width, on four half-shifted grids
    candidates = []  # (views, spread, x, y, slope, size, response)
    for slope in slopes:
        px = a[:, 2] + slope * (a[:, 1] - (S - 1) / 2)
        py = a[:, 3] + slope * (a[:, 0] - (T - 1) / 2)
        for ox in (0.0, 0.5):
            for oy in (0.0, 0.5):
                cx = np.floor(px / cell + ox).astype(np.int64)
                cy = np.floor(py / cell + oy).astype(np.int64)
                key = (cx - cx.min()) * (cy.max() - cy.min() + 1) + (cy - cy.min())
                # Distinct views per cell.
                pairs = np.unique(key * (T * S) + view)
                cells, views_per_cell = np.unique(pairs // (T * S), return_counts=True)
                good = cells[views_per_cell >= need]
                if len(good) == 0:
                    continue
                members = np.isin(key, good)
                groups, inverse = np.unique(key[members], return_inverse=True)
                count = np.bincount(inverse)
                mean = lambda v: np.bincount(inverse, weights=v[members]) / count  # noqa: E731
                n_views = views_per_cell[np.searchsorted(cells, groups)]
                mx, my = mean(px), mean(py)
                spread = mean(px * px) - mx * mx + mean(py * py) - my * my
                for g in range(len(groups)):
                    candidates.append((int(n_views[g]), float(spread[g]), mx[g], my[g],
                                       float(slope), mean(a[:, 4])[g], mean(a[:, 5])[g]))
    # Most views first; among equals the tightest cluster, which is the best slope.
    candidates.sort(key=lambda c: (-c[0], c[1]))
    kept: list = []
    for n_views, _, x, y, slope, size, response in candidates:
        if any(np.hypot(x - k[0], y - k[1]) < 3.0 for k in kept):
            continue
        kept.append((x, y, slope, size, response))
    return tuple(cv2.KeyPoint(x, y, size, -1, response, 0, int(round(slope * SLOPE_SCALE)))
                 for x, y, slope, size, response in kept)


def repeated_sift(lf: np.ndarray, fraction: float, detector: LiFF = None, **kwargs):
    """Repeated SIFT as the paper describes it: SIFT on every view, consolidated by
    :func:`consolidate`. ``lf`` is (T, S, V, U); returns centre-view keypoints."""
    detector = detector or LiFF.create()
    return consolidate(sift_on_views(lf, detector), lf.shape[:2], fraction, **kwargs)
