"""``liff match A B --plot matches.png``: ratio-test matches and RANSAC inliers."""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from .._paths import special_kind
from ..feature_file import Features, content_digest, features_from_light_field, load_features
from ..io.images import write_image
from ..matching import chance_inliers, draw_inliers, ratio_matches, verify
from ..outputs import atomic_output, refuse_inputs
from ..plot import to_display
from . import common

#: Fewer RANSAC inliers than this do not show that two views share a scene (COLMAP's
#: two-view verification needs 15: TwoViewGeometryOptions.min_num_inliers), nor fewer
#: than CHANCE_FACTOR times what RANSAC keeps among randomly re-paired matches.
MIN_INLIERS = 15
CHANCE_FACTOR = 2


def add_parser(sub) -> None:
    p = sub.add_parser(
        "match", help="match the features of two light fields",
        description="Matches two feature files from `liff detect` (or two light fields, "
                    "detected on the fly): nearest neighbours with Lowe's ratio test, then "
                    f"RANSAC. Prints the putative and inlier counts, and warns when the inliers are "
                    f"too few to show a shared scene: below {MIN_INLIERS}, or below "
                    f"{CHANCE_FACTOR}x what RANSAC keeps among randomly re-paired matches.")
    p.add_argument("a", help="feature file (.npz from liff detect) or light field")
    p.add_argument("b", help="feature file (.npz from liff detect) or light field")
    p.add_argument("--plot", default=None, help="picture of the inlier matches (.png)")
    p.add_argument("--ratio", type=common.ratio, default=0.75, help="ratio test (default 0.75)")
    p.add_argument("--model", choices=("homography", "fundamental"), default="homography",
                   help="RANSAC model (default homography)")
    p.add_argument("--threshold", type=common.positive_float, default=3.0, help="RANSAC pixels (default 3)")
    p.add_argument("--hloc", default=None, metavar="MATCHES.h5",
                   help="also add the pair's ratio-test matches to this hloc matches file, "
                        "under the names liff detect --hloc gives (A-NAME.png, B-NAME.png); "
                        "needs --hloc-features")
    p.add_argument("--hloc-features", default=None, metavar="FEATS.h5",
                   help="with --hloc: the hloc features file the matches index (liff detect "
                        "--hloc's); it must hold A's and B's features as they are now, else "
                        "the match is refused as stale")
    common.add_reader_options(p)
    common.add_detector_options(p)
    p.set_defaults(run=run)


def is_feature_file(path: str) -> bool:
    if not path.endswith(".npz") or special_kind(path) is not None:
        return False  # (read_light_field refuses a FIFO without opening it)
    try:
        with np.load(path, allow_pickle=False) as data:
            return "descriptors" in data.files and "keypoints" in data.files
    except Exception:  # not a readable zip: not a feature file (read_light_field will say why)
        return False


def features_of(path: str, options: dict, args: argparse.Namespace) -> Features:
    """The features of a feature file, or of a light field read with ``options``
    (:func:`common.input_options`) and detected with the command line's parameters."""
    if is_feature_file(path):
        return load_features(path)
    light_field = common.load_light_field(path, options, args.preprocess)
    detector = common.make_detector(common.detector_parameters(args))
    return features_from_light_field(detector, light_field)


def many_to_one(matches, inliers, a: str, b: str) -> str:
    """"; many-to-one: ..." when several matches share a feature of B (the ratio test
    matches each feature of A to its nearest in B, so counts of matches can exceed the
    features of B they join), else ""."""
    joined = len({m.trainIdx for m in matches})
    joined_inliers = len({m.trainIdx for m, inlier in zip(matches, inliers) if inlier})
    if joined == len(matches) and joined_inliers == int(np.sum(inliers)):
        return ""
    return (f"; many-to-one: the matches join {joined} and the inliers {joined_inliers} "
            f"distinct features of {b} (the ratio test matches each feature of {a} to its "
            f"nearest in {b}, and several may share one)")


def check_hloc_options(args: argparse.Namespace) -> None:
    """Before any reading: ``--hloc`` is a matches file (no input), with
    ``--hloc-features``, a features file that holds both images' names, which differ.

    Raises
    ------
    ValueError
        Naming the flag and what was expected.
    """
    if args.hloc_features and not args.hloc:
        raise ValueError("--hloc-features without --hloc; expected both (the matches file and "
                         "the features file its matches index)")
    if not args.hloc:
        return
    # lazy: defers pycolmap (optional: liff[sfm]) and SciPy (liff.hloc imports liff.colmap)
    from ..hloc import check_pair_names, features_in, image_name

    common.check_hloc_output(args.hloc, [args.a, args.b], "--hloc", "matches")
    if not args.hloc_features:
        raise ValueError("--hloc without --hloc-features; expected the hloc features file "
                         "the matches index (the FEATS.h5 of liff detect --hloc), which liff "
                         "checks holds the features matched now")
    if os.path.abspath(args.hloc_features) == os.path.abspath(args.hloc):
        raise ValueError(f"--hloc-features {args.hloc_features} is the --hloc file; expected "
                         "two files, features and matches")
    names = image_name(args.a), image_name(args.b)
    check_pair_names(*names)
    try:
        features_in(args.hloc_features, names)
    except ValueError as error:
        raise ValueError(f"--hloc-features: {error}") from None


def run(args: argparse.Namespace) -> int:
    if args.plot:
        refuse_inputs([args.plot], [args.a, args.b], "--plot")
    check_hloc_options(args)
    options_a, options_b = common.input_options([args.a, args.b], args,
                                                  common.light_field_flags(args))
    fa, fb = features_of(args.a, options_a, args), features_of(args.b, options_b, args)
    matches = ratio_matches(fa.descriptors, fb.descriptors, args.ratio)
    result = verify(fa.keypoints, fb.keypoints, matches, args.model, args.threshold)
    print(f"{args.a}: {len(fa.keypoints)} features; {args.b}: {len(fb.keypoints)} features")
    print(f"putative matches: {len(matches)}; inliers ({args.model}, {args.threshold:g} px): "
          f"{result.inlier_count}" + many_to_one(matches, result.inliers, args.a, args.b))
    chance = chance_inliers(fa.keypoints, fb.keypoints, matches, args.model, args.threshold)
    if result.inlier_count < max(MIN_INLIERS, CHANCE_FACTOR * chance):
        print(f"liff match: warning: {result.inlier_count} inliers are too few to show that the two share a "
              f"scene (expected at least {MIN_INLIERS}, and {CHANCE_FACTOR}x the {chance} that "
              "RANSAC keeps among randomly re-paired matches)", file=sys.stderr)
    if args.hloc:
        # lazy: defers pycolmap (optional: liff[sfm]) and SciPy (liff.hloc imports liff.colmap)
        from ..hloc import feature_file_group, image_name, updated, write_matches

        digests = (content_digest(feature_file_group(fa)[0]),
                   content_digest(feature_file_group(fb)[0]))
        with updated(args.hloc) as partial:
            write_matches(partial, image_name(args.a), image_name(args.b), matches,
                          len(fa.keypoints), len(fb.keypoints), overwrite=True, digests=digests,
                          features=args.hloc_features)
        print(f"hloc: {len(matches)} matches of {image_name(args.a)} and {image_name(args.b)} "
              f"-> {args.hloc}")
    if args.plot:
        if fa.centre_view is None or fb.centre_view is None:
            raise ValueError("--plot needs the centre views; the feature files hold none")
        picture = draw_inliers(to_display(fa.centre_view), fa.centre_view_keypoints(),
                               to_display(fb.centre_view), fb.centre_view_keypoints(), result)
        with atomic_output(args.plot) as partial:
            write_image(partial, picture)
    return 0
