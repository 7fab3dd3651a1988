"""``liff match A B --plot matches.png``: ratio-test matches and RANSAC inliers."""

from __future__ import annotations

import argparse

import numpy as np

from ..feature_file import Features, features_from_light_field, load_features
from ..io.images import write_image
from ..matching import draw_inliers, ratio_matches, verify
from ..plot import to_display
from . import common


def add_parser(sub) -> None:
    p = sub.add_parser(
        "match", help="match the features of two light fields",
        description="Matches two feature files from `liff detect` (or two light fields, "
                    "detected on the fly): nearest neighbours with Lowe's ratio test, then "
                    "RANSAC. Prints the putative and inlier counts.")
    p.add_argument("a", help="feature file (.npz from liff detect) or light field")
    p.add_argument("b", help="feature file or light field")
    p.add_argument("--plot", default=None, help="picture of the inlier matches (.png)")
    p.add_argument("--ratio", type=float, default=0.75, help="ratio test (default 0.75)")
    p.add_argument("--model", choices=("homography", "fundamental"), default="homography",
                   help="RANSAC model (default homography)")
    p.add_argument("--threshold", type=float, default=3.0, help="RANSAC pixels (default 3)")
    common.add_reader_options(p)
    common.add_detector_options(p)
    p.set_defaults(run=run)


def is_feature_file(path: str) -> bool:
    if not path.endswith(".npz"):
        return False
    try:
        with np.load(path, allow_pickle=False) as data:
            return "descriptors" in data.files and "keypoints" in data.files
    except Exception:  # not a readable zip: not a feature file (read_light_field will say why)
        return False


def features_of(path: str, args: argparse.Namespace) -> Features:
    if is_feature_file(path):
        return load_features(path)
    light_field = common.load_light_field(path, common.reader_options(args), args.preprocess)
    detector = common.make_detector(common.detector_parameters(args))
    return features_from_light_field(detector, light_field)


def run(args: argparse.Namespace) -> int:
    fa, fb = features_of(args.a, args), features_of(args.b, args)
    matches = ratio_matches(fa.descriptors, fb.descriptors, args.ratio)
    result = verify(fa.keypoints, fb.keypoints, matches, args.model, args.threshold)
    print(f"{args.a}: {len(fa.keypoints)} features; {args.b}: {len(fb.keypoints)} features")
    print(f"putative matches: {len(matches)}; inliers ({args.model}, {args.threshold:g} px): "
          f"{result.inlier_count}")
    if args.plot:
        if fa.centre_view is None or fb.centre_view is None:
            raise ValueError("--plot needs the centre views; the feature files hold none")
        picture = draw_inliers(to_display(fa.centre_view), fa.keypoints,
                               to_display(fb.centre_view), fb.keypoints, result)
        write_image(args.plot, picture)
    return 0
