"""``liff detect --mask PATH|auto``: where features may be detected."""

from __future__ import annotations

import argparse
import os
from typing import Optional

import numpy as np

from .._paths import refuse_special

AUTO = "auto"


def add_mask_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--mask", default=None, metavar="PATH|auto",
        help="keep only features whose centre-view pixel is non-zero in this image (the views' "
             "size V x U; colour: any non-zero colour channel); 'auto' leaves out a lenslet "
             "capture's black, vignetted border (liff.preprocess.border_mask; docs/INPUTS.md)")


def check_mask_option(spec: Optional[str]) -> None:
    """Raises ValueError, before any light field is read, if ``--mask`` names no file."""
    if spec is not None and spec != AUTO:
        refuse_special(spec, "an image of the views' size for --mask")
    if spec is not None and spec != AUTO and not os.path.isfile(spec):
        raise ValueError(f"--mask {spec}: no such file; expected an image of the views' size, "
                         f"or '{AUTO}'")


def load_mask(spec: Optional[str], light_field: np.ndarray, source: str) -> Optional[np.ndarray]:
    """The detection mask for ``light_field`` (read from ``source``): None without
    ``--mask``, :func:`liff.preprocess.border_mask` for ``auto``, else the image at
    ``spec`` as uint8 (V, U), 255 where any colour channel is non-zero.

    Raises
    ------
    ValueError
        Naming the mask file: unreadable, or not of the views' size.
    """
    if spec is None:
        return None
    if spec == AUTO:
        from ..preprocess import border_mask

        return border_mask(light_field)
    from ..io.images import read_image

    try:
        image = read_image(spec)
    except ValueError as error:  # (the message names the file; say which option gave it)
        raise ValueError(f"--mask: {error}") from None
    if image.ndim == 3:  # the colour channels; alpha (C = 2 or 4) is not part of the mask
        image = image[..., : 1 if image.shape[2] == 2 else 3].max(axis=2)
    V, U = light_field.shape[2:4]
    if image.shape != (V, U):
        raise ValueError(f"{os.fspath(spec)}: mask is {image.shape[1]}x{image.shape[0]} (width x "
                         f"height); expected the views' size {U}x{V} of {source}")
    return np.where(image != 0, 255, 0).astype(np.uint8)
