"""Synthetic light fields with known answers, for tests, demos and benchmarks.

Every generator renders analytically (no resampling), so a point at (x, y) in the
centre view appears exactly at ``(x - slope*(s - s_c), y - slope*(t - t_c))`` in view
(t, s), with ``s_c = (S - 1) / 2`` and ``t_c = (T - 1) / 2``. Larger slopes are
nearer the camera and occlude smaller ones.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from .keypoint_rows import keypoint_slopes


@dataclass(frozen=True)
class Blob:
    """A radially symmetric feature: centre (x, y) in centre-view pixels, radius in
    pixels, slope in pixels per view step, and intensity (added to the background)."""

    x: float
    y: float
    radius: float
    slope: float
    intensity: float


def _check_shape(shape) -> Tuple[int, int, int, int]:
    """``shape`` as four ints (T, S, V, U), each >= 1; raises ValueError otherwise."""
    try:
        T, S, V, U = (operator.index(n) for n in shape)
    except (TypeError, ValueError):
        raise ValueError(f"shape = {shape!r}; expected four integers (T, S, V, U)") from None
    if min(T, S, V, U) < 1:
        raise ValueError(f"shape = {tuple(shape)!r}; expected at least 1 view (T, S) and 1 pixel "
                         f"(V, U) along each axis")
    return T, S, V, U


def _check_noise(noise_variance: float) -> float:
    """``noise_variance`` if it is a finite number >= 0; raises ValueError otherwise."""
    if not (np.isfinite(noise_variance) and noise_variance >= 0):
        raise ValueError(f"noise_variance = {noise_variance!r}; expected a finite number >= 0 "
                         f"(0 for no noise)")
    return noise_variance


def _view_offsets(T: int, S: int, slope: float):
    """Per-view (dy, dx) displacement of a point at this slope, shape (T, S)."""
    t = np.arange(T) - (T - 1) / 2
    s = np.arange(S) - (S - 1) / 2
    return -slope * t[:, None] + 0 * s[None, :], -slope * s[None, :] + 0 * t[:, None]


def render_disks(
    blobs: Sequence[Blob],
    shape: Tuple[int, int, int, int] = (9, 9, 256, 256),
    background: float = 0.5,
    noise_variance: float = 0.0,
    seed: Optional[int] = None,
    profile: str = "disk",
) -> np.ndarray:
    """Renders blobs into a light field.

    Parameters
    ----------
    blobs : sequence of Blob
    shape : (T, S, V, U)
    background : float
        Background intensity.
    noise_variance : float
        Variance of additive white Gaussian noise (0 for none).
    seed : int, optional
        Seed of the noise.
    profile : {"disk", "gaussian"}
        "disk": anti-aliased disk (1-pixel linear edge), replacing what is behind it;
        "gaussian": Gaussian of sigma = radius, added.

    Returns
    -------
    lf : ndarray of float64, shape (T, S, V, U)

    Raises
    ------
    ValueError
        For a shape entry below 1, a negative or non-finite ``noise_variance``, or an
        unknown ``profile``.
    """
    T, S, V, U = shape = _check_shape(shape)
    _check_noise(noise_variance)
    if profile not in ("disk", "gaussian"):
        raise ValueError(f"profile = {profile!r}; expected 'disk' or 'gaussian'")
    lf = np.full(shape, background, dtype=np.float64)
    yy, xx = np.mgrid[0:V, 0:U].astype(np.float64)
    for blob in sorted(blobs, key=lambda b: b.slope):  # far first; near ones occlude
        dy, dx = _view_offsets(T, S, blob.slope)
        reach = blob.radius * (4 if profile == "gaussian" else 1) + 2
        for t in range(T):
            for s in range(S):
                cx, cy = blob.x + dx[t, s], blob.y + dy[t, s]
                x0, x1 = max(0, int(cx - reach)), min(U, int(cx + reach) + 2)
                y0, y1 = max(0, int(cy - reach)), min(V, int(cy + reach) + 2)
                if x0 >= x1 or y0 >= y1:
                    continue
                r2 = (xx[y0:y1, x0:x1] - cx) ** 2 + (yy[y0:y1, x0:x1] - cy) ** 2
                patch = lf[t, s, y0:y1, x0:x1]
                if profile == "gaussian":
                    patch += blob.intensity * np.exp(-r2 / (2 * blob.radius**2))
                else:
                    cover = np.clip(blob.radius + 0.5 - np.sqrt(r2), 0.0, 1.0)
                    patch *= 1 - cover
                    patch += cover * (background + blob.intensity)
    if noise_variance > 0:
        lf += np.random.default_rng(seed).normal(0.0, np.sqrt(noise_variance), shape)
    return lf


def paper_disks(
    n: int = 26,
    shape: Tuple[int, int, int, int] = (9, 9, 256, 256),
    contrast: float = 0.1,
    slope_range: Tuple[float, float] = (-1.0, 1.0),
    seed: int = 0,
) -> list:
    """The paper's noise-experiment scene: ``n`` disks at varying scales and slopes.

    Disks sit on a jittered grid so that none overlap in any view; radii span about
    2.5 to 8 pixels, slopes are spread evenly over ``slope_range`` in a shuffled
    order, and every disk is brighter than the background by ``contrast``.

    Raises ValueError for ``n`` < 1 or a shape entry below 1.
    """
    T, S, V, U = _check_shape(shape)
    if n < 1:
        raise ValueError(f"n = {n!r}; expected at least 1 disk")
    rng = np.random.default_rng(seed)
    cols = int(np.ceil(np.sqrt(n * U / V)))
    rows = int(np.ceil(n / cols))
    cell_w, cell_h = U / cols, V / rows
    max_shift = max(abs(slope_range[0]), abs(slope_range[1])) * (max(T, S) - 1) / 2
    max_radius = max(2.5, min(8.0, min(cell_w, cell_h) / 2 - max_shift - 3))
    radii = np.geomspace(2.5, max_radius, n)
    slopes = np.linspace(slope_range[0], slope_range[1], n)
    rng.shuffle(radii)
    rng.shuffle(slopes)
    blobs = []
    for i in range(n):
        r, c = divmod(i, cols)
        jitter = rng.uniform(-0.25, 0.25, 2) * np.array([cell_w, cell_h]) * 0.3
        blobs.append(
            Blob(
                x=float((c + 0.5) * cell_w + jitter[0]),
                y=float((r + 0.5) * cell_h + jitter[1]),
                radius=float(radii[i]),
                slope=float(slopes[i]),
                intensity=contrast,
            )
        )
    return blobs


def random_blob_layers(
    slopes: Sequence[float],
    shape: Tuple[int, int, int, int] = (7, 7, 128, 128),
    blobs_per_layer: int = 12,
    radius_range: Tuple[float, float] = (2.0, 4.0),
    seed: int = 0,
    margin: float = 10.0,
) -> list:
    """Gaussian blobs of random sign on fronto-parallel layers at the given slopes.

    Blobs keep at least 4 radii from each other (within and across layers), so each
    is an isolated feature whose true position and slope are known.
    """
    T, S, V, U = shape
    rng = np.random.default_rng(seed)
    blobs: list = []
    for slope in slopes:
        placed, tries = 0, 0
        while placed < blobs_per_layer and tries < 2000:
            tries += 1
            r = rng.uniform(*radius_range)
            x, y = rng.uniform(margin, U - margin), rng.uniform(margin, V - margin)
            if any(np.hypot(b.x - x, b.y - y) < 4 * max(b.radius, r) for b in blobs):
                continue
            sign = 1.0 if rng.random() < 0.5 else -1.0
            blobs.append(Blob(x, y, r, float(slope), sign * rng.uniform(0.3, 0.5)))
            placed += 1
    return blobs


@dataclass
class LayeredScene:
    """Fronto-parallel textured layers: ``light_field`` float32 (T, S, V, U) in [0, 1],
    and ``slope_map`` float32 (V, U), the slope of the nearest layer at each centre-view
    pixel (what a feature there should report)."""

    light_field: np.ndarray
    slope_map: np.ndarray


def _smooth_texture(shape, seed: int, blur: float) -> np.ndarray:
    """Gaussian-smoothed uniform noise, stretched to [0, 1]."""
    import cv2

    rng = np.random.default_rng(seed)
    texture = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), blur)
    texture -= texture.min()
    return texture / max(float(texture.max()), 1e-6)


def textured_plane(shape: Tuple[int, int, int, int] = (3, 3, 256, 256), slope: float = 1.0,
                   seed: int = 0, blur: float = 2.0) -> np.ndarray:
    """A fronto-parallel textured plane at ``slope`` whose world continues beyond the
    frame, as a camera array or gantry sees it: each view is a window onto a texture
    larger than the frame, so a view's border shows content its neighbours show inside
    (unlike :func:`textured_layers`, which reflects at the borders).

    Parameters
    ----------
    shape : (T, S, V, U)
        Views and view size, pixels.
    slope : float
        Pixels per view step; centre-view content (x, y) appears at
        ``(x - slope (s - s_c), y - slope (t - t_c))`` in view (t, s).
    seed : int
        Seed of the texture (uniform noise).
    blur : float
        Gaussian sigma of the texture, pixels.

    Returns
    -------
    light_field : ndarray of float32, shape (T, S, V, U), values in [0, 1]
        Each view warped bilinearly from the texture (not analytically).

    Raises
    ------
    ValueError
        For a shape entry below 1 or a non-finite slope.
    """
    import cv2

    T, S, V, U = _check_shape(shape)
    if not np.isfinite(slope):
        raise ValueError(f"slope = {slope}; expected a finite value, pixels per view step")
    margin = int(np.ceil(abs(slope) * max(T, S))) + 8
    texture = _smooth_texture((V + 2 * margin, U + 2 * margin), seed, blur)
    lf = np.empty((T, S, V, U), np.float32)
    for t in range(T):
        for s in range(S):
            dx, dy = -slope * (s - (S - 1) / 2), -slope * (t - (T - 1) / 2)
            warp = np.array([[1, 0, margin - dx], [0, 1, margin - dy]], np.float32)
            lf[t, s] = cv2.warpAffine(texture, warp, (U, V),
                                      flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
    return lf


def textured_layers(
    shape: Tuple[int, int, int, int] = (9, 9, 128, 128),
    slopes: Tuple[float, float, float] = (-0.6, 0.1, 0.7),
    seed: int = 0,
    noise_variance: float = 1e-4,
    contrast: float = 1.0,
) -> LayeredScene:
    """Three textured layers at ``slopes`` (far to near), each partially occluding what
    is behind: a full background, a disc of radius 0.3 V, and vertical bars 8 px wide
    every 60 px (the occluder).

    Textures are smoothed noise (blur 2, 1.5 and 1 px) scaled to ``contrast`` around
    0.5. Rendering warps each layer bilinearly per view (so, unlike the disk scenes,
    not analytically), composites near over far, adds Gaussian noise of variance
    ``noise_variance`` view by view and clips to [0, 1].

    Raises ValueError for a shape entry below 1, a negative or non-finite
    ``noise_variance``, or slopes that are not three increasing values.
    """
    import cv2

    T, S, V, U = shape = _check_shape(shape)
    _check_noise(noise_variance)
    if len(slopes) != 3 or not np.all(np.diff(slopes) > 0):
        raise ValueError(f"slopes = {slopes}; expected three increasing slopes (far to near)")
    yy, xx = np.mgrid[0:V, 0:U]
    disc = ((xx - U * 0.45) ** 2 + (yy - V * 0.5) ** 2 < (0.3 * V) ** 2).astype(np.float32)
    bars = (np.mod(xx, 60) < 8).astype(np.float32)
    layers = [(slope, 0.5 + contrast * (_smooth_texture((V, U), seed + i, blur) - 0.5), alpha)
              for i, (slope, blur, alpha) in enumerate(
                  zip(slopes, (2.0, 1.5, 1.0), (np.ones((V, U), np.float32), disc, bars)))]
    slope_map = np.full((V, U), slopes[0], np.float32)
    slope_map[disc > 0] = slopes[1]
    slope_map[bars > 0] = slopes[2]
    lf = np.zeros(shape, np.float32)
    noise = np.random.default_rng(seed + 9)
    for t in range(T):
        for s in range(S):
            view = np.zeros((V, U), np.float32)
            for slope, texture, alpha in layers:
                # Content at centre-view (x, y) appears at (x + dx, y + dy) in this view.
                dx, dy = -slope * (s - (S - 1) / 2), -slope * (t - (T - 1) / 2)
                warp = np.array([[1, 0, dx], [0, 1, dy]], np.float32)
                warped = cv2.warpAffine(texture, warp, (U, V), flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REFLECT)
                cover = cv2.warpAffine(alpha, warp, (U, V), flags=cv2.INTER_LINEAR,
                                       borderMode=cv2.BORDER_REFLECT)
                view = view * (1 - cover) + warped * cover
            if noise_variance > 0:  # view by view, so memory stays at one light field
                view += noise.normal(0, np.sqrt(noise_variance), (V, U)).astype(np.float32)
            lf[t, s] = np.clip(view, 0, 1)
    return LayeredScene(lf, slope_map)


@dataclass
class BlobMatch:
    """Keypoints matched to a scene's blobs (see :func:`match_blobs`).

    ``found`` (N,) bool: blob i has its nearest keypoint within reach; ``nearest`` (N,)
    int: index of blob i's nearest keypoint (-1 without keypoints); ``slope_errors``
    (found blobs,) float64: that keypoint's slope minus the blob's, in blob order;
    ``spurious``: keypoints beyond reach of every blob."""

    found: np.ndarray
    nearest: np.ndarray
    slope_errors: np.ndarray
    spurious: int


def match_blobs(keypoints, blobs: Sequence[Blob], found_within, spurious_beyond) -> BlobMatch:
    """Matches keypoints to the blobs of a scene with known answers.

    Parameters
    ----------
    keypoints : sequence of cv2.KeyPoint
        From :class:`liff.LiFF` (the slope in ``class_id``) or any detector.
    blobs : sequence of Blob
    found_within : float or array of shape (N,)
        Blob i counts as found when its nearest keypoint is at most this far from its
        centre (pixels; one value, or one per blob).
    spurious_beyond : float or array of shape (N,)
        A keypoint is spurious when it is farther than this from every blob centre
        (pixels; one value, or one per blob).

    Returns
    -------
    BlobMatch
    """
    centres = np.array([(b.x, b.y) for b in blobs], dtype=np.float64).reshape(-1, 2)
    within = np.broadcast_to(np.asarray(found_within, dtype=np.float64), (len(blobs),))
    beyond = np.broadcast_to(np.asarray(spurious_beyond, dtype=np.float64), (len(blobs),))
    if len(keypoints) == 0 or len(blobs) == 0:
        return BlobMatch(np.zeros(len(blobs), bool), np.full(len(blobs), -1), np.zeros(0),
                         len(keypoints))
    points = np.array([k.pt for k in keypoints], dtype=np.float64)
    distance = np.hypot(points[:, None, 0] - centres[None, :, 0],
                        points[:, None, 1] - centres[None, :, 1])  # (keypoints, blobs)
    nearest = distance.argmin(axis=0)
    found = distance[nearest, np.arange(len(blobs))] <= within
    spurious = int((distance > beyond[None, :]).all(axis=1).sum())
    truth = np.array([b.slope for b in blobs])
    errors = keypoint_slopes(keypoints)[nearest[found]] - truth[found]
    return BlobMatch(found, nearest, errors, spurious)


def lenslet_capture(light_field: np.ndarray, border: float = 0.1, corner_gain: float = 0.35
                    ) -> np.ndarray:
    """A lenslet camera's defects applied to a light field, as a Lytro's decoded capture
    shows them: the views of each lenslet darken towards its rim and the views beyond
    its circle hold no light (alpha 0), and the main lens leaves a black, vignetted
    border around every view.

    Parameters
    ----------
    light_field : ndarray, shape (T, S, V, U)
        Grey intensities in [0, 1] (e.g. :func:`textured_layers`' light field).
    border : float
        Width of the black border, as a share of min(V, U): intensities fall smoothly
        to 0 over ``border`` and are 0 beyond, in a rounded rectangle.
    corner_gain : float
        Gain of the outermost views still inside the lenslet circle (1 at its centre,
        falling quadratically with the distance from it).

    Returns
    -------
    ndarray of uint8, shape (T, S, V, U, 4)
        BGRA (grey repeated), alpha 255 for the views inside the lenslet circle
        (distance from the centre view at most (max(T, S) - 1) / 2 + 0.5) and 0 outside,
        where the intensities are 0 too. Write it with ``liff.io.write_eslf``.

    Raises
    ------
    ValueError
        If ``light_field`` is not 4-D, ``border`` is not in [0, 0.5) or ``corner_gain``
        not in (0, 1].
    """
    light_field = np.asarray(light_field, np.float32)
    if light_field.ndim != 4:
        raise ValueError(f"light field shape {light_field.shape}; expected (T, S, V, U) grey")
    if not 0 <= border < 0.5 or not 0 < corner_gain <= 1:
        raise ValueError(f"border = {border!r}, corner_gain = {corner_gain!r}; expected border in "
                         f"[0, 0.5) and corner_gain in (0, 1]")
    T, S, V, U = light_field.shape
    t = np.arange(T)[:, None] - (T - 1) / 2
    s = np.arange(S)[None, :] - (S - 1) / 2
    radius = (max(T, S) - 1) / 2 + 0.5
    r = np.hypot(t, s) / radius  # 1 at the lenslet's rim
    inside = r <= 1
    gain = np.where(inside, 1 - (1 - corner_gain) * np.minimum(r, 1) ** 2, 0).astype(np.float32)
    # main-lens vignetting: a rounded rectangle, smooth to 0 over `border`
    width = max(border * min(V, U), 1e-6)
    y = np.minimum(np.arange(V), V - 1 - np.arange(V))[:, None] / width
    x = np.minimum(np.arange(U), U - 1 - np.arange(U))[None, :] / width
    edge = np.clip(np.minimum(np.minimum(x, y), 1 - np.hypot(1 - np.minimum(x, 1), 1 - np.minimum(y, 1))), 0, 1)
    spatial = (edge ** 2).astype(np.float32) if border > 0 else np.ones((V, U), np.float32)
    grey = np.clip(light_field * gain[:, :, None, None] * spatial, 0, 1)
    out = np.empty((T, S, V, U, 4), np.uint8)
    out[..., :3] = np.round(grey * 255).astype(np.uint8)[..., None]
    out[..., 3] = np.where(inside, 255, 0).astype(np.uint8)[:, :, None, None]
    return out
