"""Tiled sub-aperture mosaics: one image of T x S tiles, tile (t, s) being view (t, s).

Tile (t, s) covers rows ``t * V .. (t + 1) * V - 1`` and columns ``s * U .. (s + 1) * U - 1``
of the image. The grid cannot be told from the pixels, so the reader takes it from the
caller.
"""

from __future__ import annotations

import os

import numpy as np

from ._shared import LightFieldFile, PathLike, as_image, check_writable, grid_size, read_image, write_image


def read_mosaic(path: PathLike, grid=None) -> LightFieldFile:
    """Reads a mosaic of T x S views.

    Parameters
    ----------
    path : path
        The image (``cv2.IMREAD_UNCHANGED``: 16 bits and alpha kept).
    grid : (int, int)
        Required. (T, S): tile rows and columns. The image's height must be a multiple of T and
        its width of S.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]) with V = height / T, U = width / S;
        ``metadata``: ``grid`` (T, S), ``tile_size`` (V, U).

    Raises
    ------
    ValueError
        Naming the file: unreadable, no or a bad grid, or a size not divisible by the grid.
    """
    path = os.fspath(path)
    if grid is None:  # the pixels cannot tell it
        raise ValueError(f"{path}: no grid given for a mosaic; expected grid=(T, S)")
    T, S = grid_size(grid, path)
    image = read_image(path, copies=2)  # the image and the light field rearranged from it
    height, width = image.shape[:2]
    if height % T or width % S:
        raise ValueError(f"{path}: image is {width}x{height} (width x height); expected a "
                         f"width divisible by S = {S} and a height divisible by T = {T}")
    V, U = height // T, width // S
    channels = image.shape[2:]
    tiles = image.reshape((T, V, S, U) + channels)
    light_field = np.ascontiguousarray(tiles.swapaxes(1, 2))
    return LightFieldFile(light_field, "mosaic", {"grid": (T, S), "tile_size": (V, U)}, None, path)


def write_mosaic(path: PathLike, light_field: np.ndarray) -> None:
    """Writes a light field as one image of T x S tiles (view (t, s) at tile (t, s)).

    Parameters
    ----------
    path : path
        Image path; its ending picks the format.
    light_field : ndarray, shape (T, S, V, U[, C])
        uint8, or uint16 for .png/.tif; C in {1, 3, 4}.

    Raises
    ------
    ValueError
        If the light field cannot be stored in that image format.
    """
    light_field = check_writable(light_field, path)
    T, S, V, U = light_field.shape[:4]
    channels = light_field.shape[4:]
    image = light_field.swapaxes(1, 2).reshape((T * V, S * U) + channels)
    write_image(path, as_image(image))
