"""Features and images as COLMAP takes them: keypoints, descriptors (SIFT, RootSIFT),
grey 8-bit images, and the paper's greyscale for SfM. Pure numpy and OpenCV; the
conventions crossed are in :mod:`liff.colmap`'s notes (pixel centres, scale,
orientation, descriptor scale)."""

from __future__ import annotations

from typing import Optional, Sequence

import cv2
import numpy as np

from .. import plot, preprocess


def keypoints_to_colmap(keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
    """COLMAP keypoints (x, y, scale, orientation), float32 (N, 4): see the module notes."""
    rows = [(k.pt[0] + 0.5, k.pt[1] + 0.5, k.size / 2,
             0.0 if k.angle < 0 else np.radians(k.angle)) for k in keypoints]
    out = np.asarray(rows, dtype=np.float32).reshape(-1, 4)
    # Orientation in [-pi, pi), as COLMAP's own extractor reports it.
    out[:, 3] = (out[:, 3] + np.pi) % (2 * np.pi) - np.pi
    return out


def _descriptor_matrix(descriptors: np.ndarray) -> np.ndarray:
    """``descriptors`` as an array of shape (N, 128); raises ValueError for another shape."""
    d = np.asarray(descriptors)
    if d.ndim != 2 or d.shape[1] != 128:
        raise ValueError(f"descriptors have shape {d.shape}; expected (N, 128)")
    return d


def _check_descriptor_dtype(d: np.ndarray) -> None:
    if d.dtype.kind not in "fiu":
        raise ValueError(f"descriptors have dtype {d.dtype}; expected uint8 or float")


def descriptors_to_colmap(descriptors: Optional[np.ndarray], num_keypoints: int) -> np.ndarray:
    """Checks descriptors on SIFT's integer scale and casts them to uint8 (N, 128).

    Raises ValueError for a wrong shape, a count that differs from ``num_keypoints``,
    non-finite values, values outside [0, 255], or float descriptors that look unit-norm
    (COLMAP wants ``round(512 * d)``; pass unit-norm ones through
    ``np.clip(np.round(512 * d), 0, 255)``).
    """
    if descriptors is None:
        if num_keypoints:
            raise ValueError(f"descriptors are None but there are {num_keypoints} keypoints")
        return np.zeros((0, 128), np.uint8)
    d = _descriptor_matrix(descriptors)
    if d.shape[0] != num_keypoints:
        raise ValueError(f"{d.shape[0]} descriptors for {num_keypoints} keypoints; expected one each")
    if d.dtype == np.uint8:
        return np.ascontiguousarray(d)
    _check_descriptor_dtype(d)
    if not np.isfinite(d).all() or (d.size and (d.min() < 0 or d.max() > 255.5)):
        raise ValueError("descriptors must be finite and in [0, 255] (SIFT's round(512 * d))")
    if d.size and d.max() <= 1.0:
        raise ValueError("descriptors look unit-norm (max <= 1); COLMAP stores round(512 * d): "
                         "pass np.clip(np.round(512 * d), 0, 255)")
    return np.clip(np.round(d), 0, 255).astype(np.uint8)


def root_sift(descriptors: Optional[np.ndarray]) -> np.ndarray:
    """RootSIFT (Arandjelovic and Zisserman 2012) of SIFT descriptors, on the same scale.

    Parameters
    ----------
    descriptors : ndarray, shape (N, 128), or None
        SIFT descriptors as ``round(512 * d)`` (cv2.SIFT, liff with rootSift=False);
        None (what cv2.SIFT returns when it finds no keypoints) is taken as N = 0.

    Returns
    -------
    ndarray of uint8, shape (N, 128)
        ``round(512 * sqrt(d / |d|_1))`` saturated to [0, 255]; sqrt(d / |d|_1) has unit
        L2 norm, so this is COLMAP's format. The paper used RootSIFT for both methods.

    Raises
    ------
    ValueError
        For a shape other than (N, 128), a dtype other than integer or float, or
        values that are negative or not finite.
    """
    if descriptors is None:
        return np.zeros((0, 128), np.uint8)
    d = _descriptor_matrix(descriptors)
    _check_descriptor_dtype(d)
    if not np.isfinite(d).all() or (d.size and d.min() < 0):
        raise ValueError("descriptors must be finite and >= 0 (SIFT's round(512 * d))")
    d = d.astype(np.float64)
    l1 = np.maximum(d.sum(axis=1, keepdims=True), 1e-12)
    return np.clip(np.round(512 * np.sqrt(d / l1)), 0, 255).astype(np.uint8)


def grey_uint8_image(image: np.ndarray) -> np.ndarray:
    """A grey uint8 copy of a grey or BGR image (uint8, uint16 or float in [0, 1]), as
    :func:`liff.plot.to_display` scales it; what COLMAP's images are."""
    image = np.asarray(image)
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] in (1, 3))) or 0 in image.shape:
        raise ValueError(f"image has shape {image.shape}; expected a grey (V, U) or BGR "
                         f"(V, U, 3) image")
    if image.dtype.kind not in "fu":
        raise ValueError(f"image has dtype {image.dtype}; expected uint8, uint16 or float")
    return cv2.cvtColor(plot.to_display(image), cv2.COLOR_BGR2GRAY)


def prepare_light_field(lf: np.ndarray, gamma: float = 0.5, equalise=True) -> np.ndarray:
    """The paper's greyscale for SfM in 8 bits: :func:`liff.preprocess.prepare`
    (luminance, gamma, one histogram mapping for the whole light field, as the
    authors' code does it), rounded to uint8 so that cv2.SIFT can take the centre view.

    Parameters
    ----------
    lf : ndarray, shape (T, S, V, U[, C]) or (V, U[, C])
        uint8 (/255), uint16 (/65535) or float nominally in [0, 1] (clipped); colour is
        BGR, turned grey by luminance 0.299 R + 0.587 G + 0.114 B. A weight / alpha
        channel (C = 2 or 4) is kept as a second channel (docs/INPUTS.md).
    gamma : float
        Exponent applied to the [0, 1] intensities (the paper: 0.5).
    equalise : bool or {"stretch", "cdf"}
        Histogram step: True is "stretch" (the authors' code), "cdf" classic
        equalisation, False none (see :func:`liff.preprocess.equalize`).

    Returns
    -------
    ndarray of uint8, shape (T, S, V, U) or (V, U)
        Its centre view is what SIFT on the centre view should see. (T, S, V, U, 2)
        or (V, U, 2), grey + weight, for input with a weight channel.

    Raises
    ------
    ValueError
        From :func:`liff.preprocess.prepare`, naming the input's shape.
    """
    try:
        grey = preprocess.prepare(lf, luminance=True, gamma=gamma, equalize=equalise)
    except ValueError as error:
        raise ValueError(f"input of shape {np.shape(lf)}: {error}") from None
    return np.round(grey * 255).astype(np.uint8)
