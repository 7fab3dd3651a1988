"""Light fields saved with numpy: ``.npy`` (one array) and ``.npz`` (named arrays).

Write them with numpy itself: ``np.save(path, lf)`` or
``np.savez_compressed(path, light_field=lf, gt_disparity=d)``.
"""

from __future__ import annotations

import os
from typing import Optional

import numpy as np

from .._budget import array_bytes, check_fits
from .._paths import refuse_special
from ._shared import LightFieldFile, PathLike, check_disparity, check_light_field, pick_key

LIGHT_FIELD_KEY = "light_field"
DISPARITY_KEY = "gt_disparity"


def read_numpy(path: PathLike, key: Optional[str] = None) -> LightFieldFile:
    """Reads a light field from ``.npy`` or ``.npz``.

    Parameters
    ----------
    path : path
        ``.npy``, or ``.npz`` (any other ending is read as ``.npy``). Pickled objects are
        refused.
    key : str, optional
        For ``.npz``: the array to read. Default: ``"light_field"`` if present, else the
        only array.

    Returns
    -------
    LightFieldFile
        ``light_field`` as stored (4-D or 5-D, C in {1, 2, 3, 4}, uint8 / uint16 /
        float32 / float64; a big-endian array is converted to native byte order);
        ``format`` "npy" or "npz"; ``metadata``: ``key`` and
        ``keys`` (npz). An npz array ``gt_disparity`` of shape (V, U) becomes
        ``gt_disparity`` (float32).

    Raises
    ------
    ValueError
        Naming the file: unreadable, ``key`` absent, several arrays and no ``key``, or an
        array that is not a light field.
    MemoryError
        Naming the file (and member): its header states an array larger than the memory
        budget leaves (:func:`check_stored_array_fits`), checked before anything is
        allocated or inflated.
    """
    path = os.fspath(path)
    refuse_special(path, "a .npy or .npz file")
    try:
        with open(path, "rb") as f:
            if f.read(len(np.lib.format.MAGIC_PREFIX)) == np.lib.format.MAGIC_PREFIX:  # .npy
                f.seek(0)
                check_stored_array_fits(path, f)
        loaded = np.load(path, allow_pickle=False)
    except MemoryError:
        raise
    except Exception as e:  # numpy's header parsing raises many kinds on a bad file
        raise ValueError(f"{path}: unreadable ({type(e).__name__}: {e}); expected a .npy or "
                         ".npz file") from None
    if isinstance(loaded, np.ndarray):
        if key is not None:
            raise ValueError(f"{path}: key {key!r} given for a .npy file; expected a .npz file")
        light_field = check_light_field(loaded, path)
        return LightFieldFile(light_field, "npy", {}, None, path)

    with loaded:
        keys = sorted(loaded.files)
        key = pick_key(path, keys, key, LIGHT_FIELD_KEY, [k for k in keys if k != DISPARITY_KEY])
        wanted = [key] + ([DISPARITY_KEY] if DISPARITY_KEY in keys and key != DISPARITY_KEY else [])
        try:  # members are read (and their headers parsed) only now
            members = set(loaded.zip.namelist())
            for name in wanted:  # the member of key "a" is "a.npy" (or "a", as numpy reads)
                with loaded.zip.open(name + ".npy" if name + ".npy" in members else name) as member:
                    check_stored_array_fits(f"{path}[{name!r}]", member)
            array = loaded[key]
            disparity = loaded[DISPARITY_KEY] if len(wanted) == 2 else None
        except MemoryError:
            raise
        except Exception as e:
            raise ValueError(f"{path}: array {key!r} unreadable ({type(e).__name__}: {e}); "
                             "expected a .npz written by numpy") from None
        light_field = check_light_field(array, f"{path}[{key!r}]")
    if disparity is not None:
        disparity = check_disparity(disparity, light_field, f"{path}[{DISPARITY_KEY!r}]")
    return LightFieldFile(light_field, "npz", {"key": key, "keys": keys}, disparity, path)


def check_stored_array_fits(source: str, stored) -> None:
    """Reads the .npy header at the start of the open file ``stored`` (a file, or an
    .npz member, inflating only the header) and raises MemoryError naming ``source``,
    the shape, dtype and bytes it states, and the budget, if that array does not fit
    the memory budget (:func:`liff._budget.check_fits`). A header that cannot be read
    is left for ``np.load`` to report."""
    try:
        version = np.lib.format.read_magic(stored)
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)  # 3.0: 2.0's layout, UTF-8
        shape, _, dtype = read_header(stored)
    except Exception:  # numpy raises several kinds on a bad header
        return
    check_fits(source, array_bytes(shape, dtype.itemsize), f"an array of shape {shape} {dtype}")


def stored_shapes(path: PathLike) -> Optional[list]:
    """The shapes of the arrays a ``.npy`` or ``.npz`` file holds, from their headers
    alone (an npz member's header is all that is inflated), or None if the file cannot
    be read that way (the reader then says what is wrong with it)."""
    import zipfile

    def header_shape(stored) -> tuple:
        version = np.lib.format.read_magic(stored)
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)
        return read_header(stored)[0]

    try:
        if zipfile.is_zipfile(path):
            with zipfile.ZipFile(path) as archive:
                shapes = []
                for name in archive.namelist():
                    with archive.open(name) as member:
                        shapes.append(header_shape(member))
                return shapes
        with open(path, "rb") as f:
            return [header_shape(f)]
    except Exception:  # numpy and zipfile raise many kinds on a damaged file
        return None
