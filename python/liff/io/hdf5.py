"""HDF5 light fields, as the 2013 HCI light field benchmark ships them.

Layout relied on. The benchmark's page (lightfieldgroup.iwr.uni-heidelberg.de, "Old 4D
Light Field Benchmark"; Wanner, Meister and Goldluecke, "Datasets and Benchmarks for
Densely Sampled 4D Light Fields", VMV 2013) documents the main HDF5 file's camera
attributes ``dH`` (baseline), ``focalLength`` and ``shift``. The dataset name and axis
order come from the authors' own reader/writer (Sven Wanner's ``LightField.py``:
``f["LF"]``, "4D raw data in (v,u,y,x,channels)", uint8, root attributes ``vRes``,
``hRes``, ``yRes``, ``xRes``, ``channels``, ``dH``, ``dV``, ``focalLength``,
``camDistance``, ...) and from the readers people publish for the dataset (``lf.h5``,
``np.array(f["LF"])`` taken as (view row, view column, y, x, RGB), ground truth in
``GT_DEPTH``). So: dataset ``LF`` of shape (T, S, V, U[, C]) in h5py's (C) order, RGB.

Not checked against a file of the dataset (none was at hand): the direction of the view
axes. Some published readers flip the view-row axis (``np.flip(LF, axis=0)``); liff reads
the axes as stored. If features come out with poorly focused slopes or slopes of the
wrong sign, flip an axis (``lf[::-1]``) and compare.
"""

from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from .._budget import array_bytes, check_fits
from ._shared import LightFieldFile, PathLike, pick_key, required_module, rgb_light_field, stored_file

#: the dataset the 2013 HCI benchmark stores the light field in
LF_DATASET = "LF"
#: a MATLAB v7.3 file is HDF5 with this text in its 512-byte user block
MATLAB_HEADER = b"MATLAB 7.3 MAT-file"


def read_hdf5(path: PathLike, key: Optional[str] = None) -> LightFieldFile:
    """Reads a light field from an HDF5 file (through h5py, installed with liff).

    Parameters
    ----------
    path : path
        The file (``.h5``, ``.hdf5``).
    key : str, optional
        Path of the dataset inside the file (e.g. ``"LF"`` or ``"/data/lf"``). Default:
        ``LF`` if present, else the only 4-D or 5-D dataset in the file.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]): the dataset as stored, axes (T, S, V, U[, C])
        (the 2013 HCI benchmark's order), dtype as stored (uint8, uint16, float32,
        float64); colour RGB(+weight) becomes BGR(+weight), C = 1 is dropped.
        ``metadata``: ``key``, ``datasets`` (the 4-D and 5-D datasets in the file),
        ``attributes`` (the file's root attributes and the dataset's, as Python values;
        for the 2013 benchmark ``dH``, ``focalLength``, ``shift``, ...).

    Raises
    ------
    ValueError
        Naming the file: not HDF5, a MATLAB v7.3 file (read it with ``read_mat``),
        ``key`` absent, several candidate datasets and no ``key``, or a dataset that is
        not a light field.
    MemoryError
        Naming the file and dataset: its shape says it takes more than the memory budget
        leaves (:func:`check_dataset_fits`), however small the file (a dataset never
        written, or compressed).
    ImportError
        If h5py is missing all the same, saying how to install it.
    """
    path = stored_file(path, key, "an HDF5 file", "the path of a dataset in the file")
    h5py = required_module("h5py", "reading HDF5 files")
    with open(path, "rb") as f:
        if f.read(len(MATLAB_HEADER)) == MATLAB_HEADER:
            raise ValueError(f"{path}: a MATLAB v7.3 file (axes stored column-major); expected "
                             f"HDF5 written in C order; read it as a .mat file (format='mat')")
    try:
        with h5py.File(path, "r") as f:
            found: Dict[str, int] = {}  # dataset path -> number of axes
            f.visititems(lambda name, node: found.__setitem__(name, len(node.shape))
                         if isinstance(node, h5py.Dataset) else None)
            datasets = sorted(name for name, axes in found.items() if axes in (4, 5))
            key = pick_key(path, sorted(found), key.strip("/") if key else None, LF_DATASET,
                           datasets, "dataset")
            node = f[key]
            check_dataset_fits(f"{path}[{key!r}]", node)
            try:
                array = node[()]
            except MemoryError:
                raise ValueError(f"{path}[{key!r}]: dataset of shape {node.shape} does not fit "
                                 f"in memory") from None
            attributes = {**_attributes(f.attrs), **_attributes(node.attrs)}
    except Exception as e:  # h5py raises OSError, KeyError, ValueError, ... on damaged files
        if isinstance(e, (ValueError, MemoryError)) and str(e).startswith(path):  # liff's own
            raise
        raise ValueError(f"{path}: unreadable ({type(e).__name__}: {e}); expected an HDF5 file "
                         f"holding a light field") from None
    light_field = rgb_light_field(np.asarray(array), f"{path}[{key!r}]")
    metadata = {"key": key, "datasets": datasets, "attributes": attributes}
    return LightFieldFile(light_field, "hdf5", metadata, None, path)


def dataset_shapes(path: PathLike) -> Optional[list]:
    """The shapes of the datasets in an HDF5 file (a MATLAB v7.3 file's too), from its
    metadata alone, or None if h5py is missing or cannot open the file (the reader then
    says what is wrong)."""
    datasets = named_dataset_shapes(path)
    return None if datasets is None else [shape for _, shape in datasets]


def named_dataset_shapes(path: PathLike) -> Optional[list]:
    """[(path in the file, shape)] of every dataset of an HDF5 file, as :func:`dataset_shapes`."""
    try:
        import h5py

        found: list = []
        with h5py.File(path, "r") as f:
            f.visititems(lambda name, node: found.append((name, node.shape))
                         if isinstance(node, h5py.Dataset) else None)
        return found
    except Exception:  # h5py raises OSError, KeyError, ValueError, ... on damaged files
        return None


def check_dataset_fits(source: str, dataset) -> None:
    """Raises MemoryError naming ``source``, the dataset's shape, dtype and bytes, and
    the budget, if reading the h5py ``dataset`` would not fit the memory budget
    (:func:`liff._budget.check_fits`): its shape and dtype are what reading allocates,
    whatever the file holds (fill value only, gzip-compressed chunks)."""
    check_fits(source, array_bytes(dataset.shape or (), dataset.dtype.itemsize),
               f"a dataset of shape {dataset.shape} {dataset.dtype}")


def _attributes(attrs) -> dict:
    """HDF5 attributes as plain Python values (scalars and lists; text decoded)."""
    result = {}
    for name in attrs:
        try:
            value = attrs[name]
        except Exception:  # an attribute of a type h5py cannot read: leave it out
            continue
        if isinstance(value, bytes):
            value = value.decode("utf-8", "replace")
        elif isinstance(value, np.ndarray):
            value = value.item() if value.size == 1 else value.tolist()
        elif isinstance(value, np.generic):
            value = value.item()
        result[name] = value
    return result
