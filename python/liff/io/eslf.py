"""ESLF (lenslet-interleaved) images, as in the Stanford Lytro light field archive.

An ESLF image stores the light field lenslet by lenslet: each n x n block of pixels is
one lenslet, pixel (t, s) of a block belonging to view (t, s). So view (t, s) is
``image[t::n, s::n]``. The archive's Lytro Illum files use n = 14 and carry an alpha
channel marking the samples that hold light (0 in the dark corners of each lenslet).
"""

from __future__ import annotations

import os
from typing import Optional

import numpy as np

from ._shared import (LightFieldFile, PathLike, as_image, centre_range, centre_views,
                      check_writable, positive_int, read_image, write_image)

LYTRO_LENSLET_SIZE = 14


def read_eslf(path: PathLike, n: int = LYTRO_LENSLET_SIZE, keep=None) -> LightFieldFile:
    """Reads an ESLF image.

    Parameters
    ----------
    path : path
        The image (any format OpenCV reads; ``cv2.IMREAD_UNCHANGED``).
    n : int
        Lenslet size in pixels (views per row and per column of the lenslet grid); a
        whole number (2.0 is taken as 2, 2.5 is refused).
    keep : int or (int, int), optional
        Keep only the centre ``keep`` x ``keep`` views (or keep_t x keep_s). The first
        kept view is ``(n - keep) // 2`` on each axis, so an odd number of dropped views
        drops the extra one at the bottom / right: n = 14, keep = 11 keeps views 1..11
        (0-based), the paper's choice for Lytro data.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]) with V = height // n, U = width // n: rows and
        columns past the last whole lenslet are dropped. An alpha channel is kept as the
        last channel (BGRA: C = 4, grey + alpha: C = 2): it is the per-sample validity
        weight. ``metadata``: ``lenslet_size``, ``first_view`` (t, s) within the
        lenslet, ``image_size`` (height, width), ``cropped`` (rows, columns dropped at
        the bottom / right), ``has_alpha``.

    Raises
    ------
    ValueError
        Naming the file: unreadable, ``n`` or ``keep`` not a whole number >= 1, an
        image smaller than one lenslet, or ``keep`` larger than ``n``.
    """
    path = os.fspath(path)
    n = positive_int(n, "lenslet size n", path, 1)
    image = read_image(path)
    height, width = image.shape[:2]
    V, U = height // n, width // n
    if V == 0 or U == 0:
        raise ValueError(f"{path}: image is {width}x{height}; expected at least one {n}x{n} "
                         f"lenslet")
    if image.ndim == 2:
        image = image[:, :, None]
    channels = image.shape[2]
    # (V, n, U, n, C) -> (t, s, v, u, c): pixel (v * n + t, u * n + s) is view (t, s)'s (v, u)
    blocks = image[: V * n, : U * n].reshape(V, n, U, n, channels).transpose(1, 3, 0, 2, 4)
    first = (0, 0)
    if keep is not None:
        try:
            blocks = centre_views(blocks, keep)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None
        first = (centre_range(n, blocks.shape[0]).start, centre_range(n, blocks.shape[1]).start)
    light_field = np.ascontiguousarray(blocks if channels > 1 else blocks[..., 0])
    metadata = {"lenslet_size": n, "first_view": first, "image_size": (height, width),
                "cropped": (height - V * n, width - U * n), "has_alpha": channels in (2, 4)}
    return LightFieldFile(light_field, "eslf", metadata, None, path)


def write_eslf(path: PathLike, light_field: np.ndarray, n: Optional[int] = None) -> None:
    """Writes a light field as an ESLF image.

    Parameters
    ----------
    path : path
        Image path; its ending picks the format (.png keeps alpha and 16 bits).
    light_field : ndarray, shape (T, S, V, U[, C])
        uint8, or uint16 for .png/.tif; C in {1, 3, 4}.
    n : int, optional
        Lenslet size, at least max(T, S) (the default). With a larger ``n`` the views
        are placed where ``read_eslf(path, n, keep=(T, S))`` finds them again and the
        other lenslet samples are 0 (alpha 0 too, so they read back as invalid).

    Raises
    ------
    ValueError
        If the light field cannot be stored in that image format or ``n`` is too small.
    """
    path = os.fspath(path)
    light_field = check_writable(light_field, path)
    T, S, V, U = light_field.shape[:4]
    n = positive_int(max(T, S) if n is None else n, "lenslet size n", path, max(T, S))
    channels = light_field.shape[4:]
    lenslets = np.zeros((n, n, V, U) + channels, light_field.dtype)
    lenslets[centre_range(n, T), centre_range(n, S)] = light_field
    image = lenslets.transpose((2, 0, 3, 1) + tuple(range(4, 4 + len(channels))))
    write_image(path, as_image(image.reshape((V * n, U * n) + channels)))
