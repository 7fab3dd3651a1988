"""Images on disk, as liff's readers, writers and commands read and write them.

Every light field format built of images (view folders, ESLF, mosaics, HCI scenes)
goes through :func:`read_image` and :func:`write_image`: OpenCV decodes and encodes,
keeping 16 bits and alpha, and every failure is a ValueError naming the file.
"""

from __future__ import annotations

import os
from typing import Optional, Union

import cv2
import numpy as np

from .._budget import check_fits
from .._paths import refuse_special
from .image_headers import DecodedSize, decoded_size

PathLike = Union[str, os.PathLike]

#: dtypes a light field may have (as the detector accepts them, see docs/CONVENTIONS.md)
LIGHT_FIELD_DTYPES = (np.uint8, np.uint16, np.float32, np.float64)
#: file name endings read as images by the view-folder reader
IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp", ".ppm", ".pgm", ".webp")
#: endings whose OpenCV encoders keep 16 bits (the others fall back to 8 bits silently)
SIXTEEN_BIT_SUFFIXES = (".png", ".tif", ".tiff")


def _is_grey_alpha_png(path: str) -> bool:
    """True for a PNG of colour type 4 (grey + alpha), which OpenCV expands to BGRA."""
    with open(path, "rb") as f:
        head = f.read(26)
    return len(head) == 26 and head[:8] == b"\x89PNG\r\n\x1a\n" and head[25] == 4


def decode_image(path: str, flags: int) -> Optional[np.ndarray]:
    """``cv2.imread(path, flags)`` with OpenCV's errors as liff's, naming ``path``:
    MemoryError when decoding runs out of memory, ValueError for anything else (such
    as a header claiming more pixels than OpenCV decodes, ``CV_IO_MAX_IMAGE_PIXELS``,
    2^30 unless the environment's ``OPENCV_IO_MAX_IMAGE_PIXELS`` says otherwise). None
    where OpenCV cannot decode the file, as ``cv2.imread``."""
    try:
        return cv2.imread(path, flags)
    except cv2.error as error:
        reason = f"OpenCV: {getattr(error, 'err', '') or error}".strip()
        if getattr(error, "code", None) == cv2.Error.StsNoMem:
            raise MemoryError(f"{path}: not enough memory to decode the image ({reason}); "
                              "expected an image that fits in the memory available") from None
        if "CV_IO_MAX_IMAGE_PIXELS" in reason:
            raise _too_many_pixels(path, reason) from None
        raise ValueError(f"{path}: OpenCV cannot decode the image ({reason}); expected a "
                         "well-formed image (PNG, TIFF, JPEG, ...)") from None


def _too_many_pixels(path: str, reason: str) -> ValueError:
    return ValueError(f"{path}: the image's header claims more pixels than OpenCV decodes "
                      f"({reason}); expected an image of at most {max_image_pixels()} pixels "
                      "(2^30 unless OPENCV_IO_MAX_IMAGE_PIXELS says otherwise)")


def max_image_pixels() -> int:
    """The most pixels OpenCV decodes in one image (``CV_IO_MAX_IMAGE_PIXELS``): the
    environment's ``OPENCV_IO_MAX_IMAGE_PIXELS``, else 2^30."""
    try:
        return int(os.environ.get("OPENCV_IO_MAX_IMAGE_PIXELS", 1 << 30))
    except ValueError:
        return 1 << 30


def header_size(path: str) -> Optional[DecodedSize]:
    """The size ``path`` decodes to, from its header (:func:`decoded_size`; None if the
    header does not tell).

    Raises
    ------
    ValueError
        Naming ``path``: the header claims more pixels than OpenCV decodes (as
        :func:`decode_image` would say, without decoding).
    """
    size = decoded_size(path)
    if size is not None and size.height * size.width > max_image_pixels():
        raise _too_many_pixels(path, f"the header says {size.width}x{size.height}")
    return size


def check_image_fits(path: str, copies: int = 1, what: str = "") -> Optional[DecodedSize]:
    """The size ``path`` decodes to, from its header (:func:`header_size`; None if not
    told), once ``copies`` arrays of that size are known to fit the memory budget.

    Raises
    ------
    ValueError
        The header claims more pixels than OpenCV decodes (:func:`header_size`).
    MemoryError
        Naming ``path``, the size its header claims (times ``copies``, described by
        ``what``) and the budget (:func:`liff._budget.check_fits`).
    """
    size = header_size(path)
    if size is not None:
        check_fits(path, copies * size.nbytes, f"{size.describe()}{what}")
    return size


def read_image(path: PathLike, copies: int = 1) -> np.ndarray:
    """Reads an image as stored (``cv2.IMREAD_UNCHANGED``: 16 bits and alpha survive).

    Parameters
    ----------
    path : path
    copies : int
        Arrays of the image's size the caller will hold at once (2 for a light field
        rearranged from the image): checked against the memory budget, from the
        header, before decoding.

    Returns
    -------
    ndarray, shape (V, U) grey, (V, U, 2) grey + alpha, (V, U, 3) BGR or (V, U, 4) BGRA,
        dtype as stored (uint8, uint16, float32 or float64).

    Raises
    ------
    ValueError
        If the file is missing or not a regular file, OpenCV cannot decode it (its header
        claims more pixels than OpenCV decodes, ...), or it decodes to a dtype liff does
        not accept (e.g. a signed-integer TIFF).
    MemoryError
        If its header claims more than the memory budget leaves (:func:`check_image_fits`)
        or decoding it runs out of memory (:func:`decode_image`).
    """
    path = os.fspath(path)
    refuse_special(path, "an image")
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file; expected an image")
    check_image_fits(path, copies, f", {copies} times" if copies > 1 else "")
    image = decode_image(path, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError(f"{path}: unreadable image; expected a format OpenCV decodes "
                         f"(PNG, TIFF, JPEG, ...)")
    if image.dtype not in LIGHT_FIELD_DTYPES:  # OpenCV reads some TIFFs as int8/16/32
        raise ValueError(f"{path}: image has dtype {image.dtype}; expected uint8, uint16, "
                         f"float32 or float64")
    if image.ndim == 3 and image.shape[2] == 4 and _is_grey_alpha_png(path):
        image = np.ascontiguousarray(image[:, :, [0, 3]])
    return image


def as_image(array: np.ndarray) -> np.ndarray:
    """(V, U) or (V, U, C) image of a view or mosaic, dropping a single channel axis."""
    return array[..., 0] if array.ndim == 3 and array.shape[2] == 1 else array


def write_image(path: PathLike, image: np.ndarray) -> None:
    """Writes one image with OpenCV; raises ValueError naming ``path`` if it fails."""
    path = os.fspath(path)
    try:
        ok = cv2.imwrite(path, np.ascontiguousarray(image))
    except cv2.error as e:
        raise ValueError(f"{path}: OpenCV could not write the image ({e})") from None
    if not ok:
        raise ValueError(f"{path}: OpenCV could not write the image; expected a writable path "
                         f"with an image ending such as .png or .tif")
