"""Intensity scale: is a light field on the scale liff reads its dtype on, and rescaling
data of a known bit depth to it.

The detector takes uint8 / 255, uint16 / 65535 and floats as given, nominally in
[0, 1] (docs/CONVENTIONS.md), and its thresholds (``contrastThreshold``) are on that
scale. Data that fill only part of the range (10- or 12-bit sensor values in uint16),
or exceed it (floats in 0..255), give no features or many noise features without any
error: :func:`check_intensity` warns about them, :func:`scale_bit_depth` fixes them.
"""

from __future__ import annotations

import math
import warnings
from typing import Optional, Tuple

import numpy as np

from .._warnings import IntensityWarning
from ._shared import positive_int

#: uint16 data whose largest value is below this use at most 14 of the 16 bits: the
#: detector sees at most a quarter of the contrast it would on full-range data
UINT16_LOW = 1 << 14
#: floats up to this are taken to be in [0, 1] (rounding may overshoot 1 a little)
FLOAT_HIGH = 1.01
#: floats beyond [0, FLOAT_HIGH] are on another scale only when the centre view's median
#: is too: sensor noise and highlights push [0, 1] data past its ends, 0..255 data sits
#: far beyond
FLOAT_MEDIAN_HIGH = 1.0
#: floats whose largest value is below this use at most 1/16 of [0, 1]
FLOAT_LOW = 1 / 16
#: views sampled by :func:`intensity_range` on each view axis (plus the centre view)
SAMPLED_VIEWS = 3


def _channels(array: np.ndarray) -> Tuple[int, bool]:
    """(channel count, has a weight channel) of a light field or image: the channel
    axis exists when ``ndim`` is 3 or 5."""
    channels = array.shape[-1] if array.ndim in (3, 5) else 1
    return channels, channels in (2, 4)


def intensity_range(light_field: np.ndarray) -> Tuple[float, float]:
    """(smallest, largest) intensity of a light field, from a sample of whole views.

    Parameters
    ----------
    light_field : ndarray, shape (T, S, V, U[, C]), or an image (V, U[, C])
        A last channel of C = 2 or 4 is a weight, not an intensity, and is left out.

    Returns
    -------
    (float, float)
        Over the centre view and views spread over the grid (``SAMPLED_VIEWS`` per view
        axis: the first, middle and last row and column), every pixel of each: a bright
        highlight is not missed within a sampled view. The array is only read.
    """
    array = np.asarray(light_field)
    if array.ndim in (2, 3):  # an image: one view
        array = array[None, None]
    if array.ndim not in (4, 5) or array.size == 0:
        raise ValueError(f"light field has shape {array.shape}; expected (T, S, V, U[, C]) or "
                         f"an image (V, U[, C])")
    T, S = array.shape[:2]
    channels, weighted = _channels(array)
    rows = np.unique(np.round(np.linspace(0, T - 1, SAMPLED_VIEWS)).astype(int))
    cols = np.unique(np.round(np.linspace(0, S - 1, SAMPLED_VIEWS)).astype(int))
    views = {(t, s) for t in rows for s in cols} | {(T // 2, S // 2)}
    low, high = math.inf, -math.inf
    for t, s in sorted(views):
        view = array[t, s]
        # channel by channel: numpy reduces one strided channel far faster than a
        # (pixels, channels - 1) slice
        for part in ([view[..., c] for c in range(channels - 1)] if weighted else [view]):
            low, high = min(low, float(part.min())), max(high, float(part.max()))
    return low, high


def _off_scale(array: np.ndarray) -> bool:
    """Whether the centre view (its weight channel left out) sits on another scale than
    [0, 1]: its median above FLOAT_MEDIAN_HIGH, or a quarter of it negative. Noise and
    highlights push [0, 1] data past its ends without moving these."""
    view = array if array.ndim in (2, 3) else array[array.shape[0] // 2, array.shape[1] // 2]
    channels, weighted = _channels(array)
    if weighted:
        view = view[..., :channels - 1]
    with np.errstate(invalid="ignore"):  # NaN (refused by the core, naming it) is no scale
        quarter, median = np.percentile(view, [25, 50])
    return bool(median > FLOAT_MEDIAN_HIGH or quarter < 0)


def check_intensity(light_field: np.ndarray, source: Optional[str] = None,
                    stacklevel: int = 2) -> Optional[str]:
    """Warns (:class:`liff.IntensityWarning`) when a light field's values are off the scale
    the detector reads its dtype on; cheap (a sample of views, :func:`intensity_range`)
    and read-only.

    Parameters
    ----------
    light_field : ndarray, shape (T, S, V, U[, C]), or an image (V, U[, C])
        uint8, uint16, float32 or float64 (other dtypes and shapes are not checked
        here, and never raise: the detector reports them). A last channel of C = 2 or 4
        is a weight and is not checked.
    source : str, optional
        Named at the start of the message (e.g. the file the light field came from).
    stacklevel : int
        Passed to ``warnings.warn``: 2 points at the caller of this function; a wrapper
        that calls it on its caller's behalf passes 3.

    Returns
    -------
    str or None
        The warning's message, or None when the values look right: uint8 always; uint16
        with values reaching 2**14 or more; floats reaching 1/16 or more, in [0, 1.01]
        or with a centre view on the [0, 1] scale (see Notes).

    Notes
    -----
    Warned about, with the range seen and the fix: uint16 whose largest value is below
    2**14 (10-, 12- or 14-bit sensor data, which the detector divides by 65535 and so
    sees with a 64th, 16th or 4th of its contrast: few or no features); floats above
    1.01 (e.g. 0..255: the detector sees 255 times the contrast, many noise features)
    or below 0 when the centre view's median is above 1 or a quarter of it negative
    (noise and highlights alone push [0, 1] data past its ends); floats whose largest
    value is below 1/16.
    An all-zero light field is not warned about.
    """
    array = np.asarray(light_field)
    if array.dtype.kind not in "uf" or array.ndim not in (2, 3, 4, 5) or array.size == 0:
        return None  # not a light field liff takes: the detector says what is wrong
    dtype = array.dtype.newbyteorder("=")
    if dtype not in (np.uint16, np.float32, np.float64):
        return None
    low, high = intensity_range(array)
    seen = f"values in [{low:g}, {high:g}]"
    message = None
    if dtype == np.uint16 and 0 < high < UINT16_LOW:
        bits = max(8, math.ceil(math.log2(high + 1)))
        message = (f"light field is uint16 with {seen} (sampled views): {bits}-bit data? liff "
                   f"divides uint16 by 65535, so it sees 1/{65535 / (2 ** bits - 1):.0f} of the "
                   f"contrast and finds few or no features; read it with bit_depth={bits} "
                   f"(--bit-depth {bits}), or scale it: lf * (65535 / {2 ** bits - 1})")
    elif dtype != np.uint16 and (high > FLOAT_HIGH or low < 0) and _off_scale(array):
        if low >= 0 and high <= 65535:
            bits = 8 if high <= 255 else math.ceil(math.log2(high + 1))
            fix = (f"read it with bit_depth={bits} (--bit-depth {bits}), or scale it: "
                   f"lf / {2 ** bits - 1}")
        else:
            fix = "scale it to [0, 1], e.g. (lf - lf.min()) / (lf.max() - lf.min())"
        message = (f"light field is {dtype} with {seen} (sampled views): liff takes floats as "
                   f"intensities in [0, 1], so its thresholds are off (too many noise features, "
                   f"or none); {fix}")
    elif dtype != np.uint16 and 0 < high < FLOAT_LOW:
        message = (f"light field is {dtype} with {seen} (sampled views): it uses 1/"
                   f"{1 / high:.0f} of the [0, 1] range liff takes floats on, so the detector "
                   f"finds few or no features; scale it to [0, 1] (e.g. lf / lf.max(), or "
                   f"lf * (65535 / 4095) for 12-bit data that was divided by 65535)")
    if message is None:
        return None
    if source:
        message = f"{source}: {message}"
    warnings.warn(message, IntensityWarning, stacklevel=stacklevel)
    return message


def scale_bit_depth(light_field: np.ndarray, bit_depth, source: str = "light field") -> np.ndarray:
    """A light field of ``bit_depth``-bit values rescaled to the nominal range of its
    dtype: a new array, the input is not modified.

    Parameters
    ----------
    light_field : ndarray, shape (T, S, V, U[, C])
        uint8 or uint16 holding values up to ``2**bit_depth - 1``, or floats on that
        scale (e.g. 0..255 with ``bit_depth=8``). A weight channel (C = 2 or 4) is left
        as it is (only ratios of weights matter).
    bit_depth : int
        Bits per value, 1 to 16 (at most 8 for uint8).
    source : str
        Named in errors (the file).

    Returns
    -------
    ndarray, same shape
        uint8 / uint16: ``round(value * max / (2**bit_depth - 1))`` in the same dtype
        (max = 255 or 65535; the input itself when ``bit_depth`` is the dtype's own);
        floats: ``value / (2**bit_depth - 1)`` in the same dtype.

    Raises
    ------
    ValueError
        Naming ``source``: ``bit_depth`` not a whole number in 1..16, more bits than
        the dtype holds, another dtype, or values above ``2**bit_depth - 1``.
    """
    bits = positive_int(bit_depth, "bit_depth", source, 1, "a whole number of bits from 1 to 16")
    if bits > 16:
        raise ValueError(f"{source}: bit_depth = {bit_depth!r}; expected a whole number of bits "
                         f"from 1 to 16")
    array = np.asarray(light_field)
    dtype = array.dtype.newbyteorder("=")
    if dtype not in (np.uint8, np.uint16, np.float32, np.float64):
        raise ValueError(f"{source}: light field has dtype {array.dtype}; expected uint8, uint16, "
                         f"float32 or float64 to rescale")
    if dtype.kind == "u" and bits > 8 * dtype.itemsize:
        raise ValueError(f"{source}: bit_depth = {bits} for a {dtype} light field; expected at "
                         f"most {8 * dtype.itemsize} bits")
    if array.ndim not in (4, 5) or array.size == 0:
        raise ValueError(f"{source}: light field has shape {array.shape}; expected (T, S, V, U[, C])")
    top = (1 << bits) - 1
    weighted = _channels(array)[1]

    def intensities(view: np.ndarray) -> np.ndarray:
        return view[..., :-1] if weighted else view

    high = max(float(intensities(view).max()) for view in array.reshape((-1,) + array.shape[2:]))
    if high > top:
        raise ValueError(f"{source}: values up to {high:g} exceed {top}, the largest "
                         f"{bits}-bit value; expected bit_depth >= {math.ceil(math.log2(high + 1))}")
    if dtype.kind == "u" and bits == 8 * dtype.itemsize:
        return array
    out = array.astype(dtype, copy=True)
    full = np.iinfo(dtype).max if dtype.kind == "u" else None
    for view in out.reshape((-1,) + out.shape[2:]):  # one view at a time: bounded memory
        part = intensities(view)
        if full is None:
            part /= top
        else:  # in uint32: exact rounding
            part[...] = (part.astype(np.uint32) * full + top // 2) // top
    return out
