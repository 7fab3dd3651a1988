"""Camera options shared by ``liff pose`` and ``liff sfm``: where the calibration of the
light field camera comes from (docs/METRIC.md)."""

from __future__ import annotations

import argparse
import math
import os
from typing import Optional

import numpy as np

from .._paths import refuse_special
from ..camera import LightFieldCamera


def add_camera_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group(
        "calibrated camera (docs/METRIC.md; slope = f b (1/Z - 1/focus distance))")
    source = group.add_mutually_exclusive_group()
    source.add_argument("--camera", type=float, nargs=4, metavar=("F", "B", "CX", "CY"),
                        default=None,
                        help="focal length (pixels), baseline between neighbouring views "
                             "(metres), principal point of the centre view (pixels, pixel "
                             "centres at integers)")
    source.add_argument("--hci", default=None, metavar="PATH",
                        help="the camera of an HCI benchmark scene (its folder or parameters.cfg)")
    source.add_argument("--lftoolbox", default=None, metavar="FILE",
                        help="a text or .npy file holding the Light Field Toolbox's 5x5 "
                             "intrinsic matrix H of the rectified light field")
    group.add_argument("--focus-distance", type=float, default=math.inf, metavar="M",
                       help="with --camera: depth in metres of slope 0 (default inf: "
                            "parallel views)")


def camera_from_args(args: argparse.Namespace) -> Optional[LightFieldCamera]:
    """The camera the options name, or None when none is given."""
    if args.focus_distance != math.inf and args.camera is None:
        raise ValueError("--focus-distance goes with --camera")
    if args.camera is not None:
        f, b, cx, cy = args.camera
        return LightFieldCamera(f, b, (cx, cy), args.focus_distance)
    if args.hci is not None:
        return LightFieldCamera.from_hci(args.hci)
    if args.lftoolbox is not None:
        return LightFieldCamera.from_lftoolbox(read_matrix(args.lftoolbox))
    return None


def read_matrix(path: str) -> np.ndarray:
    """A matrix from a .npy file or a whitespace- or comma-separated text file."""
    refuse_special(path, "the toolbox's 5x5 H as text or .npy")
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file; expected the toolbox's 5x5 H as text or .npy")
    try:
        if path.endswith(".npy"):
            return np.load(path, allow_pickle=False)
        with open(path, encoding="utf-8") as f:
            text = f.read().replace(",", " ")
        return np.array([[float(v) for v in line.split()] for line in text.splitlines()
                         if line.strip() and not line.lstrip().startswith(("#", "%"))])
    except (ValueError, OSError) as error:
        raise ValueError(f"{path}: unreadable ({error}); expected 5 rows of 5 numbers") from None
