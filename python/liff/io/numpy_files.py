"""Light fields saved with numpy: ``.npy`` (one array) and ``.npz`` (named arrays).

Write them with numpy itself: ``np.save(path, lf)`` or
``np.savez_compressed(path, light_field=lf, gt_disparity=d)``.
"""

from __future__ import annotations

import os
from typing import Optional

import numpy as np

from ._shared import LightFieldFile, PathLike, check_disparity, check_light_field, pick_key
from .._paths import refuse_special

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
    """
    path = os.fspath(path)
    refuse_special(path, "a .npy or .npz file")
    try:
        loaded = np.load(path, allow_pickle=False)
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
        try:  # members are read (and their headers parsed) only now
            array = loaded[key]
            disparity = loaded[DISPARITY_KEY] if DISPARITY_KEY in keys and key != DISPARITY_KEY else None
        except Exception as e:
            raise ValueError(f"{path}: array {key!r} unreadable ({type(e).__name__}: {e}); "
                             "expected a .npz written by numpy") from None
        light_field = check_light_field(array, f"{path}[{key!r}]")
    if disparity is not None:
        disparity = check_disparity(disparity, light_field, f"{path}[{DISPARITY_KEY!r}]")
    return LightFieldFile(light_field, "npz", {"key": key, "keys": keys}, disparity, path)
