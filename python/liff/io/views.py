"""Folders of sub-aperture views whose file names carry the view's row and column.

Examples of names read without options: ``scene_03_04.png``, the Stanford gantry's
``out_03_04_-859.738525_1022.898743.png``, ``3_4.tif``, ``view_1_12.png``: the first
two ``_``-separated whole numbers of the name (without its ending) are the view row
``t`` and column ``s``. Indices may start at 0 or 1 and need not be zero-padded.
"""

from __future__ import annotations

import itertools
import os
import re
from typing import Dict, List, Optional, Pattern, Tuple, Union

import numpy as np

from ._shared import (IMAGE_SUFFIXES, LightFieldFile, PathLike, as_image, check_writable,
                      describe_missing, grid_size, read_image, write_image)

# Row and column: the first two whole numbers separated by "_", each standing at the
# start of the name or after "_", "-" or ".", followed by the end or "_", "-", ".".
DEFAULT_NAME = re.compile(r"^(?:.*?[_.\-])??(?P<t>\d+)_(?P<s>\d+)(?:[_.\-].*)?$")


def _compile(pattern: Union[str, Pattern, None], folder: str) -> Optional[Pattern]:
    if pattern is None:
        return None
    try:
        regex = re.compile(pattern)
    except re.error as e:
        raise ValueError(f"{folder}: pattern {pattern!r} is not a regular expression ({e})") from None
    groups = set(regex.groupindex)
    if not ({"t", "s"} <= groups or "index" in groups):
        raise ValueError(f"{folder}: pattern {regex.pattern!r} has groups {sorted(groups)}; "
                         f"expected named groups (?P<t>...) and (?P<s>...), or (?P<index>...)")
    return regex


def _find_views(folder: str, regex: Optional[Pattern], grid, linear: bool
                ) -> Dict[Tuple[int, int], str]:
    """{(t, s) as numbered in the names: file name} for the folder's views; with a
    running index (``linear``), {(index, 0): file name}."""
    numbered: Dict[Tuple[int, int], str] = {}
    if linear and grid is None:
        raise ValueError(f"{folder}: pattern {regex.pattern!r} numbers views by (?P<index>...); "
                         f"expected grid=(T, S) to go with it")
    for name in sorted(os.listdir(folder)):
        if regex is None:
            stem, suffix = os.path.splitext(name)
            m = DEFAULT_NAME.match(stem) if suffix.lower() in IMAGE_SUFFIXES else None
        else:
            m = regex.fullmatch(name)
        if not m:
            continue
        if linear:
            key = (int(m.group("index")), 0)
        else:
            key = (int(m.group("t")), int(m.group("s")))
        if key in numbered:
            raise ValueError(f"{folder}: {numbered[key]} and {name} are both view "
                             f"{key[0] if linear else key}; expected one file per view")
        numbered[key] = name
    if not numbered:
        expected = (f"file names matching {regex.pattern!r}" if regex is not None else
                    f"images ({', '.join(IMAGE_SUFFIXES)}) named like scene_RR_CC.png")
        raise ValueError(f"{folder}: no views found; expected {expected}")
    return numbered


def _arrange(folder: str, numbered: Dict[Tuple[int, int], str], grid, linear: bool):
    """(T, S, first index, {(t, s) 0-based: name})."""
    indices = [i for key in numbered for i in (key[:1] if linear else key)]
    first = min(indices)
    if first not in (0, 1):
        raise ValueError(f"{folder}: the smallest view index in the names is {first}; expected "
                         f"indices starting at 0 or 1")
    if linear:
        T, S = grid_size(grid, folder)
        views = {divmod(i - first, S): name for (i, _), name in numbered.items()}
    else:
        views = {(t - first, s - first): name for (t, s), name in numbered.items()}
    found_t = 1 + max(t for t, _ in views)
    found_s = 1 + max(s for _, s in views)
    if grid is None:
        T, S = found_t, found_s
    else:
        T, S = grid_size(grid, folder)
        if found_t > T or found_s > S:
            raise ValueError(f"{folder}: names number views up to a {found_t}x{found_s} grid "
                             f"(first index {first}); expected grid={T, S} to hold them")
    missing_count = T * S - len(views)  # views holds distinct (t, s) inside the grid
    if missing_count:
        # Name the first few without listing a grid that huge indices can make enormous.
        missing = itertools.islice(((t, s) for t in range(T) for s in range(S)
                                    if (t, s) not in views), 6)
        shown = [f"(t={t + first}, s={s + first})" for t, s in missing]
        raise ValueError(f"{folder}: {missing_count} views missing for a {T}x{S} grid "
                         f"(first index {first}): {describe_missing(shown)}")
    return T, S, first, views


def read_views(folder: PathLike, grid=None, pattern: Union[str, Pattern, None] = None
               ) -> LightFieldFile:
    """Reads a folder of views named by row and column.

    Parameters
    ----------
    folder : path
        The folder. Files whose names do not match are ignored.
    grid : (int, int), optional
        (T, S). Without it the grid spans the indices found. With it, the names must fit
        in it and every view of it must be present.
    pattern : str or compiled regex, optional
        Matched against the whole file name (``re.fullmatch``, any ending) instead of the
        default rule; named groups ``t`` (row) and ``s`` (column), or ``index`` (row-major
        ``t * S + s``, needs ``grid``). Example: ``r"cam_(?P<s>\\d+)_(?P<t>\\d+)\\.png"``.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]) as stored (``cv2.IMREAD_UNCHANGED``; BGR,
        alpha kept as the last channel); ``metadata``: ``grid`` (T, S),
        ``first_index`` (0 or 1, as numbered in the names), ``files`` (T x S nested
        list of file names).

    Raises
    ------
    ValueError
        Naming the folder or file: not a folder, no views, two files for one view,
        indices not starting at 0 or 1, views missing, names outside ``grid``, or views
        of differing size, channel count or dtype.
    """
    folder = os.fspath(folder)
    if not os.path.isdir(folder):
        raise ValueError(f"{folder}: not a folder; expected a folder of views")
    regex = _compile(pattern, folder)
    linear = regex is not None and "t" not in regex.groupindex
    T, S, first, views = _arrange(folder, _find_views(folder, regex, grid, linear), grid, linear)

    light_field: Optional[np.ndarray] = None
    for (t, s), name in sorted(views.items()):
        path = os.path.join(folder, name)
        image = read_image(path)
        if light_field is None:
            reference, first_name = image, name
            light_field = np.empty((T, S) + image.shape, image.dtype)
        elif image.shape != reference.shape or image.dtype != reference.dtype:
            raise ValueError(f"{path}: view is {_describe(image)}; expected "
                             f"{_describe(reference)} like {first_name}")
        light_field[t, s] = image
    files = [[views[t, s] for s in range(S)] for t in range(T)]
    metadata = {"grid": (T, S), "first_index": first, "files": files}
    return LightFieldFile(light_field, "views", metadata, None, folder)


def _describe(image: np.ndarray) -> str:
    channels = 1 if image.ndim == 2 else image.shape[2]
    return f"{image.shape[1]}x{image.shape[0]}, {channels} channel(s), {image.dtype}"


def write_views(folder: PathLike, light_field: np.ndarray,
                pattern: str = "view_{t:02d}_{s:02d}.png") -> List[str]:
    """Writes each view of a light field as an image.

    Parameters
    ----------
    folder : path
        Created if absent. Files already there are left alone (a smaller light field
        written over a larger one leaves the old extra views behind).
    light_field : ndarray, shape (T, S, V, U[, C])
        uint8, or uint16 for .png/.tif; C in {1, 3, 4} (BGR / BGRA).
    pattern : str
        ``str.format`` pattern with fields ``t`` and ``s`` (0-based); its ending picks
        the image format. The default reads back with :func:`read_views`.

    Returns
    -------
    list of str
        The paths written, row-major.

    Raises
    ------
    ValueError
        If the light field cannot be stored in that image format, or the pattern gives
        two views the same name.
    """
    folder = os.fspath(folder)
    light_field = check_writable(light_field, os.path.join(folder, pattern))
    T, S = light_field.shape[:2]
    names = [pattern.format(t=t, s=s) for t in range(T) for s in range(S)]
    if len(set(names)) != len(names):
        raise ValueError(f"{folder}: pattern {pattern!r} gives views the same file name; "
                         f"expected a pattern with both {{t}} and {{s}}")
    os.makedirs(folder, exist_ok=True)
    paths = [os.path.join(folder, name) for name in names]
    for index, path in enumerate(paths):
        write_image(path, as_image(light_field[index // S, index % S]))
    return paths
