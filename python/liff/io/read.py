"""One entry point for every light field format: :func:`read_light_field`."""

from __future__ import annotations

import inspect
import os
from typing import Callable, Dict, Optional

from ._shared import LightFieldFile, PathLike
from .eslf import read_eslf
from .hci import _VIEW as _HCI_VIEW
from .hci import read_hci
from .mosaic import read_mosaic
from .numpy_files import read_numpy
from .views import read_views


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
    "eslf": (read_eslf, "a *.eslf.png image, or format='eslf' (options n=14, keep=...)"),
    "mosaic": (read_mosaic, "format='mosaic' with grid=(T, S) (one image of T x S tiles)"),
}


def _accepted_formats() -> str:
    return "; ".join(f"{name}: {how}" for name, (_, how) in FORMATS.items())


def guess_format(path: PathLike) -> Optional[str]:
    """The format name :func:`read_light_field` would pick for ``path``, or None."""
    path = os.fspath(path)
    if os.path.isdir(path):
        return "hci" if any(_HCI_VIEW.match(n) for n in os.listdir(path)) else "views"
    name = os.path.basename(path).lower()
    if name.endswith(".npy"):
        return "npy"
    if name.endswith(".npz"):
        return "npz"
    if ".eslf." in name:
        return "eslf"
    return None


def read_light_field(path: PathLike, format: Optional[str] = None, **options) -> LightFieldFile:
    """Reads a light field in any format liff knows (docs/INPUTS.md).

    Parameters
    ----------
    path : path
        A folder (HCI scene or views named by row and column), a ``.npy`` / ``.npz``
        file, an ESLF image (``*.eslf.png``) or, with ``format="mosaic"``, a mosaic.
    format : str, optional
        One of "hci", "views", "npy", "npz", "eslf", "mosaic"; guessed from ``path``
        when omitted (a mosaic or an ESLF image without ``.eslf.`` in its name must be
        named).
    **options
        Passed to the format's reader: ``grid``, ``pattern`` (views); ``key`` (npz);
        ``n``, ``keep`` (eslf); ``grid`` (mosaic, required).

    Returns
    -------
    LightFieldFile

    Raises
    ------
    ValueError
        If ``path`` does not exist, the format cannot be told or is unknown (the message
        lists the accepted formats), an option does not apply to the format, or the
        reader rejects the data.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"{path}: no such file or folder; expected a light field "
                         f"({_accepted_formats()})")
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
                         f"{format!r}; expected {', '.join(accepted) or 'no options'}")
    return reader(path, **options)
