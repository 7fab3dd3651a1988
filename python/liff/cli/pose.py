"""``liff pose A B``: the metric relative pose of two light field captures."""

from __future__ import annotations

import argparse
import configparser
import json
import os
import sys
from typing import Optional

import numpy as np

from .. import io
from ..camera import HCI_CAMERA_KEYS
from ..feature_file import Features, features_from_light_field, load_features
from ..outputs import atomic_output, refuse_inputs
from ..pose import estimate_relative_pose
from ..preprocess import prepare
from . import common
from .calibration import Calibration, add_camera_options, calibration_from_args, check_feature_file
from .match import MIN_INLIERS, is_feature_file


def add_parser(sub) -> None:
    p = sub.add_parser(
        "pose", help="metric relative pose of two light field captures",
        description="Estimates the rigid motion between two light field captures of a "
                    "scene, with absolute scale, from their LiFF features and the "
                    "calibrated camera (liff.estimate_relative_pose; docs/METRIC.md). "
                    "Prints R and t (metres) with X_B = R X_A + t in the centre views' "
                    "camera frames (x right, y down, z forward). The camera comes from the "
                    "options, or from an input that knows it (an HCI scene).")
    p.add_argument("a", help="light field (or feature file from liff detect) of capture A")
    p.add_argument("b", help="light field (or feature file) of capture B")
    p.add_argument("--ratio", type=common.ratio, default=0.8, help="ratio test (default 0.8)")
    p.add_argument("--max-size-factor", type=float, default=None, metavar="K",
                   help="scale-sensitive matching: reject candidates whose metric sizes differ "
                        "by more than K (e.g. 1.5)")
    p.add_argument("--out", default=None, help="write R, t and the inlier count as JSON")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    add_camera_options(p)
    common.add_reader_options(p)
    common.add_detector_options(p)
    p.set_defaults(run=run)


def features_and_camera(path: str, options: dict, args: argparse.Namespace,
                        calibration: Optional[Calibration] = None):
    """(Features, the camera the file's reader knows or None); ``options``: the reader
    options of ``path`` (:func:`common.input_options`). ``calibration``: the camera
    given, whose view size the input's must be (checked before detecting)."""
    if is_feature_file(path):
        features = load_features(path)
        if calibration is not None:
            check_feature_file(calibration, path, features)
        return features, None
    light_field, metadata = common.read_input(path, options, preprocess=False)
    if calibration is not None:
        calibration.check(path, light_field.shape)
    if args.preprocess:
        light_field = prepare(light_field)
    detector = common.make_detector(common.detector_parameters(args))
    return features_from_light_field(detector, light_field), metadata.get("camera")


def carries_camera(path: str, args: argparse.Namespace) -> bool:
    """Whether the input ``path`` carries its camera's calibration (an HCI scene whose
    parameters.cfg holds the camera's entries), told without reading its light field."""
    if is_feature_file(path) or (args.format or io.guess_format(path)) != "hci":
        return False
    cfg = os.path.join(path, "parameters.cfg")
    if not os.path.isfile(cfg):
        return False
    parser = configparser.ConfigParser(interpolation=None)
    try:
        with open(cfg, encoding="utf-8") as f:
            parser.read_file(f)
    except (OSError, configparser.Error, UnicodeDecodeError):
        return False  # (the reader says what is wrong with it)
    return all(parser.has_option(section, key) for section, key in HCI_CAMERA_KEYS)


def run(args: argparse.Namespace) -> int:
    if args.out:  # before anything is read or detected
        # The calibration files are inputs too: --out must not replace the camera it reads.
        calibration_files = [path for path in (getattr(args, "camera_file", None),
                                               getattr(args, "hci", None),
                                               getattr(args, "lftoolbox", None)) if path]
        refuse_inputs([args.out], [args.a, args.b] + calibration_files, "--out")
        if os.path.isdir(args.out):
            raise ValueError(f"--out {args.out} is a folder; expected a JSON file path (such as "
                             f"{os.path.join(args.out, 'pose.json')}); nothing was written")
        if os.path.exists(args.out) and not args.overwrite:
            raise ValueError(f"{args.out}: exists; expected a new --out path (or --overwrite to "
                             "replace it); nothing was written")
    calibration = calibration_from_args(args)
    camera = None if calibration is None else calibration.camera
    without = [path for path in (args.a, args.b) if not carries_camera(path, args)]
    if camera is None and without:  # said before anything is read or detected
        raise ValueError(f"no camera calibration for {' and '.join(without)}: give --camera F B "
                         "CX CY (and --focus-distance), --camera-file, --hci or --lftoolbox, or "
                         "inputs that carry one (HCI scenes with the camera in parameters.cfg)")
    options_a, options_b = common.input_options([args.a, args.b], args,
                                                  common.light_field_flags(args))
    fa, camera_a = features_and_camera(args.a, options_a, args, calibration)
    fb, camera_b = features_and_camera(args.b, options_b, args, calibration)
    if camera is not None:
        camera_a = camera_b = camera
    _check(fa, args.a)
    _check(fb, args.b)
    R, t, matches = estimate_relative_pose(fa.keypoints, fa.descriptors, fb.keypoints,
                                           fb.descriptors, camera_a, camera_b, ratio=args.ratio,
                                           max_size_factor=args.max_size_factor)
    angle = float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))
    print(f"{args.a}: {len(fa.keypoints)} features; {args.b}: {len(fb.keypoints)} features; "
          f"{len(matches)} inlier matches")
    print("R =\n" + np.array2string(R, precision=6, suppress_small=True))
    print("t = " + np.array2string(t, precision=6, suppress_small=True) + f" m, |t| = "
          f"{np.linalg.norm(t):.6g} m; rotation {angle:.4f} deg")
    print("centre of B in A's frame: " + np.array2string(-R.T @ t, precision=6, suppress_small=True) + " m")
    if len(matches) < MIN_INLIERS:
        print(f"liff pose: warning: {len(matches)} inlier matches are too few to trust this pose (expected "
              f"at least {MIN_INLIERS}, as liff match and COLMAP's two-view verification)",
              file=sys.stderr)
    if args.out:
        with atomic_output(args.out) as partial, open(partial, "w", encoding="utf-8") as f:
            json.dump({"R": R.tolist(), "t": t.tolist(), "inliers": len(matches),
                       "convention": "X_B = R X_A + t, metres, OpenCV camera frames"}, f, indent=2)
        print(f"wrote {args.out}")
    return 0


def _check(features: Features, path: str) -> None:
    if features.descriptors is None or len(features.keypoints) == 0:
        raise ValueError(f"{path}: no features; expected a light field with texture")
