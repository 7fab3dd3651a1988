"""PFM (portable float map) images, as the HCI benchmark stores disparity and depth.

A PFM file is a header ``Pf`` (grey) or ``PF`` (colour), ``width height``, and a scale
whose sign gives the byte order (negative: little-endian), then float32 rows stored
bottom-up. :func:`read_pfm` returns rows top-down, as every image in liff.
"""

from __future__ import annotations

import os
from typing import Union

import numpy as np

from .._paths import refuse_special

PathLike = Union[str, os.PathLike]


def read_pfm(path: PathLike) -> np.ndarray:
    """Reads a PFM image.

    Returns
    -------
    image : ndarray of float32, shape (V, U) for ``Pf`` or (V, U, 3) for ``PF``,
        rows top-down.

    Raises
    ------
    ValueError
        If the file is not a well-formed PFM (names the file and what was wrong).
    """
    path = os.fspath(path)
    refuse_special(path, "a PFM file")
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise ValueError(f"{path}: cannot read ({e.strerror}); expected a PFM file") from None
    # Header: three whitespace-separated tokens after the magic, then one whitespace byte.
    tokens, pos = [], 0
    while len(tokens) < 4:
        while pos < len(data) and data[pos : pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(data) and not data[pos : pos + 1].isspace():
            pos += 1
        if start == pos:
            raise ValueError(f"{path}: truncated PFM header; expected 'Pf|PF', width, height, scale")
        tokens.append(data[start:pos])
    pos += 1  # the single whitespace byte that ends the header
    magic = tokens[0]
    if magic not in (b"Pf", b"PF"):
        raise ValueError(f"{path}: not a PFM file (magic {magic[:8]!r}; expected b'Pf' or b'PF')")
    try:
        if not (tokens[1].isdigit() and tokens[2].isdigit()):  # int() would take "1_0", "+3"
            raise ValueError
        width, height, scale = int(tokens[1]), int(tokens[2]), float(tokens[3])
    except ValueError:
        raise ValueError(f"{path}: bad PFM header {b' '.join(tokens)!r}; expected integer width "
                         f"and height and a non-zero scale") from None
    if width <= 0 or height <= 0 or scale == 0 or not np.isfinite(scale):
        raise ValueError(f"{path}: bad PFM header (width {width}, height {height}, scale "
                         f"{scale}); expected positive sizes and a finite non-zero scale")
    channels = 3 if magic == b"PF" else 1
    count = width * height * channels
    if len(data) - pos < 4 * count:
        raise ValueError(f"{path}: PFM data holds {len(data) - pos} bytes; expected "
                         f"{4 * count} for {width}x{height}x{channels} float32")
    dtype = "<f4" if scale < 0 else ">f4"
    image = np.frombuffer(data, dtype=dtype, count=count, offset=pos).astype(np.float32)
    image = image.reshape((height, width, channels) if channels == 3 else (height, width))
    return np.ascontiguousarray(image[::-1])


def write_pfm(path: PathLike, image: np.ndarray) -> None:
    """Writes a (V, U) or (V, U, 3) image as little-endian PFM (rows top-down in
    ``image``, stored bottom-up as the format requires)."""
    image = np.asarray(image)
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3) or image.size == 0:
        raise ValueError(f"PFM image has shape {image.shape}; expected (V, U) or (V, U, 3)")
    if not np.issubdtype(image.dtype, np.floating) and not np.issubdtype(image.dtype, np.integer):
        raise ValueError(f"PFM image has dtype {image.dtype}; expected a real number type")
    height, width = image.shape[:2]
    magic = b"PF" if image.ndim == 3 else b"Pf"
    with open(os.fspath(path), "wb") as f:
        f.write(magic + b"\n%d %d\n-1.0\n" % (width, height))
        f.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())
