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
    truth: Optional[Tuple[np.ndarray, np.ndarray]] = None,
) -> np.ndarray:
    """Draws keypoints as circles (radius = size / 2, a tick for the angle) coloured by
    slope, each with a dot of its colour at its centre (a thin dark outline, radius
    :func:`dot_radius`, drawn over every circle so that no feature's colour is hidden),
    and a colour bar on the right.

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
    truth : (ndarray (N, 2), ndarray of bool (N,)), optional
        Known feature positions (x, y) in the view's pixels and whether each was found,
        marked by :func:`draw_ground_truth` over the circles and under the dots.

    Returns
    -------
    picture : ndarray of uint8, shape (max(scale*V, 120), scale*U + bar, 3)
        The view at the top left (white below it if it is less than 120 pixels
        high, so that the colour bar's labels fit), the colour bar on the right.
    """
    canvas = to_display(image)
    canvas = cv2.resize(canvas, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    if canvas.shape[0] < MIN_HEIGHT:
        canvas = cv2.copyMakeBorder(canvas, 0, MIN_HEIGHT - canvas.shape[0], 0, 0,
                                    cv2.BORDER_CONSTANT, value=(255, 255, 255))
    slopes = keypoint_slopes(keypoints)
    if slope_range is None:
        slope_range = (float(slopes.min()), float(slopes.max())) if len(slopes) else (-1.0, 1.0)
    colours = [tuple(int(v) for v in colour) for colour in slope_colours(slopes, slope_range, colormap)]
    centres = [np.array(kp.pt) * scale + (scale - 1) / 2 for kp in keypoints]
    for kp, centre, c in zip(keypoints, centres, colours):
        radius = max(kp.size / 2 * scale, 2.0)
        cv2.circle(canvas, _pixel(centre), int(round(radius)), c, 1, cv2.LINE_AA)
        tip = centre + radius * np.array([np.cos(np.radians(kp.angle)), np.sin(np.radians(kp.angle))])
        cv2.line(canvas, _pixel(centre), _pixel(tip), c, 1, cv2.LINE_AA)
    if truth is not None:
        draw_ground_truth(canvas, truth[0], truth[1], scale)
    dot = dot_radius(scale)
    for centre in centres:  # every outline first: no outline covers another feature's dot
        cv2.circle(canvas, _pixel(centre), dot + 1, (0, 0, 0), -1, cv2.LINE_8)
    for centre, c in zip(centres, colours):
        cv2.circle(canvas, _pixel(centre), dot, c, -1, cv2.LINE_8)
    return np.hstack([canvas, _colour_bar(canvas.shape[0], slope_range, colormap)])


def dot_radius(scale: int) -> int:
    """Radius in pixels of the slope-coloured dot at a feature's centre in a picture
    drawn at ``scale`` (3 at the default 2)."""
    return max(2, scale + 1)


def _pixel(point) -> Tuple[int, int]:
    """The integer pixel nearest to a point (x, y)."""
    x, y = np.round(np.asarray(point, float))
    return int(x), int(y)


def text_scale(height: int) -> float:
    """OpenCV font scale for labels on a picture ``height`` pixels high: letters about
    2.5% of the height (12 px at 480), and never under 9 px."""
    return max(0.4, height / 1000)


def _put_text(picture: np.ndarray, text: str, origin, font_scale: float,
              colour=(0, 0, 0), outline: int = 0) -> None:
    """Text at ``origin`` (its baseline's left end); ``outline`` thickens the stroke,
    for a dark border drawn before the same text in a light colour."""
    thickness = max(1, int(round(font_scale * 1.5))) + outline
    cv2.putText(picture, text, tuple(int(v) for v in origin), cv2.FONT_HERSHEY_SIMPLEX,
                font_scale, colour, thickness, cv2.LINE_AA)


def _colour_bar(height: int, slope_range: Tuple[float, float], colormap: int) -> np.ndarray:
    """A vertical colour bar with its end values and "slope", sized for ``height``."""
    font = text_scale(height)
    (label_width, label_height), _ = cv2.getTextSize("+0.00", cv2.FONT_HERSHEY_SIMPLEX, font, 1)
    margin = label_height
    ramp = max(20, label_height * 2)
    bar = np.full((height, 3 * margin + ramp + label_width, 3), 255, np.uint8)
    top, bottom = 2 * margin, height - 2 * margin
    levels = np.linspace(slope_range[1], slope_range[0], max(bottom - top, 2))
    bar[top:bottom, margin:margin + ramp] = slope_colours(levels, slope_range, colormap)[:, None, :]
    x = 2 * margin + ramp
    for value, y in ((slope_range[1], top + label_height // 2),
                     (slope_range[0], bottom - 1 + label_height // 2)):
        _put_text(bar, f"{value:+.2f}", (x, y), font)
    _put_text(bar, "slope", (x, height // 2 + label_height // 2), font)
    return bar


MIN_HEIGHT = 120  # pixels: the colour bar's three labels fit


def draw_ground_truth(picture: np.ndarray, points: np.ndarray, found: np.ndarray,
                      scale: int = 2) -> np.ndarray:
    """Marks known feature positions on a picture from :func:`draw_keypoints_by_slope`
    (which calls this with its ``truth``, under the features' dots): a white + on the ones
    found, its arms starting outside the feature's dot so that the slope colour shows
    through the gap in its middle, a magenta x on the ones missed (colours the slope map
    does not use), and a legend with both counts at the top left.

    Parameters
    ----------
    picture : ndarray of uint8, shape (H, W, 3)
        Drawn on in place and returned.
    points : ndarray, shape (N, 2)
        (x, y) in the view's pixels.
    found : ndarray of bool, shape (N,)
    scale : int
        The picture's ``scale``.
    """
    size = max(7, int(round(picture.shape[0] / 40)))
    gap = dot_radius(scale) + 2  # the dot and its outline, and a pixel of the view
    arm = max(size // 2, gap + 3)
    for (x, y), hit in zip(np.asarray(points, float), np.asarray(found, bool)):
        centre = np.array([x, y]) * scale + (scale - 1) / 2
        if not hit:
            cv2.drawMarker(picture, _pixel(centre), (0, 0, 0), cv2.MARKER_TILTED_CROSS, size + 2, 4)
            cv2.drawMarker(picture, _pixel(centre), (255, 0, 255), cv2.MARKER_TILTED_CROSS, size, 2)
            continue
        for colour, width, extra in (((0, 0, 0), 4, 1), ((255, 255, 255), 2, 0)):
            for direction in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                d = np.array(direction)
                cv2.line(picture, _pixel(centre + gap * d), _pixel(centre + (arm + extra) * d),
                         colour, width, cv2.LINE_8)
    found = np.asarray(found, bool)
    font = text_scale(picture.shape[0])
    lines = [(f"+ found {found.sum()}/{len(found)}", (255, 255, 255)),
             (f"x missed {(~found).sum()}", (255, 0, 255))]
    step = cv2.getTextSize("x", cv2.FONT_HERSHEY_SIMPLEX, font, 1)[0][1] * 2
    for i, (text, colour) in enumerate(lines):
        origin = (step // 2, step * (i + 1))
        _put_text(picture, text, origin, font, (0, 0, 0), outline=3)
        _put_text(picture, text, origin, font, colour)
    return picture
