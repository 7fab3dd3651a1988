"""Camera options shared by ``liff pose`` and ``liff sfm``: where the calibration of the
light field camera comes from (docs/METRIC.md)."""

from __future__ import annotations

import argparse
import json
import math
import os
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .._paths import refuse_special
from ..camera import LightFieldCamera, read_hci_parameters
from ..io.mat import LF_VARIABLE, variable_shapes


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


@dataclass(frozen=True)
class Calibration:
    """A camera, where it came from, and what that source states of the light fields it
    calibrates (None where it states nothing).

    Attributes
    ----------
    camera : LightFieldCamera
    source : str
        As the user gave it: ``--camera-file poses.truth.json``.
    view_size : (width, height) or None
        Pixels of a view.
    grid : (T, S) or None
        Views.
    """

    camera: LightFieldCamera
    source: str
    view_size: Optional[Tuple[int, int]] = None
    grid: Optional[Tuple[int, int]] = None

    def check(self, path: str, shape, grid_known: bool = True) -> None:
        """Refuses the input ``path`` of light field shape ``shape`` ((T, S, V, U[, C]),
        or a view's (V, U[, C]): a 1x1 light field, or with ``grid_known=False`` a view
        of a grid not known) unless its views are of the size the calibration states, in
        its grid or a centred part of it (``--keep-views``: the same centre view). A
        calibration that states no size must at least have its principal point inside
        the views.

        Raises
        ------
        ValueError
            Naming the input, its view size, the calibration's source and its size.
        """
        shape = tuple(int(v) for v in shape)
        many = len(shape) >= 4
        size = (shape[3], shape[2]) if many else (shape[1], shape[0])
        grid = shape[:2] if many else (1, 1) if grid_known else None
        seen = f"{path}: views of {size[0]}x{size[1]} pixels" + (
            f" in a {grid[0]}x{grid[1]} grid" if grid is not None and self.grid is not None else "")
        # a centred part of the calibrated grid (--keep-views) keeps its centre view
        centred = grid is None or self.grid is None or all(
            g <= c and (c - g) % 2 == 0 for g, c in zip(grid, self.grid))
        if self.view_size is not None and (size != self.view_size or not centred):
            stated = f"{self.view_size[0]}x{self.view_size[1]} pixels" + (
                f" in a {self.grid[0]}x{self.grid[1]} grid" if self.grid is not None else "")
            raise ValueError(f"{seen}, but {self.source} is the calibration of views of {stated}; "
                             "expected the calibration of these inputs' camera (the same view "
                             "size" + (", and its grid or a centred part of it, which keeps its "
                                       "centre view" if self.grid is not None else "") + ")")
        if self.view_size is None:
            cx, cy = self.camera.principal_point
            if not (-0.5 <= cx <= size[0] - 0.5 and -0.5 <= cy <= size[1] - 0.5):
                raise ValueError(f"{seen}, but the principal point ({cx:g}, {cy:g}) of "
                                 f"{self.source} lies outside them; expected the calibration of "
                                 "these inputs' camera (a principal point inside the views)")


def check_feature_file(calibration: Calibration, path: str, features) -> None:
    """:meth:`Calibration.check` of a feature file: the light field's shape it records,
    else its centre view (grid unknown); a file with neither is not checked."""
    shape = features.meta.get("shape")
    if shape is not None:
        calibration.check(path, shape)
    elif features.centre_view is not None:
        calibration.check(path, features.centre_view.shape, grid_known=False)


#: LightFieldCamera's keywords, as the command line gives their values
CAMERA_FLAGS = {"focal_length": "--camera F (focal length)", "baseline": "--camera B (baseline)",
                "principal_point": "--camera CX CY (principal point)",
                "focus_distance": "--focus-distance"}


def calibration_from_args(args: argparse.Namespace) -> Optional[Calibration]:
    """The calibration the options name, or None when none is given."""
    if args.focus_distance != math.inf and args.camera is None:  # (a camera file has its own)
        raise ValueError("--focus-distance goes with --camera")
    if args.camera is not None:
        f, b, cx, cy = args.camera
        try:
            camera = LightFieldCamera(f, b, (cx, cy), args.focus_distance)
        except ValueError as error:  # named as the command line's values, not the keywords
            message = str(error)
            for keyword, flag in CAMERA_FLAGS.items():
                message = message.replace(keyword, flag)
            raise ValueError(message) from None
        return Calibration(camera, "--camera " + " ".join(f"{v:g}" for v in args.camera))
    if args.hci is not None:
        return read_hci_calibration(args.hci)
    if args.lftoolbox is not None:
        return Calibration(LightFieldCamera.from_lftoolbox(read_matrix(args.lftoolbox)),
                           f"--lftoolbox {args.lftoolbox}")
    if getattr(args, "camera_file", None) is not None:
        return read_calibration(args.camera_file)
    return None


def camera_from_args(args: argparse.Namespace) -> Optional[LightFieldCamera]:
    """The camera the options name, or None when none is given."""
    calibration = calibration_from_args(args)
    return None if calibration is None else calibration.camera


def read_hci_calibration(path: str) -> Calibration:
    """``--hci PATH``: the scene's camera, its views' size and, where parameters.cfg
    states it (num_cams_y, num_cams_x), its grid."""
    parameters, cfg_path = read_hci_parameters(path)
    camera = LightFieldCamera.from_hci_parameters(parameters, cfg_path)
    intrinsics, extrinsics = parameters.get("intrinsics", {}), parameters.get("extrinsics", {})
    size = (int(intrinsics["image_resolution_x_px"]), int(intrinsics["image_resolution_y_px"]))
    try:
        grid: Optional[Tuple[int, int]] = (int(extrinsics["num_cams_y"]),
                                           int(extrinsics["num_cams_x"]))
    except (KeyError, ValueError):
        grid = None
    return Calibration(camera, f"--hci {path}", size, grid)


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
    or the Light Field Toolbox's JSON (``CalInfo.json``) or .mat output holding H
    (:func:`read_calibration`)."""
    return read_calibration(path).camera


def read_calibration(path: str) -> Calibration:
    """The calibration of a camera file (``--camera-file``): liff synth's truth JSON
    (its views' size: ``intrinsics.width``, ``intrinsics.height``), or the Light Field
    Toolbox's JSON (``CalInfo.json``, no size) or .mat output holding H (the size and
    grid of the light field ``LF`` beside it, from its header).

    Raises
    ------
    ValueError
        Naming the file and the field that is missing or wrong.
    """
    refuse_special(path, "a camera file (JSON or .mat)")
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file; expected a camera file: {EXPECTED}")
    data = _load_mapping(path)
    source = f"--camera-file {path}"
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
            camera = LightFieldCamera(f, b, (cx, cy), focus)
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None
        size = tuple(_field(data, name) for name in ("intrinsics.width", "intrinsics.height"))
        whole = all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in size)
        return Calibration(camera, source, size if whole else None)
    for name in TOOLBOX_FIELDS:
        H = _field(data, name)
        if H is not None:
            try:
                camera = LightFieldCamera.from_lftoolbox(np.asarray(H, dtype=float))
            except (TypeError, ValueError) as error:
                raise ValueError(f"{path}: {name}: {error}") from None
            shape = _light_field_shape(path) if path.lower().endswith(".mat") else None
            return (Calibration(camera, source) if shape is None else
                    Calibration(camera, source, (shape[3], shape[2]), (shape[0], shape[1])))
    raise ValueError(f"{path}: none of {', '.join(SYNTH_FIELDS + TOOLBOX_FIELDS)}; expected "
                     f"{EXPECTED}")


def _light_field_shape(path: str) -> Optional[tuple]:
    """MATLAB's (t, s, v, u[, c]) of the light field a .mat camera file holds beside H
    (its variable ``LF``, else its only 4-D or 5-D array), from the headers; None if
    it holds none."""
    arrays = [(name, shape) for name, shape, kind in variable_shapes(path) or ()
              if len(shape) in (4, 5) and not isinstance(kind, tuple)]
    named = [shape for name, shape in arrays if name == LF_VARIABLE]
    return named[0] if named else arrays[0][1] if len(arrays) == 1 else None


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
