"""What the format modules share: the result type and array checks (image reading and
writing are public, in :mod:`liff.io.images`).

Nothing here knows a particular layout; each ``liff.io`` format module builds on these.
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass, field
from typing import Iterable, Optional, Sequence, Tuple

import numpy as np

from .._paths import refuse_special
from .._warnings import MissingViewsWarning

# The image helpers are public (liff.io.images); the readers take them from here too.
from .images import (  # noqa: F401
    IMAGE_SUFFIXES,
    LIGHT_FIELD_DTYPES,
    SIXTEEN_BIT_SUFFIXES,
    PathLike,
    as_image,
    read_image,
    write_image,
)


@dataclass
class LightFieldFile:
    """A light field read from disk.

    Attributes
    ----------
    light_field : ndarray, shape (T, S, V, U) or (T, S, V, U, C)
        As stored (uint8, uint16, float32 or float64; BGR colour). C is 1, 3, or 2/4
        when the last channel is an alpha / per-sample weight (docs/INPUTS.md).
    format : str
        The reader that produced it: "hci", "views", "eslf", "mosaic", "npy" or "npz".
    metadata : dict
        Format-specific facts (grid, lenslet size, files, ...); see docs/INPUTS.md.
    gt_disparity : ndarray of float32, shape (V, U), or None
        Ground-truth disparity of the centre view in pixels per view step (= liff's
        slope), when the format carries one.
    source : str
        The path that was read.
    """

    light_field: np.ndarray
    format: str
    metadata: dict = field(default_factory=dict)
    gt_disparity: Optional[np.ndarray] = None
    source: str = ""


def check_light_field(array: np.ndarray, source: str) -> np.ndarray:
    """Returns ``array`` if it is a light field liff accepts, else raises. A non-native
    byte order (e.g. big-endian ``'>u2'``) is accepted: the result is then a copy in
    native byte order (``'>u2'`` becomes uint16).

    Raises
    ------
    ValueError
        Naming ``source``: not 4-D or 5-D, an empty axis, C not in {1, 2, 3, 4}, or a
        dtype other than uint8, uint16, float32, float64.
    """
    if not isinstance(array, np.ndarray):  # e.g. a .npz member that is not a .npy
        raise ValueError(f"{source}: holds {type(array).__name__}, not an array; expected a "
                         f"light field (T, S, V, U) or (T, S, V, U, C)")
    if array.ndim not in (4, 5):
        raise ValueError(f"{source}: array has shape {array.shape}; expected a light field "
                         f"(T, S, V, U) or (T, S, V, U, C)")
    if 0 in array.shape:
        raise ValueError(f"{source}: array has shape {array.shape}; expected no empty axis")
    if array.ndim == 5 and array.shape[4] not in (1, 2, 3, 4):
        raise ValueError(f"{source}: array has {array.shape[4]} channels (shape {array.shape}); "
                         f"expected C in 1, 2, 3, 4")
    array = native_byte_order(array)  # e.g. np.save of '>f4': the values, in native order
    if array.dtype not in LIGHT_FIELD_DTYPES:
        raise ValueError(f"{source}: array has dtype {array.dtype}; expected uint8, uint16, "
                         f"float32 or float64")
    return array


def check_disparity(disparity, light_field: np.ndarray, source: str) -> np.ndarray:
    """A ground-truth disparity map stored beside a light field, as float32 (V, U).

    Raises
    ------
    ValueError
        Naming ``source``: not an array of the views' size (V, U), or not real numbers.
    """
    if not isinstance(disparity, np.ndarray) or disparity.shape != light_field.shape[2:4]:
        raise ValueError(f"{source}: shape {getattr(disparity, 'shape', None)}; "
                         f"expected the views' (V, U) = {light_field.shape[2:4]}")
    if disparity.dtype.kind not in "biuf":  # astype would parse strings, drop imaginary parts
        raise ValueError(f"{source}: dtype {disparity.dtype}; expected real "
                         f"numbers (disparity in pixels per view step)")
    return disparity.astype(np.float32)


def native_byte_order(array: np.ndarray) -> np.ndarray:
    """``array`` itself, or a copy in native byte order if it is stored otherwise (a
    big-endian ``'>f4'`` becomes float32 with the same values)."""
    if array.dtype.isnative:
        return array
    return array.astype(array.dtype.newbyteorder("="))


def positive_int(value, name: str, source: str, minimum: int = 1,
                 expected: Optional[str] = None) -> int:
    """``value`` as an int if it is a whole number >= ``minimum``, else a ValueError
    ``"{source}: {name} = {value!r}; expected {expected}"``.

    Whole numbers of any real type are accepted (2, 2.0, np.int64(2)); fractions (2.9),
    NaN, infinity, bools, strings and other types are refused rather than truncated.
    ``expected`` defaults to "an integer >= {minimum}".
    """
    number = None
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
        number = int(value)
    elif isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        try:
            as_float = float(value)
            if math.isfinite(as_float) and as_float.is_integer():
                number = int(as_float)
        except (OverflowError, TypeError, ValueError):  # e.g. a Fraction beyond float
            pass
    if number is None or number < minimum:
        raise ValueError(f"{source}: {name} = {value!r}; expected "
                         f"{expected or f'an integer >= {minimum}'}")
    return number


def grid_size(grid, source: str, name: str = "grid") -> Tuple[int, int]:
    """``grid`` as a pair of positive ints (T, S); raises ValueError naming ``source``
    (and the option ``name``) for anything but two whole numbers >= 1."""
    try:
        rows, cols = grid
    except (TypeError, ValueError):
        raise ValueError(f"{source}: {name} {grid!r}; expected two view counts (T, S)") from None
    expected = "positive whole view counts (T, S)"
    return (positive_int(rows, f"{name} {grid!r}: T", source, 1, expected),
            positive_int(cols, f"{name} {grid!r}: S", source, 1, expected))


def centre_range(count: int, keep: int) -> slice:
    """The centre ``keep`` of ``count`` indices: ``slice(first, first + keep)`` with
    ``first = (count - keep) // 2``, so for an odd surplus the extra index dropped is
    the last one (14 -> 11 keeps 1..11, as the LiFF authors' ``LF(2:end-2)``)."""
    first = (count - keep) // 2
    return slice(first, first + keep)


def centre_views(light_field: np.ndarray, keep) -> np.ndarray:
    """The centre views of a light field (a view of the array, not a copy).

    Parameters
    ----------
    light_field : ndarray, shape (T, S, V, U[, C])
    keep : int or (int, int)
        How many view rows and columns to keep (one int: the same for both). For each
        axis the first kept view is ``(T - keep) // 2``: when ``T - keep`` is odd the
        extra view dropped is at the bottom / right.

    Returns
    -------
    ndarray, shape (keep_t, keep_s, V, U[, C])
    """
    rows, cols = grid_size((keep, keep) if np.isscalar(keep) else keep, "centre_views", "keep")
    T, S = light_field.shape[:2]
    if rows > T or cols > S:
        raise ValueError(f"centre_views: keep {rows}x{cols} views of a {T}x{S} grid; expected "
                         f"at most {T}x{S}")
    return light_field[centre_range(T, rows), centre_range(S, cols)]


def check_writable(light_field: np.ndarray, path: PathLike) -> np.ndarray:
    """Checks that ``light_field`` can be written as images at ``path`` (by ending).

    Raises
    ------
    ValueError
        Naming ``path``: not a light field, a dtype other than uint8 (or uint16 for
        PNG/TIFF), or 2 channels (OpenCV writes only 1, 3 or 4).
    """
    path = os.fspath(path)
    light_field = check_light_field(np.asarray(light_field), path)
    suffix = os.path.splitext(path)[1].lower()
    allowed = ("uint8", "uint16") if suffix in SIXTEEN_BIT_SUFFIXES else ("uint8",)
    if light_field.dtype.name not in allowed:
        raise ValueError(f"{path}: light field has dtype {light_field.dtype}; expected "
                         f"{' or '.join(allowed)} for {suffix or 'this'} images (scale floats "
                         f"explicitly, e.g. np.round(lf * 255).astype(np.uint8))")
    channels = light_field.shape[4] if light_field.ndim == 5 else 1
    if channels == 2:
        raise ValueError(f"{path}: light field has 2 channels (grey + alpha); expected 1, 3 or 4 "
                         f"for images (OpenCV cannot write grey + alpha: repeat the grey "
                         f"channel to BGRA, or save .npz)")
    return light_field


def pick_key(source: str, names: Sequence[str], key: Optional[str], preferred: str,
             candidates: Sequence[str], kind: str = "array") -> str:
    """The name of the stored array to read: ``key`` if given, else ``preferred`` if
    present, else the only one of ``candidates``.

    Raises
    ------
    ValueError
        Naming ``source``: ``key`` absent, or no ``key`` and no single choice (listing
        ``names``).
    """
    names = sorted(names)
    if key is None:
        if preferred in names:
            key = preferred
        elif len(candidates) == 1:
            key = candidates[0]
        elif {"keypoints", "descriptors", "meta"} <= set(names):
            raise ValueError(f"{source}: a liff feature file (keypoints and descriptors, as "
                             "liff detect writes them), not a light field; expected a light "
                             "field")
        else:
            raise ValueError(f"{source}: {kind}s {names}; expected one named {preferred!r}, a "
                             f"single {kind}, or key=...")
    if key not in names:
        raise ValueError(f"{source}: no {kind} {key!r}; expected one of {names}")
    return key


def rgb_to_bgr(array: np.ndarray) -> np.ndarray:
    """A light field (T, S, V, U, C) stored with RGB colour (MATLAB, HDF5 files) in liff's
    channel order: C = 3 (RGB) or 4 (RGB + weight) become BGR / BGR + weight, C = 1 is
    dropped to (T, S, V, U), C = 2 (grey + weight) and 4-D arrays are returned as they
    are. Other shapes are returned unchanged, for :func:`check_light_field` to refuse."""
    if array.ndim != 5 or array.shape[4] not in (1, 3, 4):
        return array
    if array.shape[4] == 1:
        return array[..., 0]
    return array[..., [2, 1, 0, 3][: array.shape[4]]]


def stored_file(path: PathLike, key, what: str, key_is: str) -> str:
    """``path`` as a str, once it is known to be a file and ``key`` None or a str.

    Raises
    ------
    ValueError
        Naming ``path``: no such file (expected ``what``), or ``key`` not a str
        (expected ``key_is``).
    """
    path = os.fspath(path)
    refuse_special(path, what)
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file; expected {what}")
    if key is not None and not isinstance(key, str):
        raise ValueError(f"{path}: key {key!r}; expected {key_is} (str)")
    return path


def rgb_light_field(array, source: str) -> np.ndarray:
    """A stored RGB(+weight) array as a C-contiguous light field in liff's channel order
    (:func:`rgb_to_bgr`, then :func:`check_light_field`, which raises naming ``source``)."""
    light_field = check_light_field(rgb_to_bgr(array), source)
    return light_field if light_field.flags.c_contiguous else np.ascontiguousarray(light_field)


def required_module(name: str, purpose: str):
    """Imports the dependency ``name`` (SciPy, h5py: installed with liff); raises an
    ImportError saying how to install it when it is missing all the same (an
    installation that skipped dependencies)."""
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError as error:
        package = name.split(".")[0]
        raise ImportError(f"{purpose} needs {package}, a dependency of liff that is not "
                          f"installed here: pip install {package}") from error


#: views named at the most in a MissingViewsWarning (metadata["missing"] has them all)
MISSING_NAMED = 20


def check_incomplete(source: str, grid: Tuple[int, int], present: int, missing: Iterable[str],
                     numbered: str = "") -> None:
    """The rule for incomplete view sets, shared by the readers of views: a set of any
    pattern is read as the whole ``grid`` with the missing views at alpha 0, and a
    :class:`liff.MissingViewsWarning` names them (the first :data:`MISSING_NAMED` of
    ``missing``, an iterable of names, so a huge grid is not listed); a set of fewer
    views than the grid's longer side cannot be views of that grid (names whose numbers
    are not view indices, a few views in an enormous grid) and is refused.

    Raises
    ------
    ValueError
        Naming ``source``, the grid and the first missing views.
    """
    import itertools
    import warnings

    T, S = grid
    count = T * S - present
    shown = list(itertools.islice(missing, MISSING_NAMED + 1))
    where = f" ({numbered})" if numbered else ""
    if present < max(T, S):
        raise ValueError(f"{source}: {count} views missing for a {T}x{S} grid{where}: "
                         f"{describe_missing(shown)}; expected at least {max(T, S)} views (the "
                         f"grid's longer side) for an incomplete set: {present} view(s) in so "
                         f"large a grid are more likely names whose numbers are not view "
                         f"indices (give pattern= or grid=)")
    warnings.warn(f"{source}: {count} of {T * S} views missing from the {T}x{S} grid{where}: "
                  f"{describe_missing(shown, MISSING_NAMED)}; read with alpha 0 there, so LiFF "
                  f"uses the {present} views present", MissingViewsWarning, stacklevel=3)


def describe_missing(names: Sequence[str], limit: int = 5) -> str:
    """The first ``limit`` names, comma-separated, with ' ...' if there are more."""
    return ", ".join(names[:limit]) + (" ..." if len(names) > limit else "")
