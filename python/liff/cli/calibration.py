"""Camera options shared by ``liff pose`` and ``liff sfm``: where the calibration of the
light field camera comes from (docs/METRIC.md)."""

from __future__ import annotations

import argparse
import json
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
    source.add_argument("--camera-file", default=None, metavar="FILE",
                        help="a camera file: liff synth's <out>.truth.json (intrinsics.focal, "
                             "intrinsics.cx, intrinsics.cy, baseline, focus_depth), or the Light "
                             "Field Toolbox's JSON or .mat output holding "
                             "RectOptions.RectCamIntrinsicsH or EstCamIntrinsicsH (CalInfo.json)")
    group.add_argument("--focus-distance", type=float, default=math.inf, metavar="M",
                       help="with --camera: depth in metres of slope 0 (default inf: "
                            "parallel views)")


def camera_from_args(args: argparse.Namespace) -> Optional[LightFieldCamera]:
    """The camera the options name, or None when none is given."""
    if args.focus_distance != math.inf and args.camera is None:  # (a camera file has its own)
        raise ValueError("--focus-distance goes with --camera")
    if args.camera is not None:
        f, b, cx, cy = args.camera
        return LightFieldCamera(f, b, (cx, cy), args.focus_distance)
    if args.hci is not None:
        return LightFieldCamera.from_hci(args.hci)
    if args.lftoolbox is not None:
        return LightFieldCamera.from_lftoolbox(read_matrix(args.lftoolbox))
    if getattr(args, "camera_file", None) is not None:
        return read_camera_file(args.camera_file)
    return None


#: the fields of liff synth's truth file that make its camera
SYNTH_FIELDS = ("intrinsics.focal", "baseline", "intrinsics.cx", "intrinsics.cy", "focus_depth")
#: where the Light Field Toolbox keeps H: the rectified light field's, then the calibration's
TOOLBOX_FIELDS = ("RectOptions.RectCamIntrinsicsH", "RectCamIntrinsicsH", "EstCamIntrinsicsH",
                  "CalInfo.EstCamIntrinsicsH")
EXPECTED = (f"liff synth's truth ({', '.join(SYNTH_FIELDS)}) or the Light Field Toolbox's "
            f"{' or '.join(TOOLBOX_FIELDS[::2])}")


def _field(data, dotted: str):
    """``data["a"]["b"]`` for ``"a.b"``, or None where a part is missing."""
    for part in dotted.split("."):
        if not isinstance(data, dict) or part not in data:
            return None
        data = data[part]
    return data


def read_camera_file(path: str) -> LightFieldCamera:
    """The camera of a calibration file (``--camera-file``): liff synth's truth JSON,
    or the Light Field Toolbox's JSON (``CalInfo.json``) or .mat output holding H.

    Raises
    ------
    ValueError
        Naming the file and the field that is missing or wrong.
    """
    refuse_special(path, "a camera file (JSON or .mat)")
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file; expected a camera file: {EXPECTED}")
    data = _load_mapping(path)
    if any(_field(data, name) is not None for name in ("intrinsics", "baseline", "focus_depth")):
        values = {name: _field(data, name) for name in SYNTH_FIELDS}
        missing = [name for name, value in values.items() if value is None]
        if missing:
            raise ValueError(f"{path}: no {', '.join(missing)}; expected liff synth's truth with "
                             f"{', '.join(SYNTH_FIELDS)}")
        for name, value in values.items():  # (float() would take true and "0.04")
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{path}: {name} is {json.dumps(value)}; expected a number")
        f, b, cx, cy, focus = (float(values[name]) for name in SYNTH_FIELDS)
        try:
            return LightFieldCamera(f, b, (cx, cy), focus)
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None
    for name in TOOLBOX_FIELDS:
        H = _field(data, name)
        if H is not None:
            try:
                return LightFieldCamera.from_lftoolbox(np.asarray(H, dtype=float))
            except (TypeError, ValueError) as error:
                raise ValueError(f"{path}: {name}: {error}") from None
    raise ValueError(f"{path}: none of {', '.join(SYNTH_FIELDS + TOOLBOX_FIELDS)}; expected "
                     f"{EXPECTED}")


def _matrices_v73(path: str) -> dict:
    """The toolbox's H matrices of a MATLAB v7.3 file, as {"RectOptions": {...}, ...}
    (MATLAB stores column-major: h5py's array is the transpose)."""
    import h5py

    found: dict = {}
    try:
        with h5py.File(path, "r") as f:
            for name in TOOLBOX_FIELDS:
                node = f.get(name.replace(".", "/"))
                if isinstance(node, h5py.Dataset):
                    parent, _, key = name.rpartition(".")
                    (found.setdefault(parent, {}) if parent else found)[key] = node[()].T
    except (OSError, KeyError, ValueError) as error:
        raise ValueError(f"{path}: unreadable MATLAB v7.3 file ({error}); expected "
                         f"{EXPECTED}") from None
    return found


def _load_mapping(path: str) -> dict:
    """A JSON object, or a .mat file's variables (structs as dicts)."""
    if path.lower().endswith(".mat"):
        import h5py
        import scipy.io

        if h5py.is_hdf5(path):  # MATLAB v7.3 (the toolbox's default save): H only
            return _matrices_v73(path)

        try:
            data = scipy.io.loadmat(path, simplify_cells=True)
        except Exception as error:  # SciPy raises many kinds on a damaged file
            raise ValueError(f"{path}: unreadable .mat ({type(error).__name__}: {error}); "
                             f"expected {EXPECTED}") from None
        return {k: v for k, v in data.items() if not k.startswith("__")}
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise ValueError(f"{path}: unreadable JSON ({error}); expected {EXPECTED}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a JSON {type(data).__name__}; expected an object: {EXPECTED}")
    return data


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
