"""``liff detect --mask PATH|auto``: where features may be detected."""

from __future__ import annotations

import argparse
import os
from typing import Optional

from .._detection import AUTO, load_mask  # noqa: F401 (liff.cli.mask.load_mask)
from .._paths import refuse_special


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


