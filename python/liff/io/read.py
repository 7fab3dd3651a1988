"""One entry point for every light field format: :func:`read_light_field`."""

from __future__ import annotations

import inspect
import os
from typing import Callable, Dict, Optional

from ._shared import LightFieldFile, PathLike
from .eslf import read_eslf
from .hci import _VIEW as _HCI_VIEW
from .hci import read_hci
from .hdf5 import read_hdf5
from .images import IMAGE_SUFFIXES
from .intensity import scale_bit_depth
from .mat import read_mat
from .mosaic import read_mosaic
from .numpy_files import read_numpy
from .views import read_views
from .._paths import refuse_special


def _read_hci(folder: PathLike) -> LightFieldFile:
    scene = read_hci(folder)
    metadata = {"disp_min": scene.disp_min, "disp_max": scene.disp_max,
                "parameters": scene.parameters, "camera": scene.camera}
    return LightFieldFile(scene.light_field, "hci", metadata, scene.gt_disparity,
                          os.fspath(folder))


#: format name -> (reader, how it is recognised)
FORMATS: Dict[str, tuple] = {
    "hci": (_read_hci, "a folder with input_CamNNN.png views (HCI 4D benchmark)"),
    "views": (read_views, "any other folder of views named like scene_RR_CC.png"),
    "npy": (read_numpy, "a .npy file"),
    "npz": (read_numpy, "a .npz file (option key=...)"),
    "mat": (read_mat, "a MATLAB .mat file, variable LF (t, s, v, u, c) (option key=...)"),
    "hdf5": (read_hdf5, "an .h5 / .hdf5 file, dataset LF (T, S, V, U[, C]) (option key=...)"),
    "eslf": (read_eslf, "a *.eslf.png or *_eslf.png image, or format='eslf' (options n (default: "
                        "detected), keep=...)"),
    "mosaic": (read_mosaic, "format='mosaic' with grid=(T, S) (one image of T x S tiles)"),
}
#: name endings of each file format (lower case)
SUFFIXES = {".npy": "npy", ".npz": "npz", ".mat": "mat", ".h5": "hdf5", ".hdf5": "hdf5",
            ".hdf": "hdf5"}


def _accepted_formats() -> str:
    return "; ".join(f"{name}: {how}" for name, (_, how) in FORMATS.items())


def guess_format(path: PathLike) -> Optional[str]:
    """The format name :func:`read_light_field` would pick for ``path``, or None."""
    path = os.fspath(path)
    if os.path.isdir(path):
        return "hci" if any(_HCI_VIEW.match(n) for n in os.listdir(path)) else "views"
    name = os.path.basename(path).lower()
    stem, suffix = os.path.splitext(name)
    if suffix in SUFFIXES:
        return SUFFIXES[suffix]
    if (".eslf." in name or stem.endswith("_eslf")) and suffix in IMAGE_SUFFIXES:
        return "eslf"  # (not scene.eslf.png.truth.json, which liff synth writes beside it)
    return None


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
        One of "hci", "views", "npy", "npz", "mat", "hdf5", "eslf", "mosaic"; guessed
        from ``path`` when omitted (a mosaic, or an ESLF image without ``.eslf.`` or
        ``_eslf.`` in its name, must be named).
    bit_depth : int, optional
        The light field holds ``bit_depth``-bit values (e.g. 10 or 12 for sensor data
        stored in uint16, 8 for floats in 0..255): rescale them to the nominal range
        of the dtype (:func:`liff.io.scale_bit_depth`); ``metadata["bit_depth"]`` records
        it. Any format.
    **options
        Passed to the format's reader: ``grid``, ``pattern`` (views); ``key`` (npz, mat,
        hdf5); ``n``, ``keep`` (eslf); ``grid`` (mosaic, required).

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
        raise ValueError(f"{path}: no such file or folder; expected a light field "
                         "(liff.io.read_light_field lists the formats read)")
    if format is None:
        format = guess_format(path)
        if format is None:
            raise ValueError(f"{path}: cannot tell the light field format from the name; "
                             f"expected one of: {_accepted_formats()}")
    elif format not in FORMATS:
        raise ValueError(f"{path}: unknown format {format!r}; expected one of: "
                         f"{_accepted_formats()}")
    reader: Callable[..., LightFieldFile] = FORMATS[format][0]
    accepted = [p for p in inspect.signature(reader).parameters if p != "path" and p != "folder"]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(f"{path}: option(s) {', '.join(unknown)} do not apply to format "
                         f"{format!r}; expected {', '.join(accepted + ['bit_depth'])}")
    result = reader(path, **options)
    if bit_depth is not None:
        result.light_field = scale_bit_depth(result.light_field, bit_depth, path)
        result.metadata["bit_depth"] = int(bit_depth)
    return result
