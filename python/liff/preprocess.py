"""The LiFF paper's preprocessing for structure from motion, one step per function.

The paper's SfM runs converted each light field to grey by luminance, applied gamma
0.5 and equalised its histogram. :func:`prepare` chains the three; each step is also
available on its own (:func:`to_float`, :func:`to_luminance`, :func:`apply_gamma`,
:func:`equalize`).

Every function takes a light field (T, S, V, U[, C]) or an image (V, U[, C]) (a channel
axis exists when ``ndim`` is 3 or 5), of dtype uint8, uint16, float32 or float64, and
returns a new float32 array with intensities in [0, 1]: uint8 is divided by 255,
uint16 by 65535, floats are clipped to [0, 1]. Any byte order is accepted (a big-endian
``'>u2'`` array is uint16). The input is never modified.

A 2nd channel (grey + weight) or 4th channel (BGRA) is the per-sample weight / alpha
(docs/INPUTS.md). It is carried through every step unchanged apart from the same
dtype scaling (uint8 alpha 255 becomes 1.0); the equalisation histogram counts each
sample by its weight, so invalid (weight 0) samples do not shape the mapping.
"""

from __future__ import annotations

import math
import numbers
from typing import Optional, Tuple, Union

import numpy as np

from .io.images import LIGHT_FIELD_DTYPES

__all__ = ["to_float", "to_luminance", "apply_gamma", "equalize", "prepare", "border_mask"]

#: BT.601 luminance weights for B, G, R (OpenCV's COLOR_BGR2GRAY, MATLAB's rgb2gray)
BGR_LUMINANCE = (0.114, 0.587, 0.299)
_SCALE = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}
#: bins of the equalisation histogram over [0, 1] (the LiFF authors' LiFF_HistEqualize: 2^16)
HISTOGRAM_BINS = 65536
_METHODS = ("stretch", "cdf")


def _native(dtype: np.dtype) -> np.dtype:
    """``dtype`` in native byte order ('>u2' -> uint16), for the dtype checks and scales."""
    return dtype.newbyteorder("=")


def _channel_layout(array: np.ndarray) -> Tuple[int, bool]:
    """(channel count, has a weight channel); raises ValueError for other shapes/dtypes."""
    if array.ndim not in (2, 3, 4, 5) or 0 in array.shape:
        raise ValueError(f"array has shape {array.shape}; expected a light field (T, S, V, U[, C]) "
                         f"or an image (V, U[, C])")
    if _native(array.dtype) not in LIGHT_FIELD_DTYPES:
        raise ValueError(f"array has dtype {array.dtype}; expected uint8, uint16, float32 or "
                         f"float64")
    channels = array.shape[-1] if array.ndim in (3, 5) else 1
    if channels not in (1, 2, 3, 4):
        raise ValueError(f"array has {channels} channels (shape {array.shape}); expected 1 (grey), "
                         f"2 (grey + weight), 3 (BGR) or 4 (BGRA)")
    return channels, channels in (2, 4)


def _split(array: np.ndarray):
    """(intensity channels, weight or None) of a float32 array, as views."""
    channels, weighted = _channel_layout(array)
    if not weighted:
        return array, None
    return array[..., :-1], array[..., -1]


def _join(intensity: np.ndarray, weight) -> np.ndarray:
    if weight is None:
        return intensity
    if intensity.ndim == weight.ndim:  # grey without a channel axis
        intensity = intensity[..., None]
    return np.concatenate([intensity, weight[..., None]], axis=-1)


def to_float(light_field: np.ndarray) -> np.ndarray:
    """A float32 copy in [0, 1], same shape.

    uint8 is divided by 255, uint16 by 65535; float intensities are clipped to [0, 1]
    (a weight channel is only cast to float32).

    Raises
    ------
    ValueError
        For a shape, dtype or channel count liff does not accept, or NaN / infinity.
    """
    array = np.asarray(light_field)
    _, weighted = _channel_layout(array)
    scale = _SCALE.get(_native(array.dtype))  # astype below also converts the byte order
    if scale is not None:
        result = array.astype(np.float32)
        result /= np.float32(scale)
        return result
    if not np.isfinite(array).all():
        raise ValueError("array holds NaN or infinity; expected finite values in [0, 1]")
    result = array.astype(np.float32)  # always a copy: the input stays as it is
    intensity = result[..., :-1] if weighted else result
    np.clip(intensity, 0.0, 1.0, out=intensity)
    return result


def to_luminance(light_field: np.ndarray) -> np.ndarray:
    """Grey by BT.601 luminance, ``0.299 R + 0.587 G + 0.114 B`` (BGR order, as
    ``cv2.COLOR_BGR2GRAY`` but in float, without rounding).

    Returns
    -------
    ndarray of float32 in [0, 1]
        (T, S, V, U) for BGR or grey input, (T, S, V, U, 2) grey + weight for BGRA or
        grey + weight input (images likewise without T, S). A single channel axis is
        dropped.
    """
    intensity, weight = _split(to_float(light_field))
    if intensity.ndim in (3, 5) and intensity.shape[-1] == 3:
        blue, green, red = (intensity[..., c] for c in range(3))
        b, g, r = (np.float32(w) for w in BGR_LUMINANCE)
        grey = b * blue + g * green + r * red
        np.clip(grey, 0.0, 1.0, out=grey)  # the weights sum to 1, up to rounding
    else:
        grey = intensity[..., 0] if intensity.ndim in (3, 5) else intensity
    return _join(np.ascontiguousarray(grey), weight)


def apply_gamma(light_field: np.ndarray, gamma: float = 0.5) -> np.ndarray:
    """``I ** gamma`` on the intensity channels (0.5, the paper's value, brightens dark
    regions). Returns float32 in [0, 1], same shape; the weight channel is not raised.

    Raises
    ------
    ValueError
        If ``gamma`` is not a finite number > 0.
    """
    _check_gamma(gamma)
    return _apply_gamma(to_float(light_field), gamma)


def _check_gamma(gamma) -> None:
    try:
        valid = isinstance(gamma, numbers.Real) and math.isfinite(gamma) and float(gamma) > 0
    except OverflowError:  # an int beyond float
        valid = False
    if not valid:
        raise ValueError(f"gamma = {gamma!r}; expected a finite number > 0")


def _apply_gamma(result: np.ndarray, gamma: float) -> np.ndarray:
    """:func:`apply_gamma` in place on ``result``, float32 in [0, 1] as from :func:`to_float`."""
    intensity, _ = _split(result)
    np.power(intensity, np.float32(gamma), out=intensity)
    return result


def _weighted_histogram(intensity: np.ndarray, weight, bins: int) -> np.ndarray:
    """Counts (weighted) of the intensities in ``bins`` equal bins over [0, 1]."""
    counts = np.zeros(bins)
    # One leading index at a time: the bin indices of a whole Lytro light field would
    # take about a gigabyte.
    for i in range(intensity.shape[0]):
        part = intensity[i]
        index = np.minimum((part * bins).astype(np.intp), bins - 1).ravel()
        if weight is None:
            counts += np.bincount(index, minlength=bins)
        else:
            # one weight for all colour channels of a sample
            part_weight = np.broadcast_to(weight[i][..., None], part.shape)
            counts += np.bincount(index, weights=part_weight.ravel().astype(np.float64),
                                  minlength=bins)
    return counts


def equalize(light_field: np.ndarray, method: str = "stretch", cutoff_percent: float = 0.1,
             bins: int = HISTOGRAM_BINS) -> np.ndarray:
    """Histogram-based contrast adjustment with ONE mapping for the whole light field.

    One histogram is built over every view and every intensity channel, so each view
    (and each colour channel) goes through the same monotonic mapping and the views
    still agree with one another (per-view equalisation would make the focal stack
    average differently mapped views).

    Parameters
    ----------
    light_field : ndarray, (T, S, V, U[, C]) or (V, U[, C])
    method : {"stretch", "cdf"}
        "stretch" (the LiFF authors' ``LiFF_HistEqualize``, used for the paper's SfM
        runs): the intensities below the ``cutoff_percent`` and above the
        ``100 - cutoff_percent`` percentiles saturate to 0 and 1, those between are
        rescaled linearly. "cdf": classic equalisation, each intensity mapped to the
        fraction of samples below it (the histogram's cumulative sum, interpolated
        linearly within a bin), which makes the histogram about flat.
    cutoff_percent : float
        For "stretch": percent saturated at each end, in [0, 50).
    bins : int
        Histogram bins over [0, 1].

    Returns
    -------
    ndarray of float32 in [0, 1], same shape (weight channel passed through).
        A light field with a single intensity value is returned unchanged (as float).

    Raises
    ------
    ValueError
        For an unknown method, a cutoff that is not a number in [0, 50), ``bins`` not
        a whole number >= 2, or a weight channel that is zero everywhere.
    """
    bins = _check_equalize(method, cutoff_percent, bins)
    return _equalize(to_float(light_field), method, cutoff_percent, bins)


def _check_equalize(method, cutoff_percent, bins) -> int:
    """Raises ValueError for bad :func:`equalize` options; returns ``bins`` as an int."""
    if not (isinstance(method, str) and method in _METHODS):
        raise ValueError(f"method = {method!r}; expected 'stretch' or 'cdf'")
    if not (isinstance(cutoff_percent, numbers.Real) and 0 <= float(cutoff_percent) < 50):
        raise ValueError(f"cutoff_percent = {cutoff_percent!r}; expected a value in [0, 50)")
    whole = False
    if isinstance(bins, numbers.Real) and not isinstance(bins, (bool, np.bool_)):
        try:
            whole = math.isfinite(bins) and float(bins).is_integer()
        except (OverflowError, TypeError, ValueError):
            pass
    if not whole or bins < 2:
        raise ValueError(f"bins = {bins!r}; expected an integer >= 2")
    return int(bins)


def _equalize(result: np.ndarray, method: str, cutoff_percent: float, bins: int) -> np.ndarray:
    """:func:`equalize` in place on ``result``, float32 in [0, 1] as from :func:`to_float`;
    the options are checked (:func:`_check_equalize`)."""
    intensity, weight = _split(result)
    counts = _weighted_histogram(intensity, weight, bins)
    total = counts.sum()
    if total <= 0:
        raise ValueError("the weight channel is zero everywhere; expected some samples with "
                         "weight > 0 to build the histogram from")
    cdf = np.concatenate([[0.0], np.cumsum(counts) / total])  # at the bin edges
    edges = np.linspace(0.0, 1.0, bins + 1)
    if method == "cdf":
        for i in range(intensity.shape[0]):  # np.interp works in float64: a part at a time
            intensity[i] = np.interp(intensity[i], edges, cdf)
        return result
    cutoff = cutoff_percent / 100.0
    # Bin centres where the cumulative weight first reaches the cutoff / last stays
    # below 1 - cutoff (as LiFF_HistEqualize).
    centres = (edges[:-1] + edges[1:]) / 2
    lower = centres[np.searchsorted(cdf[1:], cutoff, side="left")]
    upper = centres[max(int(np.searchsorted(cdf[1:], 1.0 - cutoff, side="right")) - 1, 0)]
    if upper <= lower:  # almost all samples in one bin: fall back to the full range
        occupied = np.flatnonzero(counts)
        lower, upper = centres[occupied[0]], centres[occupied[-1]]
    if upper <= lower:
        return result
    intensity -= np.float32(lower)
    intensity *= np.float32(1.0 / (upper - lower))
    np.clip(intensity, 0.0, 1.0, out=intensity)
    return result


def prepare(light_field: np.ndarray, luminance: bool = True, gamma: float = 0.5,
            equalize: Union[bool, str] = True) -> np.ndarray:
    """The paper's SfM preprocessing: luminance, then gamma, then one-histogram
    equalisation, each step optional.

    Parameters
    ----------
    light_field : ndarray, (T, S, V, U[, C]) or (V, U[, C])
        uint8, uint16, float32 or float64, BGR(A) or grey (+ weight). Not modified.
    luminance : bool
        Convert colour to grey (:func:`to_luminance`); False keeps the channels.
    gamma : float or None
        Exponent for :func:`apply_gamma`; None or 1 skips the step.
    equalize : bool or {"stretch", "cdf"}
        True is "stretch" (the authors' method); False skips the step. See
        :func:`equalize`.

    Returns
    -------
    ndarray of float32 in [0, 1]
        Shape as :func:`to_luminance` gives it when ``luminance``, else as the input.
        A weight channel is kept last, unchanged but for dtype scaling.

    Raises
    ------
    ValueError
        For a bad ``gamma`` or ``equalize`` (checked before any work) or a light field
        liff does not accept.

    Notes
    -----
    "cdf" equalisation maps each intensity to its rank, so a gamma before it changes
    almost nothing (only through the histogram's binning); "stretch" is linear, so the
    gamma still shapes the result, as in the paper.
    """
    if gamma is not None:
        _check_gamma(gamma)
    method = _equalize_method(equalize)
    # One float32 copy, then every step in place on it.
    result = to_luminance(light_field) if luminance else to_float(light_field)
    if gamma is not None and gamma != 1:
        _apply_gamma(result, gamma)
    if method is not None:
        _equalize(result, method, 0.1, HISTOGRAM_BINS)
    return result


def _equalize_method(equalize) -> Optional[str]:
    """prepare()'s ``equalize`` as a method name, or None for no equalisation."""
    if equalize is True or (isinstance(equalize, np.bool_) and equalize):
        return "stretch"
    if isinstance(equalize, str):
        if equalize in _METHODS:
            return equalize
    elif equalize is None or (isinstance(equalize, numbers.Number) and not equalize):
        return None  # False, 0
    raise ValueError(f"equalize = {equalize!r}; expected True, False, 'stretch' or 'cdf'")


#: border_mask: a pixel is dark when its mean over the views is at most this share of the
#: 99th percentile of the means
BORDER_THRESHOLD = 0.05
#: border_mask: pixels this close (in pixels) to the dark border are dropped too
BORDER_MARGIN = 8


def border_mask(light_field: np.ndarray, threshold: float = BORDER_THRESHOLD,
                margin: int = BORDER_MARGIN) -> np.ndarray:
    """A detection mask that leaves out a lenslet capture's black, vignetted border.

    The main lens of a lenslet camera leaves the edges of every sub-aperture view dark;
    the edge between that border and the scene makes spurious features. The mask drops
    the pixels whose mean over the views (weighted by alpha, when there is a weight
    channel) is at most ``threshold`` times the 99th percentile of the means, or that no
    view sees (all alpha 0), *where they are connected to the edge of the image*: dark
    regions inside the scene are kept. Then it drops ``margin`` pixels more around them,
    where features would straddle the border. A capture without such a border gets a
    mask that keeps every pixel.

    Parameters
    ----------
    light_field : ndarray, shape (T, S, V, U[, C]), or an image (V, U[, C])
        uint8, uint16, float32 or float64; grey, BGR, grey + weight or BGRA. Not
        modified; read one view at a time.
    threshold : float
        In (0, 1).
    margin : int
        Pixels, >= 0.

    Returns
    -------
    ndarray of uint8, shape (V, U)
        255 where features are kept, 0 where they are not: the ``mask`` argument of
        ``LiFF.detect`` / ``detectAndCompute`` (``liff detect --mask auto``).

    Raises
    ------
    ValueError
        For a light field liff does not accept, or ``threshold`` / ``margin`` out of range.
    """
    import cv2

    array = np.asarray(light_field)
    _, weighted = _channel_layout(array)
    if not (isinstance(threshold, numbers.Real) and 0 < threshold < 1):
        raise ValueError(f"threshold = {threshold!r}; expected a number in (0, 1)")
    if not (isinstance(margin, numbers.Integral) and margin >= 0):
        raise ValueError(f"margin = {margin!r}; expected a whole number of pixels >= 0")
    if array.ndim in (2, 3):
        array = array[None, None]
    V, U = array.shape[2:4]
    total = np.zeros((V, U), np.float64)
    weights = np.zeros((V, U), np.float64)
    for view in array.reshape((-1,) + array.shape[2:]):
        grey = to_luminance(view)
        if weighted:
            total += grey[..., 0] * grey[..., 1]
            weights += grey[..., 1]
        else:
            total += grey
            weights += 1
    seen = weights > 1e-6 * weights.max() if weights.max() > 0 else np.zeros((V, U), bool)
    mean = np.divide(total, weights, out=np.zeros_like(total), where=seen)
    reference = float(np.percentile(mean[seen], 99)) if seen.any() else 0.0
    dark = ~seen | (mean <= threshold * reference)
    _, labels = cv2.connectedComponents(dark.astype(np.uint8), connectivity=8)
    edge = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    edge = edge[edge > 0]  # label 0: the pixels that are not dark
    keep = np.where(np.isin(labels, edge), 0, 255).astype(np.uint8)
    if margin > 0 and edge.size:
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * margin + 1, 2 * margin + 1))
        keep = cv2.erode(keep, disc, borderType=cv2.BORDER_CONSTANT, borderValue=255)
    return keep
