"""Pictures of LiFF features (OpenCV drawing only; no plotting library needed)."""

from __future__ import annotations

from typing import Optional, Sequence, Tuple

import cv2
import numpy as np

from .keypoint_rows import keypoint_slopes


def to_display(image: np.ndarray) -> np.ndarray:
    """A BGR uint8 copy of a grey or BGR image (uint8, uint16 or float in [0, 1])."""
    image = np.asarray(image)
    if image.dtype == np.uint16:
        image = image / 65535.0
    if image.dtype != np.uint8:
        image = np.clip(np.nan_to_num(image) * 255.0 + 0.5, 0, 255).astype(np.uint8)
    if image.ndim == 2 or image.shape[-1] == 1:
        image = cv2.cvtColor(image.reshape(image.shape[:2]), cv2.COLOR_GRAY2BGR)
    return image.copy()


def slope_colours(slopes: np.ndarray, slope_range: Tuple[float, float],
                  colormap: int = cv2.COLORMAP_TURBO) -> np.ndarray:
    """BGR colours (N, 3) uint8 for slopes, mapped linearly over ``slope_range``."""
    lo, hi = slope_range
    level = np.clip((np.asarray(slopes, float) - lo) / max(hi - lo, 1e-12), 0, 1)
    lut = cv2.applyColorMap(np.arange(256, dtype=np.uint8).reshape(-1, 1), colormap)[:, 0]
    return lut[np.round(level * 255).astype(int)]


def draw_keypoints_by_slope(
    image: np.ndarray,
    keypoints: Sequence[cv2.KeyPoint],
    slope_range: Optional[Tuple[float, float]] = None,
    colormap: int = cv2.COLORMAP_TURBO,
    scale: int = 2,
) -> np.ndarray:
    """Draws keypoints as circles (radius = size / 2, a tick for the angle) coloured by
    slope, with a colour bar on the right.

    Parameters
    ----------
    image : ndarray, shape (V, U) or (V, U, 3)
        Usually the centre view.
    keypoints : sequence of cv2.KeyPoint
        LiFF keypoints (slope in class_id).
    slope_range : (float, float), optional
        Slopes mapped to the ends of the colour map (default: the keypoints' range).
    scale : int
        Upscaling of the picture, so that small features stay visible.

    Returns
    -------
    picture : ndarray of uint8, shape (scale*V, scale*U + bar, 3)
    """
    canvas = to_display(image)
    canvas = cv2.resize(canvas, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    slopes = keypoint_slopes(keypoints)
    if slope_range is None:
        slope_range = (float(slopes.min()), float(slopes.max())) if len(slopes) else (-1.0, 1.0)
    colours = slope_colours(slopes, slope_range, colormap)
    for kp, colour in zip(keypoints, colours):
        centre = np.array(kp.pt) * scale + (scale - 1) / 2
        radius = max(kp.size / 2 * scale, 2.0)
        c = tuple(int(v) for v in colour)
        cv2.circle(canvas, tuple(np.round(centre).astype(int)), int(round(radius)), c, 1, cv2.LINE_AA)
        tip = centre + radius * np.array([np.cos(np.radians(kp.angle)), np.sin(np.radians(kp.angle))])
        cv2.line(canvas, tuple(np.round(centre).astype(int)), tuple(np.round(tip).astype(int)), c, 1,
                 cv2.LINE_AA)
    return np.hstack([canvas, _colour_bar(canvas.shape[0], slope_range, colormap)])


def _colour_bar(height: int, slope_range: Tuple[float, float], colormap: int) -> np.ndarray:
    bar = np.full((height, 90, 3), 255, np.uint8)
    top, bottom = 20, height - 20
    levels = np.linspace(slope_range[1], slope_range[0], max(bottom - top, 2))
    bar[top:bottom, 8:28] = slope_colours(levels, slope_range, colormap)[:, None, :]
    for value, y in ((slope_range[1], top), (slope_range[0], bottom - 1)):
        cv2.putText(bar, f"{value:+.2f}", (32, y + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1,
                    cv2.LINE_AA)
    cv2.putText(bar, "slope", (30, height // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1,
                cv2.LINE_AA)
    return bar
