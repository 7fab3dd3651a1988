"""MATLAB ``.mat`` light fields, as the Light Field Toolbox and the 4D benchmark's tools
write them.

Layouts relied on (from the tools' source):

- Light Field Toolbox (D. G. Dansereau; ``LFUtilDecodeLytroFolder.m``, ``LFReadESLF.m``):
  variable ``LF`` indexed ``LF(t, s, v, u, c)`` in MATLAB, t and s the vertical and
  horizontal view index, v and u the vertical and horizontal pixel index, c the colour
  channel: RGB, then a weight channel when saved with it (``SaveWeight``, the default),
  so c = 4 (RGB + weight), or 2 (grey + weight). Decoded captures are saved as uint16
  (``OutputPrecision``, default) or uint8 with ``save('-v7.3', ...)``, beside the structs
  ``LFMetadata``, ``DecodeOptions``, ...
- HCI 4D light field benchmark (``convertBlenderTo5D.m`` of lightfield-analysis/
  matlab-tools): variable ``LF``, a struct whose field ``LF`` is the light field
  ``(t, s, v, u, c)`` RGB double in [0, 1] (row ``t`` = the scene's camera row) and whose
  field ``disp_lowres`` is the centre view's disparity (V, U), saved with ``-v7.3``.

MATLAB stores arrays column-major. ``scipy.io.loadmat`` (MAT v4 / v5 / v7 files) returns
them with MATLAB's index order, (t, s, v, u, c); ``h5py`` (v7.3 files, which are HDF5)
returns the axes reversed, (c, u, v, s, t), which is undone here.
"""

from __future__ import annotations

import os
from typing import Optional, cast

import numpy as np

from .._budget import check_fits, over_budget, room_bytes
from . import _matv5
from ._shared import LightFieldFile, PathLike, check_disparity, pick_key, required_module, rgb_light_field, stored_file
from .hdf5 import check_dataset_fits, named_dataset_shapes

#: the variable the Light Field Toolbox and the 4D benchmark's tools save the light field in
LF_VARIABLE = "LF"
#: the 4D benchmark struct's field holding the centre view's disparity
DISPARITY_FIELD = "disp_lowres"
#: MATLAB classes a light field may have
MATLAB_CLASSES = ("uint8", "uint16", "single", "double")


def read_mat(path: PathLike, key: Optional[str] = None) -> LightFieldFile:
    """Reads a light field from a MATLAB ``.mat`` file (v4/v5/v7 through SciPy, v7.3
    through h5py; both are installed with liff).

    Parameters
    ----------
    path : path
        The ``.mat`` file.
    key : str, optional
        The variable holding the light field. Default: ``LF`` if present, else the only
        4-D or 5-D variable. A struct (the 4D benchmark's ``LF``) is read through its
        field ``LF``.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]) from MATLAB's ``LF(t, s, v, u, c)``, dtype as
        stored (uint8, uint16, float32 or float64); colour RGB(+weight) becomes liff's
        BGR(+weight), C = 1 is dropped, C = 2 (grey + weight) kept. ``gt_disparity``:
        the struct field ``disp_lowres`` (V, U) when present. ``metadata``: ``key``,
        ``variables`` (names in the file), ``version`` ("v5" or "v7.3"; v4 files read
        as "v4").

    Raises
    ------
    ValueError
        Naming the file: unreadable or not a MAT-file, ``key`` absent, several
        candidate variables and no ``key``, or a variable that is not a light field
        (shape, channels, class other than uint8, uint16, single, double).
    ImportError
        If SciPy (or, for v7.3 files, h5py) is missing all the same, saying how to
        install it.
    """
    path = stored_file(path, key, "a MATLAB .mat file", "the name of a variable in the file")
    scipy_io = required_module("scipy.io", "reading .mat files")
    try:
        major, _ = scipy_io.matlab.matfile_version(path)
    except Exception as e:  # scipy raises several kinds on a file that is not a MAT-file
        raise ValueError(f"{path}: unreadable ({type(e).__name__}: {e}); expected a MATLAB "
                         f".mat file") from None
    if major == 2:
        array, disparity, key, names = _read_v73(path, key)
        version = "v7.3"
    else:
        array, disparity, key, names = _read_v5(path, key, scipy_io)
        version = "v4" if major == 0 else "v5"
    source = f"{path}[{key!r}]"
    light_field = rgb_light_field(array, source)
    if disparity is not None:
        disparity = check_disparity(disparity, light_field, f"{source}.{DISPARITY_FIELD}")
    metadata = {"key": key, "variables": names, "version": version}
    return LightFieldFile(light_field, "mat", metadata, disparity, path)


def variable_shapes(path: PathLike) -> Optional[list]:
    """[(name, shape in MATLAB's index order, kind)] of a .mat file's variables, from
    their headers alone (v5: :func:`._matv5.variable_headers`; v7.3: the HDF5 metadata,
    its datasets' axes reversed, named by their paths; v4: SciPy's ``whosmat``), or None
    when the headers cannot be read (the reader then says what is wrong). ``kind`` is
    "numeric", another MATLAB class name, or for a v5 struct ``("struct", field names)``.
    """
    path = os.fspath(path)
    try:
        import scipy.io

        try:
            major, _ = scipy.io.matlab.matfile_version(path)  # (the header's first 128 bytes)
        except Exception:  # HDF5 without MATLAB's header (written by h5py): as v7.3
            import h5py

            if not h5py.is_hdf5(path):
                raise
            major = 2
        if major == 0:
            return [(name, tuple(shape), kind) for name, shape, kind in scipy.io.whosmat(path)]
        if major == 2:  # v7.3: HDF5, column-major (h5py reverses the axes); #refs# is MATLAB's
            datasets = named_dataset_shapes(path)
            return None if datasets is None else [
                (name, tuple(shape)[::-1], "numeric") for name, shape in datasets
                if not name.startswith("#")]
        with open(path, "rb") as f:
            return [(name, tuple(dims), ("struct", fields) if mclass == _matv5.STRUCT
                     else "numeric" if mclass in _matv5.NUMERIC_CLASSES
                     else _matv5.CLASS_NAMES.get(mclass, f"class {mclass}"))
                    for name, dims, mclass, fields in _matv5.variable_headers(f)]
    except Exception:  # a damaged or unreadable file: unknown here
        return None


def holds_light_field(path: PathLike) -> Optional[bool]:
    """Whether a .mat file can hold a light field, from its headers alone: a 4-D or 5-D
    array (a v7.3 struct's field included), or a v5 struct with a field ``LF`` (the 4D
    benchmark's layout, whose field sizes lie past the header); None when the headers
    cannot be read."""
    shapes = variable_shapes(path)
    if shapes is None:
        return None
    return any((len(shape) in (4, 5) and kind not in ("char", "cell"))
               or (isinstance(kind, tuple) and LF_VARIABLE in kind[1]) for _, shape, kind in shapes)


def _unreadable(path: str, what: str, error: BaseException) -> ValueError:
    return ValueError(f"{path}: {what} unreadable ({type(error).__name__}: {error}); expected a "
                      f"MATLAB .mat file holding a light field")


def _read_v5(path: str, key: Optional[str], scipy_io):
    """(array (t, s, v, u[, c]), disparity or None, key, variable names) of a v4-v7 file.

    v5 files go through :mod:`._matv5` first (SciPy's v5 reader crashes on some damaged
    files); v4 files, plain arrays, straight to SciPy."""
    check_fits(path, os.path.getsize(path), "the file, read whole")
    with open(path, "rb") as f:
        data = f.read()
    version4 = 0 in data[:4]  # as scipy's matfile_version tells v4 from v5
    try:
        if version4:
            variables = [(name, shape, kind) for name, shape, kind in scipy_io.whosmat(path)]
        else:
            variables = [(name, dims, _matv5.CLASS_NAMES.get(mclass, "numeric"))
                         for name, dims, mclass in _matv5.list_variables(data)]
    except _matv5.Damaged as e:
        raise ValueError(f"{path}: damaged MAT-file: {e}; expected a MATLAB .mat file") from None
    except Exception as e:
        raise _unreadable(path, "variable list", e) from None
    names = sorted(name for name, _, _ in variables)
    candidates = [name for name, shape, kind in variables if len(shape) in (4, 5) or kind == "struct"]
    key = pick_key(path, names, key, LF_VARIABLE, candidates, "variable")
    room, origin = room_bytes()
    try:
        if version4:
            value = scipy_io.loadmat(path, variable_names=[key])[key]
        else:
            value = _matv5.loadmat_checked(scipy_io, data, key, room)
    except _matv5.TooLarge as e:
        # (raised only under a bound: room is a number)
        raise over_budget(f"{path}[{key!r}]", e.claimed, "reading the variable (at least)",
                          cast(int, room), origin) from None
    except _matv5.Damaged as e:
        raise ValueError(f"{path}[{key!r}]: not read ({e}); expected a numeric light field, or "
                         f"a struct of numeric, char, cell and struct arrays") from None
    except MemoryError:
        raise ValueError(f"{path}: variable {key!r} does not fit in memory") from None
    except Exception as e:
        raise _unreadable(path, f"variable {key!r}", e) from None
    disparity = None
    if isinstance(value, np.ndarray) and value.dtype.names:  # a struct: (1, 1) record array
        if LF_VARIABLE not in value.dtype.names or value.size != 1:
            raise ValueError(f"{path}[{key!r}]: struct with fields {list(value.dtype.names)}; "
                             f"expected a light field, or a struct with a field {LF_VARIABLE!r}")
        record = value.reshape(-1)[0]
        if DISPARITY_FIELD in value.dtype.names:
            disparity = record[DISPARITY_FIELD]
        value = record[LF_VARIABLE]
        key = f"{key}.{LF_VARIABLE}"
    return value, disparity, key, names


def _read_v73(path: str, key: Optional[str]):
    """(array (t, s, v, u[, c]), disparity or None, key, variable names) of a v7.3 file."""
    h5py = required_module("h5py", "reading MATLAB v7.3 .mat files")
    try:
        with h5py.File(path, "r") as f:
            names = sorted(name for name in f.keys() if not name.startswith("#"))  # #refs#, #subsystem#
            candidates = [name for name in names
                          if _matlab_class(f[name]) == "struct" or len(getattr(f[name], "shape", ())) in (4, 5)]
            key = pick_key(path, names, key, LF_VARIABLE, candidates, "variable")
            node, disparity = f[key], None
            if _matlab_class(node) == "struct":
                fields = sorted(node.keys())
                if LF_VARIABLE not in fields:
                    raise ValueError(f"{path}[{key!r}]: struct with fields {fields}; expected a "
                                     f"light field, or a struct with a field {LF_VARIABLE!r}")
                if DISPARITY_FIELD in fields:
                    disparity = _read_matlab_array(path, f"{key}.{DISPARITY_FIELD}",
                                                   node[DISPARITY_FIELD], h5py)
                node, key = node[LF_VARIABLE], f"{key}.{LF_VARIABLE}"
            array = _read_matlab_array(path, key, node, h5py)
    except Exception as e:  # h5py raises OSError, KeyError, ValueError, ... on damaged files
        if isinstance(e, (ValueError, MemoryError)) and str(e).startswith(path):  # liff's own
            raise
        raise _unreadable(path, "HDF5 (v7.3) content", e) from None
    return array, disparity, key, names


def _matlab_class(node) -> Optional[str]:
    value = node.attrs.get("MATLAB_class")
    return value.decode("ascii", "replace") if isinstance(value, bytes) else value


def _read_matlab_array(path: str, key: str, node, h5py) -> np.ndarray:
    """A numeric MATLAB array of a v7.3 file in MATLAB's index order."""
    if not isinstance(node, h5py.Dataset):
        raise ValueError(f"{path}[{key!r}]: a MATLAB {_matlab_class(node) or 'group'}; expected "
                         f"a numeric array")
    kind = _matlab_class(node)
    if kind is not None and kind not in MATLAB_CLASSES:
        raise ValueError(f"{path}[{key!r}]: MATLAB class {kind}; expected one of "
                         f"{', '.join(MATLAB_CLASSES)}")
    check_dataset_fits(f"{path}[{key!r}]", node)
    try:
        array = node[()]
    except MemoryError:
        raise ValueError(f"{path}[{key!r}]: array of shape {node.shape} does not fit in "
                         f"memory") from None
    if not isinstance(array, np.ndarray):
        raise ValueError(f"{path}[{key!r}]: holds a scalar; expected an array")
    return array.transpose(tuple(range(array.ndim))[::-1])  # column-major: h5py reverses the axes
