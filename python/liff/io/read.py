"""One entry point for every light field format: :func:`read_light_field`."""

from __future__ import annotations

import os
from typing import Optional

from .._paths import refuse_special
from ._shared import LightFieldFile, PathLike
from .formats import FORMATS, OPTIONS, accepted_formats, format_named, formats_taking, guess_format
from .intensity import scale_bit_depth

__all__ = ["FORMATS", "guess_format", "read_light_field"]


def read_light_field(path: PathLike, format: Optional[str] = None, bit_depth=None,
                     **options) -> LightFieldFile:
    """Reads a light field in any format liff knows (docs/INPUTS.md).

    Parameters
    ----------
    path : path
        A folder (HCI scene or views named by row and column), a ``.npy`` / ``.npz``
        file, a MATLAB ``.mat`` file, an HDF5 file (``.h5``, ``.hdf5``), an ESLF image
        (``*.eslf.png``, ``*_eslf.png``) or, with ``format="mosaic"``, a mosaic.
    format : str, optional
        One of :data:`liff.io.formats.FORMATS` ("hci", "views", "npy", "npz", "mat",
        "hdf5", "eslf", "mosaic"); guessed from ``path`` when omitted (a mosaic, or an ESLF image without ``.eslf.`` or
        ``_eslf.`` in its name, must be named).
    bit_depth : int, optional
        The light field holds ``bit_depth``-bit values (e.g. 10 or 12 for sensor data
        stored in uint16, 8 for floats in 0..255): rescale them to the nominal range
        of the dtype (:func:`liff.io.scale_bit_depth`); ``metadata["bit_depth"]`` records
        it. Any format.
    **options
        Passed to the format's reader: ``grid``, ``pattern`` (views); ``key`` (npz, mat,
        hdf5); ``n``, ``keep`` (eslf); ``grid`` (mosaic, required)
        (:data:`liff.io.formats.OPTIONS`).

    Returns
    -------
    LightFieldFile

    Raises
    ------
    ValueError
        If ``path`` does not exist, the format cannot be told or is unknown (the message
        lists the accepted formats), an option does not apply to the format, the reader
        rejects the data, or values exceed ``bit_depth``.
    ImportError
        For .mat and HDF5 files when SciPy / h5py are missing (naming the pip extra).
    """
    path = os.fspath(path)
    refuse_special(path, "a light field file or folder")
    if not os.path.exists(path):
        raise ValueError(f"{path}: no such file or folder; expected a light field file or "
                         f"folder of a format liff reads ({', '.join(FORMATS)})")
    if format is None:
        format = guess_format(path)
        if format is None:
            raise ValueError(f"{path}: cannot tell the light field format from the name; "
                             f"expected one of: {accepted_formats()}")
    fmt = format_named(format, path)
    unknown = sorted(set(options) - set(fmt.options))
    if unknown:
        known = [k for k in unknown if k in OPTIONS]
        raise ValueError(f"{path}: option(s) {', '.join(unknown)} do not apply to format "
                         f"{format!r}; expected {', '.join(fmt.takes())}" +
                         (f" ({_takers(known)})" if known else ""))
    result = fmt.read(path, **options)
    if bit_depth is not None:
        result.light_field = scale_bit_depth(result.light_field, bit_depth, path)
        result.metadata["bit_depth"] = int(bit_depth)
    return result


def _takers(keywords) -> str:
    """"grid: views, mosaic; n: eslf": the formats that take each of ``keywords``."""
    return "; ".join(f"{k}: {', '.join(formats_taking(k))}" for k in keywords)
