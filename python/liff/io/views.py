"""Folders of sub-aperture views whose file names carry the view's row and column.

Examples of names read without options: ``scene_03_04.png``, the Stanford gantry's
``out_03_04_-859.738525_1022.898743.png``, ``3_4.tif``, ``view_1_12.png``, and Lytro
dataset names with a scene id before the indices, ``0421_03_07.png`` (scene 421, row 3,
column 7). Indices need not start at 0 or 1 (a crop of a larger grid, rows 8..10, reads
as a 3-row grid) and need not be zero-padded.

Incomplete sets of any pattern (a cross or star of views through the centre, as some
datasets ship) are read as the whole grid with a weight (alpha) of 0 for the missing
views, so that LiFF uses the views that exist (docs/CONVENTIONS.md, alpha); a
MissingViewsWarning names them.
"""

from __future__ import annotations

import os
import re
import shlex
from typing import Dict, List, Optional, Pattern, Tuple, Union

import numpy as np

from .._budget import array_bytes, check_fits
from ._shared import (
    IMAGE_SUFFIXES,
    LightFieldFile,
    PathLike,
    as_image,
    check_incomplete,
    check_writable,
    grid_size,
    read_image,
    write_image,
)
from .images import header_size

# A run of two or more whole numbers joined by "_", the first number at the start of the
# name or after "_", "-" or ".", the run followed by the end of the name or "_", "-", ".";
# the parts of a decimal number (the gantry's "_311.025773_") are not whole numbers.
# The first run in a name holds the view indices (see _indices_in_runs).
NUMBER_RUN = re.compile(r"(?:^|(?<=[_\-])|(?<=(?<!\d)\.))(\d+(?:_\d+)+)(?=$|[_\-]|\.(?!\d))")


def compile_pattern(pattern: Union[str, Pattern, None], where: Optional[str],
                    name: str = "pattern") -> Optional[Pattern]:
    """``pattern`` (the views' file names) compiled and checked to have the named groups
    ``t`` and ``s``, or ``index``.

    Parameters
    ----------
    pattern : str, compiled regex or None
        None gives None.
    where : str or None
        What the message starts with (the folder), or None.
    name : str
        What the pattern is called in the message: ``pattern`` (the keyword of
        :func:`read_views`) or ``--pattern`` (the command line's flag).

    Raises
    ------
    ValueError
        If ``pattern`` is not a regular expression or lacks the groups.
    """
    if pattern is None:
        return None
    at = f"{where}: " if where else ""
    try:
        regex = re.compile(pattern)
    except re.error as e:
        raise ValueError(f"{at}{name} {shlex.quote(str(pattern))} is not a regular expression ({e}); expected "
                         f"a regular expression with {GROUPS}") from None
    groups = set(regex.groupindex)
    if not ({"t", "s"} <= groups or "index" in groups):
        raise ValueError(f"{at}{name} {shlex.quote(regex.pattern)} has groups {sorted(groups)}; "
                         f"expected {GROUPS}")
    return regex


#: what a views pattern must hold, for messages
GROUPS = "named groups (?P<t>...) and (?P<s>...), or (?P<index>...)"


def _indices_in_runs(folder: str, runs: Dict[str, Tuple[int, ...]]) -> Dict[str, Tuple[int, int]]:
    """{name: (t, s)} from each name's run of numbers ({name: numbers}).

    A run of two numbers is (t, s). In a longer run the view indices are two adjacent
    numbers, and every other number of the run must be the same in all names (a scene
    id before them, a frame number after them); of the pairs for which this holds the
    last is taken, so ``0421_03_07`` is row 3, column 7.
    """
    lengths: Dict[int, str] = {}
    for name, numbers in runs.items():
        lengths.setdefault(len(numbers), name)
    if len(lengths) > 1:
        examples = " and ".join(f"{name} ({count} numbers)" for count, name in sorted(lengths.items())[:2])
        raise ValueError(f"{folder}: view names hold runs of different lengths of _-joined "
                         f"numbers: {examples}; expected one naming scheme (or pattern=...)")
    (count, _), = lengths.items()
    for first in range(count - 2, -1, -1):
        others = [i for i in range(count) if i not in (first, first + 1)]
        if all(len({numbers[i] for numbers in runs.values()}) == 1 for i in others):
            return {name: (numbers[first], numbers[first + 1]) for name, numbers in runs.items()}
    varying = sorted(runs.items(), key=lambda item: item[1])
    raise ValueError(f"{folder}: names hold {count} _-joined numbers and more than two of them "
                     f"vary (e.g. {varying[0][0]} and {varying[-1][0]}: several light fields in "
                     f"one folder?); expected the view row and column as two adjacent numbers, "
                     f"the others the same in every name (or pattern=...)")


def view_names(names, pattern: Union[str, Pattern, None] = None) -> List[str]:
    """The file names among ``names`` that :func:`read_views` takes as views: images
    whose name carries view indices (the default rule), or names ``pattern`` matches
    whole. Names only: nothing is opened.

    Raises
    ------
    ValueError
        If ``pattern`` is not a regular expression with the named groups.
    """
    regex = compile_pattern(pattern, None) if isinstance(pattern, str) else pattern
    if regex is not None:
        return [name for name in names if regex.fullmatch(name)]
    found = []
    for name in names:
        stem, suffix = os.path.splitext(name)
        if suffix.lower() in IMAGE_SUFFIXES and NUMBER_RUN.search(stem):
            found.append(name)
    return found


def _find_views(folder: str, regex: Optional[Pattern], grid, linear: bool
                ) -> Dict[Tuple[int, int], str]:
    """{(t, s) as numbered in the names: file name} for the folder's views; with a
    running index (``linear``), {(index, 0): file name}."""
    if linear and grid is None:
        pattern = regex.pattern if regex is not None else None
        raise ValueError(f"{folder}: pattern {pattern!r} numbers views by (?P<index>...); "
                         f"expected grid=(T, S) to go with it")
    keys: Dict[str, Tuple[int, int]] = {}
    runs: Dict[str, Tuple[int, ...]] = {}
    for name in sorted(os.listdir(folder)):
        if regex is None:
            stem, suffix = os.path.splitext(name)
            m = NUMBER_RUN.search(stem) if suffix.lower() in IMAGE_SUFFIXES else None
            if m:
                runs[name] = tuple(int(number) for number in m.group(1).split("_"))
            continue
        m = regex.fullmatch(name)
        if m:
            keys[name] = (int(m.group("index")), 0) if linear else (int(m.group("t")), int(m.group("s")))
    if runs:
        keys = _indices_in_runs(folder, runs)
    numbered: Dict[Tuple[int, int], str] = {}
    for name, key in keys.items():
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
    """(T, S, first indices (t0, s0), {(t, s) 0-based: name})."""
    if linear:
        first = min(i for i, _ in numbered)
        if first not in (0, 1):
            raise ValueError(f"{folder}: the smallest view index in the names is {first}; "
                             f"expected a running index starting at 0 or 1")
        T, S = grid_size(grid, folder)
        views = {divmod(i - first, S): name for (i, _), name in numbered.items()}
        origin = (first, first)
    else:
        # Any contiguous block: each axis is numbered from its smallest index.
        origin = (min(t for t, _ in numbered), min(s for _, s in numbered))
        views = {(t - origin[0], s - origin[1]): name for (t, s), name in numbered.items()}
    found_t = 1 + max(t for t, _ in views)
    found_s = 1 + max(s for _, s in views)
    if grid is None:
        T, S = found_t, found_s
    else:
        T, S = grid_size(grid, folder)
        if found_t > T or found_s > S:
            raise ValueError(f"{folder}: names number views up to a {found_t}x{found_s} grid "
                             f"({_numbered_from(origin, linear)}); expected grid={T, S} to "
                             f"hold them")
    if T * S > len(views):  # views holds distinct (t, s) inside the grid
        # (a generator: a grid that huge indices make enormous is not listed)
        missing = (f"(t={t + origin[0]}, s={s + origin[1]})" for t in range(T) for s in range(S)
                   if (t, s) not in views)
        check_incomplete(folder, (T, S), len(views), missing, _numbered_from(origin, linear))
    return T, S, origin, views


def _numbered_from(origin: Tuple[int, int], linear: bool) -> str:
    return f"index from {origin[0]}" if linear else f"numbered from t={origin[0]}, s={origin[1]}"


def read_views(folder: PathLike, grid=None, pattern: Union[str, Pattern, None] = None
               ) -> LightFieldFile:
    """Reads a folder of views named by row and column.

    Parameters
    ----------
    folder : path
        The folder. Files whose names do not match are ignored. Default naming: the
        first run of two or more ``_``-joined whole numbers in the name (less its
        ending); a run of two is (t, s); in a longer run (``0421_03_07``: scene 421, row
        3, column 7) the view indices are two adjacent numbers, the others being the
        same in every name, the last such pair.
    grid : (int, int), optional
        (T, S). Without it the grid spans the indices found: each axis from its smallest
        index to its largest, so any contiguous block reads (0- or 1-based, or a crop
        numbered 8..10). With it, the names must fit in it, numbered from the smallest
        index of each axis.
    pattern : str or compiled regex, optional
        Matched against the whole file name (``re.fullmatch``, any ending) instead of the
        default rule; named groups ``t`` (row) and ``s`` (column), or ``index`` (row-major
        ``t * S + s`` from 0 or 1, needs ``grid``). Example:
        ``r"cam_(?P<s>\\d+)_(?P<t>\\d+)\\.png"``.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]) as stored (``cv2.IMREAD_UNCHANGED``; BGR,
        alpha kept as the last channel). When views are missing (see Warns) the missing
        views are 0 with an alpha of 0, and views without alpha
        get one (full: 255 for uint8, 65535 for uint16, 1.0 for floats), so C = 1 or 3
        becomes 2 or 4. ``metadata``: ``grid`` (T, S), ``first_index`` (t0, s0), the
        indices of the first row and column as numbered in the names, ``files`` (T x S
        nested list of file names, None for a missing view), ``missing`` (list of the
        missing views' 0-based (t, s)), ``added_alpha`` (True if the reader added the
        alpha channel).

    Raises
    ------
    ValueError
        Naming the folder or file: not a folder, no views, two files for one view, names
        numbered in more than one way, fewer views than the grid's longer side, names
        outside ``grid``, or views of differing size, channel count or dtype.

    Warns
    -----
    MissingViewsWarning
        When views are missing, naming them: an incomplete set of any pattern (a cross,
        a star, HCI's EPINET subset, a view lost in a download) is read as the whole
        grid with alpha 0 at the missing views (:func:`liff.io._shared.check_incomplete`).
    """
    folder = os.fspath(folder)
    if not os.path.isdir(folder):
        raise ValueError(f"{folder}: not a folder; expected a folder of views")
    regex = compile_pattern(pattern, folder)
    linear = regex is not None and "t" not in regex.groupindex
    T, S, first, views = _arrange(folder, _find_views(folder, regex, grid, linear), grid, linear)
    complete = len(views) == T * S

    _check_light_field_fits(folder, (T, S), views, complete)
    light_field: Optional[np.ndarray] = None
    reference: Optional[np.ndarray] = None  # the first view, and its name
    first_name = ""
    add_alpha = False
    for (t, s), name in sorted(views.items()):
        path = os.path.join(folder, name)
        if reference is not None:
            _check_view_not_larger(path, reference, first_name)
        image = read_image(path)
        if light_field is None or reference is None:
            reference, first_name = image, name
            light_field, add_alpha = _allocate((T, S), image, complete)
        elif image.shape != reference.shape or image.dtype != reference.dtype:
            raise ValueError(f"{path}: view is {_describe(image)}; expected "
                             f"{_describe(reference)} like {first_name}")
        if add_alpha:
            light_field[t, s, ..., :-1] = image.reshape(light_field.shape[2:4] + (-1,))
            light_field[t, s, ..., -1] = _full_scale(image.dtype)
        else:
            light_field[t, s] = image
    files = [[views.get((t, s)) for s in range(S)] for t in range(T)]
    missing = [(t, s) for t in range(T) for s in range(S) if (t, s) not in views]
    metadata = {"grid": (T, S), "first_index": first, "files": files, "missing": missing,
                "added_alpha": add_alpha}
    assert light_field is not None  # (_find_views found at least one view)
    return LightFieldFile(light_field, "views", metadata, None, folder)


def _check_light_field_fits(folder: str, grid: Tuple[int, int],
                            views: Dict[Tuple[int, int], str], complete: bool) -> None:
    """Refuses, before any view is decoded, a light field of ``grid`` views whose first
    view's header says the whole does not fit the memory budget (MemoryError naming the
    folder, the size claimed and the budget)."""
    first = os.path.join(folder, views[min(views)])
    size = header_size(first)
    if size is not None:
        channels = size.channels + (not complete)  # an incomplete set gains an alpha channel
        claimed = array_bytes(grid + (size.height, size.width, channels), size.itemsize)
        check_fits(folder, claimed, f"a light field of {grid[0]}x{grid[1]} views like "
                   f"{views[min(views)]} ({size.describe()})")


def _check_view_not_larger(path: str, reference: np.ndarray, first_name: str) -> None:
    """Refuses, before decoding it, a view whose header gives it more pixels than the
    first view (``reference``) has (ValueError naming the view); a smaller one is
    decoded and refused with what it holds."""
    size = header_size(path)
    if size is not None and size.height * size.width > reference.shape[0] * reference.shape[1]:
        raise ValueError(f"{path}: view is {size.width}x{size.height} (its header); expected "
                         f"{_describe(reference)} like {first_name}")


def _allocate(grid: Tuple[int, int], image: np.ndarray, complete: bool):
    """(zeroed light field for views like ``image``, whether an alpha channel is added):
    a complete set is stored as is; an incomplete one needs alpha to mark its holes."""
    channels = 1 if image.ndim == 2 else image.shape[2]
    add_alpha = not complete and channels in (1, 3)
    shape = image.shape[:2] + ((channels + 1,) if add_alpha else image.shape[2:])
    return np.zeros(grid + shape, image.dtype), add_alpha


def _full_scale(dtype: np.dtype):
    """The alpha of a fully valid sample: 255, 65535 or 1.0."""
    return np.iinfo(dtype).max if np.issubdtype(dtype, np.integer) else 1.0


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
