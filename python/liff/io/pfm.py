"""PFM (portable float map) images, as the HCI benchmark stores disparity and depth.

A PFM file is a header ``Pf`` (grey) or ``PF`` (colour, RGB), ``width height``, and a
scale whose sign gives the byte order (negative: little-endian, positive: big-endian),
then float32 rows stored bottom-up. :func:`read_pfm` returns rows top-down, as every
image in liff.

Header variants read: tokens separated by any whitespace (spaces, tabs, several lines,
``width`` and ``height`` on lines of their own), lines ending in LF or CR+LF (Windows
tools; the CR+LF after the scale ends the header, as its LF does), and comment lines
(``#`` to the end of the line, as PNM allows) before any token. The header ends with
the line end (or the one whitespace byte) after the scale; where the file's size says
a CR+LF's LF is the first data byte, it is taken as data.
"""

from __future__ import annotations

import os
import re
from typing import List, Tuple, Union

import numpy as np

from .._budget import check_fits
from .._paths import refuse_special

PathLike = Union[str, os.PathLike]

#: bytes the header may take at the most, whitespace included (a header padded past them
#: is refused rather than scanned)
HEADER_BYTES = 4096
#: what may separate header tokens: whitespace and comment lines (# to the line end)
_GAP = rb"(?:\s|#[^\r\n]*[\r\n])"
#: the header: four tokens, then the line end (CR+LF, or one whitespace byte) ending it
HEADER = re.compile(_GAP + rb"*([^\s#]+)" + (_GAP + rb"+([^\s#]+)") * 3 + rb"(\r\n|\s)")


def read_pfm(path: PathLike) -> np.ndarray:
    """Reads a PFM image.

    Returns
    -------
    image : ndarray of float32, shape (V, U) for ``Pf`` or (V, U, 3) for ``PF`` (RGB,
        as stored), rows top-down, whichever byte order the file has. Every header
        variant of the module's docstring is read.

    Raises
    ------
    ValueError
        If the file is not a well-formed PFM (names the file and what was wrong):
        another magic than ``Pf`` / ``PF``, sizes that are not positive whole numbers,
        a zero or non-finite scale, fewer data bytes than the header states, or a
        header longer than ``HEADER_BYTES``.
    MemoryError
        If the header's size does not fit the memory budget (checked before the pixels
        are read; names the file, the size and the budget).
    """
    path = os.fspath(path)
    refuse_special(path, "a PFM file")
    try:
        with open(path, "rb") as f:
            head = f.read(HEADER_BYTES + 1)
            tokens, pos = _header_tokens(path, head)
            width, height, scale, channels = _header_values(path, tokens)
            count = width * height * channels
            # The bytes read and the float32 array made of them, before reading either.
            check_fits(path, 8 * count, f"a PFM image of {width}x{height}x{channels} float32")
            size = os.fstat(f.fileno()).st_size
            if head[pos - 2:pos] == b"\r\n" and size - pos == 4 * count - 1:
                pos -= 1  # (a CR ended the header, and the LF is the first data byte)
            f.seek(pos)
            data = f.read(4 * count)
            stored = size - pos
    except OSError as e:
        raise ValueError(f"{path}: cannot read ({e.strerror}); expected a PFM file") from None
    if len(data) < 4 * count:
        raise ValueError(f"{path}: PFM data holds {max(0, stored)} bytes; expected "
                         f"{4 * count} for {width}x{height}x{channels} float32")
    dtype = "<f4" if scale < 0 else ">f4"
    image = np.frombuffer(data, dtype=dtype, count=count).astype(np.float32)
    image = image.reshape((height, width, channels) if channels == 3 else (height, width))
    return np.ascontiguousarray(image[::-1])


def _header_tokens(path: str, head: bytes) -> Tuple[List[bytes], int]:
    """(the header's four tokens: magic, width, height, scale; the offset of the pixels)
    from the file's first bytes ``head``."""
    match = HEADER.match(head)
    if match is None or match.end() > HEADER_BYTES:
        if len(head) > HEADER_BYTES:
            raise ValueError(f"{path}: no PFM header in the first {HEADER_BYTES} bytes; expected "
                             "'Pf|PF', width, height, scale separated by whitespace")
        raise ValueError(f"{path}: truncated PFM header; expected 'Pf|PF', width, height, scale")
    return list(match.groups()[:4]), match.end()


def _header_values(path: str, tokens: List[bytes]) -> Tuple[int, int, float, int]:
    """(width, height, scale, channels) from the header's tokens, checked."""
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
    return width, height, scale, 3 if magic == b"PF" else 1


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
