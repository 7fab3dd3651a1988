"""``liff colmap`` (a COLMAP database of centre views and LiFF features) and ``liff sfm``
(that, then matching of every pair, by COLMAP or by metric pose with a calibrated camera,
and incremental mapping, with the paper's table)."""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from typing import List, Optional

import numpy as np

from ..feature_file import centre_view, load_features
from ..keypoint_rows import keypoint_slopes, keypoints_to_rows, rows_to_keypoints
from ..outputs import refuse_inputs
from . import common
from .calibration import add_camera_options, calibration_from_args
from .match import MIN_INLIERS, is_feature_file

METRICS = (("registered images", "registered", "{:.0%}"),
           ("keypoints / image", "keypoints_per_image", "{:.0f}"),
           ("putative matches / image", "putative_matches_per_image", "{:.0f}"),
           ("inlier matches / image", "inlier_matches_per_image", "{:.0f}"),
           ("match ratio", "match_ratio", "{:.3f}"),
           ("precision", "precision", "{:.3f}"),
           ("matching score", "matching_score", "{:.3f}"),
           ("3D points", "points3D", "{}"),
           ("mean track length", "track_length", "{:.2f}"))


def add_parser(sub) -> None:
    for name, helptext in (("colmap", "write centre views and LiFF features into a COLMAP database"),
                           ("sfm", "COLMAP structure from motion on LiFF features")):
        p = sub.add_parser(name, help=helptext, description=helptext[0].upper() + helptext[1:] + (
            ". The centre view of each light field is the image of its camera pose."
            if name == "colmap" else ": a database of LiFF features, exhaustive matching, "
            "incremental mapping, and the paper's table (registered images, matches, 3-D "
            "points, track length). Exits non-zero if any image is left unregistered."))
        p.add_argument("paths", nargs="+", metavar="PATH",
                       help="light fields (one per camera pose), folders of them, or feature "
                            "files from liff detect")
        if name == "colmap":
            p.add_argument("--database", required=True, help="COLMAP database to create")
            p.add_argument("--image-dir", required=True, help="folder for the centre views")
        else:
            p.add_argument("--workspace", required=True,
                           help="folder for database.db, images/ and sparse/")
            p.add_argument("--mapper", choices=("poses", "default", "permissive"), default=None,
                           help="'poses': a metric model from the pairs' metric poses (pose "
                                "graph, then COLMAP's triangulator; needs --matching pose); "
                                "'default' or 'permissive': COLMAP's incremental mapper with "
                                "its default or permissive options, scaled to metres with a "
                                "camera (default: poses with pose matching, else default)")
            add_camera_options(p)  # with a camera, the model is scaled to metres
            p.add_argument("--matching", choices=("pose", "colmap"), default=None,
                           help="'pose': every pair matched by its metric relative pose "
                                "(liff.colmap.match_by_pose; needs a camera, well under a "
                                "second per pair); 'colmap': COLMAP's exhaustive matching and "
                                "verification (default: pose with a camera, else colmap)")
        p.add_argument("--focal", type=float, default=None,
                       help="focal length in pixels (default: COLMAP's guess, 1.2 x max side)")
        p.add_argument("--workers", type=common.positive_int, default=1,
                       help="processes for detection" + (
                           "" if name == "colmap" else " and for matching pairs by pose")
                       + " (default 1)")
        p.add_argument("--overwrite", action="store_true", help="replace an existing database")
        common.add_reader_options(p)
        common.add_detector_options(p)
        p.set_defaults(run=run_colmap if name == "colmap" else run_sfm)


def features_for_colmap(path: str, options: dict, preprocess: bool, parameters: dict):
    """(centre view uint8 grey, keypoint rows (N, 7), descriptors) of one input; arrays
    only, so that worker processes can send them back."""
    return _features_and_shape(path, options, preprocess, parameters)[:3]


def _features_and_shape(path: str, options: dict, preprocess: bool, parameters: dict):
    """:func:`features_for_colmap` and the light field's shape (T, S, V, U[, C]), or
    None for a feature file that does not record it."""
    from .. import colmap  # lazy: defers pycolmap (optional: liff[sfm]) and SciPy

    if is_feature_file(path):
        features = load_features(path)
        if features.centre_view is None:
            raise ValueError("the feature file holds no centre view; expected one from liff detect")
        view, keypoints, descriptors = features.centre_view, features.keypoints, features.descriptors
        shape = features.meta.get("shape")
    else:
        light_field = common.load_light_field(path, options, preprocess=False)
        shape = light_field.shape
        if preprocess:  # the paper's 8-bit greyscale, which SIFT on the centre view also gets
            light_field = colmap.prepare_light_field(light_field)
        keypoints, descriptors = common.make_detector(parameters).detectAndCompute(light_field, None)
        view = centre_view(light_field)
    view = colmap.grey_uint8_image(view)  # grey uint8, as COLMAP wants
    return view, keypoints_to_rows(keypoints), descriptors, None if shape is None else tuple(shape)


def write(args: argparse.Namespace, database: str, image_dir: str, focal=None,
          principal_point=None, images_out=None, calibration=None) -> int:
    """Detects (or loads) features of every input and writes the database; returns the
    number of inputs that failed (``liff colmap``: any failure is an error, and nothing
    is written; ``liff sfm`` goes on with the others and says how many the database
    holds). Inputs of different view sizes are refused, naming them, before anything is
    written (no workspace is made). ``focal`` and ``principal_point`` (OpenCV pixels)
    default to ``--focal`` and the image centre; the images written are appended to
    ``images_out`` if given. ``calibration`` (:class:`.calibration.Calibration`): inputs
    of another view size (or grid) than it states are refused before anything is
    written."""
    from .. import colmap  # lazy: defers pycolmap (optional: liff[sfm]) and SciPy

    names = [common.output_name(path, ".png") for path in args.paths]
    refuse_inputs([database] + [os.path.join(image_dir, n) for n in names],
                  common.protected_inputs(args), "--database / --image-dir / --workspace")
    if os.path.exists(database):
        if not args.overwrite:
            raise ValueError(f"{database}: exists; COLMAP needs a fresh database (or --overwrite)")
        os.remove(database)
    if len(set(names)) != len(names):
        raise ValueError(f"inputs give repeated image names {sorted(names)}; expected distinct "
                         "file or folder names")
    jobs = [(item.path, item.options, args.preprocess, common.detector_parameters(args))
            for item in args.inputs]
    results, failures = common.run_batch(_features_and_shape, jobs, args.workers, args.command,
                                         label=lambda job: job[0])
    images, read = [], []
    for path, name, result in zip(args.paths, names, results):
        if result is None:
            continue
        view, rows, descriptors, shape = result
        if calibration is not None:  # before anything is written
            if shape is None:
                calibration.check(path, view.shape, grid_known=False)
            else:
                calibration.check(path, shape)
        images.append(colmap.FeatureImage(name, view, rows_to_keypoints(rows), descriptors))
        read.append(path)
    if not images:
        raise ValueError("no input could be read; nothing written")
    if failures and args.command == "colmap":  # a database of some inputs is no answer
        raise ValueError(f"{failures} of {len(names)} input(s) failed (above); expected every "
                         "input read: no database written, nothing left")
    shapes = [im.image.shape for im in images]
    if len({shape[:2] for shape in shapes}) > 1:  # before anything is written
        raise ValueError(f"the inputs' centre views differ in size: "
                         f"{colmap.describe_sizes(read, shapes)}; expected one camera (one "
                         "view size); nothing written")
    colmap.write_database(database, image_dir, images, focal=args.focal if focal is None else focal,
                          principal_point=principal_point)
    if images_out is not None:
        images_out.extend(images)
    total = sum(len(im.keypoints) for im in images)
    print(f"{database}: {len(images)} images, {total} LiFF features; centre views in {image_dir}")
    return failures


def scale_to_metres(result, images, camera, sparse: str, pair_poses=None, metric_model=False) -> None:
    """Scales every model to metres (liff.colmap.metric_scale: by the pair poses'
    baselines where there are some, else by the features' slopes), rewrites it in place
    and prints the factor and how the two estimates agree. A ``metric_model`` (from the
    pair poses) is in metres already: only the checks are printed."""
    from .. import colmap  # lazy: defers pycolmap (optional: liff[sfm]) and SciPy

    slopes = {im.name: keypoint_slopes(im.keypoints) for im in images}
    for index, model in sorted(result.reconstructions.items()):
        fit = colmap.metric_scale(model, slopes, camera, pair_poses)
        from_slopes = (f"{fit.inliers} of {fit.observations} observations' slopes "
                       f"(noise {number(fit.sigma_slope, '.3g')} px per view)")
        if fit.sigma_slope > SLOPE_NOISE_WARNING:
            print(f"liff sfm: model {index}'s points disagree with their slopes by "
                  f"{fit.sigma_slope:.3g} px per view (robust sd; a right calibration gives a few "
                  "hundredths): check the camera (focal length, baseline, focus distance)",
                  file=sys.stderr)
        if metric_model:
            print(f"  model {index} in metres from {fit.pairs} pair pose{'s' if fit.pairs != 1 else ''} "
                  "(pose graph); checks: "
                  f"the pair baselines say x {number(fit.scale_from_baselines, '.4f')}, {from_slopes} "
                  f"x {number(fit.scale_from_slopes, '.4f')}")
            checks = (fit.scale_from_baselines, fit.scale_from_slopes)
            if any(abs(check - 1) > SHAPE_WARNING for check in checks if np.isfinite(check)):
                print(f"liff sfm: model {index} disagrees with its pair poses or slopes by more "
                      f"than {100 * SHAPE_WARNING:.0f}%: check the camera's calibration", file=sys.stderr)
            continue
        colmap.scale_reconstruction(model, fit.scale)
        model.write(os.path.join(sparse, str(index)))
        if fit.source == "baselines":
            spread = "" if np.isnan(fit.baseline_spread) else f", spread {100 * fit.baseline_spread:.2g}%"
            slopes_say = ("" if np.isnan(fit.scale_from_slopes)
                          else f"; {from_slopes} say x {fit.scale_from_slopes:.6g}")
            print(f"  model {index} scaled to metres: x {fit.scale:.6g} (from the metric baselines "
                  f"of {fit.pairs} image pairs{spread}{slopes_say})")
            if abs(fit.shape_disagreement) > SHAPE_WARNING:
                print(f"liff sfm: model {index}'s points are {100 * fit.shape_disagreement:+.1f}% "
                      "deeper by their slopes than its camera baselines make them: its shape is "
                      "off (few images or points); its cameras are scaled right, its points less so "
                      "(--mapper poses builds the model from the pair poses)", file=sys.stderr)
        else:
            print(f"  model {index} scaled to metres: x {fit.scale:.6g} (from {from_slopes})")


def no_points_reason(pair_poses: Optional[dict]) -> str:
    """Why a model has no 3-D points: pairs of fewer inliers than COLMAP triangulates
    from (:data:`liff.cli.match.MIN_INLIERS`, its two-view ``min_num_inliers``), named
    with their counts, else poses without a baseline between them."""
    few = {pair: pose.inliers for pair, pose in (pair_poses or {}).items()
           if pose is not None and pose.inliers < MIN_INLIERS}
    if few:
        listed = ", ".join(f"{a}-{b} ({n})" for (a, b), n in list(few.items())[:5])
        return (f"{len(few)} pair(s) have fewer inlier matches than the {MIN_INLIERS} COLMAP "
                f"triangulates from: {listed}{', ...' if len(few) > 5 else ''}; expected more "
                "overlap or texture between the poses (or check the camera)")
    return ("the poses have no baseline between them (rotations about the centre view, or "
            "the same light field twice)")


#: scale_to_metres warns when the slopes' scale and the baselines' differ by more than this
SHAPE_WARNING = 0.05
#: and when the slopes' residuals have a larger robust sd than this, pixels per view step
#: (0.005-0.03 in benchmarks/metric.py's scenes; 3.5 with a baseline 10x off)
SLOPE_NOISE_WARNING = 0.25


def number(value: float, fmt: str) -> str:
    """A value as printed, "-" for NaN (as the SfM table prints missing values)."""
    return "-" if np.isnan(value) else format(value, fmt)


def run_colmap(args: argparse.Namespace) -> int:
    common.expand_args(args, common.reader_options(args), features=True,
                       light_field_flags=common.light_field_flags(args))
    return 1 if write(args, args.database, args.image_dir) else 0


def run_sfm(args: argparse.Namespace) -> int:
    # lazy: defers pycolmap (optional: liff[sfm]) and SciPy; first: without pycolmap it
    # says how to install it
    from .. import colmap

    common.expand_args(args, common.reader_options(args), features=True,
                       light_field_flags=common.light_field_flags(args))
    if len(args.paths) < 2:
        raise ValueError(f"{len(args.paths)} input; expected light fields of at least 2 camera "
                         "poses for structure from motion")
    database = os.path.join(args.workspace, "database.db")
    image_dir = os.path.join(args.workspace, "images")
    sparse = os.path.join(args.workspace, "sparse")
    refuse_inputs([database, image_dir, sparse], common.protected_inputs(args), "--workspace")
    calibration = calibration_from_args(args)
    camera = None if calibration is None else calibration.camera
    matching = args.matching or ("pose" if camera is not None else "colmap")
    if matching == "pose" and camera is None:
        raise ValueError("--matching pose needs the camera's calibration; expected --camera, "
                         "--camera-file, --hci or --lftoolbox, or --matching colmap")
    mapper = args.mapper or ("poses" if matching == "pose" else "default")
    if mapper == "poses" and matching != "pose":
        raise ValueError("--mapper poses builds the model from the pairs' metric poses; expected "
                         "--matching pose (and a camera), or --mapper default or permissive")
    if args.overwrite:
        shutil.rmtree(sparse, ignore_errors=True)
    images: List[colmap.FeatureImage] = []
    if camera is None:
        failures = write(args, database, image_dir, images_out=images)
    else:  # the calibration's focal length and principal point are COLMAP's prior
        failures = write(args, database, image_dir, args.focal or camera.focal_length,
                         camera.principal_point, images_out=images, calibration=calibration)
    with common.step(f"liff sfm: matching every pair of {len(args.paths) - failures} images"
                     + (" by their metric pose" if matching == "pose" else "")):
        if matching == "pose":
            count = len(images) * (len(images) - 1) // 2
            with common.progress(desc="liff sfm: pairs matched", total=count, unit="pair") as bar:
                pair_poses = colmap.match_by_pose(database, images, camera, workers=args.workers,
                                                  progress=bar.update)
            counts = [pose.inliers for pose in pair_poses.values() if pose is not None]
            print(f"matched by metric pose: {len(counts)} of {len(pair_poses)} pairs"
                  + (f", {int(np.median(counts))} inlier matches per pair (median)" if counts else ""))
            unmatched = [f"{a}-{b}" for (a, b), pose in pair_poses.items() if pose is None]
            if unmatched:
                print(f"liff sfm: no metric pose for {len(unmatched)} of {len(pair_poses)} pairs "
                      f"({', '.join(unmatched[:5])}{', ...' if len(unmatched) > 5 else ''}); "
                      "those pairs are not matched", file=sys.stderr)
        else:
            pair_poses = None
            colmap.match(database)
    if mapper == "poses":
        assert pair_poses is not None  # (the poses mapper comes with pose matching)
        with common.step("liff sfm: a metric model from the pair poses (pose graph, COLMAP's "
                         "triangulator)"):
            result = colmap.reconstruct_from_poses(database, image_dir, sparse, pair_poses)
    else:  # a calibrated camera's intrinsics are known: bundle adjustment keeps them
        with common.step(f"liff sfm: incremental mapping ({mapper} mapper)"):
            result = colmap.reconstruct(database, image_dir, sparse, mapper,
                                        fixed_intrinsics=camera is not None)
    metrics = colmap.table_metrics(database, result)
    print(f"reconstruction ({mapper} mapper): "
          + ("a model in " + sparse if result.success else "FAILED (no model)"))
    if result.best is not None and result.best.num_points3D() == 0:
        print(f"liff sfm: the model has no 3-D points: {no_points_reason(pair_poses)}",
              file=sys.stderr)
        return 1
    if camera is not None and result.success:
        scale_to_metres(result, images, camera, sparse, pair_poses, metric_model=mapper == "poses")
    for label, key, fmt in METRICS:
        value = metrics[key]
        print(f"  {label:26s} " + ("-" if isinstance(value, float) and np.isnan(value) else fmt.format(value)))
    registered = result.best.num_reg_images() if result.best is not None else 0
    if not result.success and mapper == "poses":
        print("liff sfm: no pair has a metric pose, so there is no model; the poses need more "
              "overlap (or check the camera)", file=sys.stderr)
    if not result.success and mapper == "default":
        print("liff sfm: COLMAP's default mapper made no model (its first pair needs 100 inliers "
              "seen 16 degrees apart); try --mapper permissive, or more poses", file=sys.stderr)
    if result.success and registered < result.num_images:
        hint = ("no metric pose links them to the others" if mapper == "poses"
                else "try --mapper permissive, or more overlap between poses")
        print(f"liff sfm: only {registered} of {result.num_images} images registered; the others "
              f"are not in the model ({hint}):", file=sys.stderr)
    if registered < result.num_images:  # each left-out image and why (all when no model)
        inputs = {common.output_name(path, ".png"): path for path in args.paths}
        for name, reason in colmap.left_out_images(database, result):
            print(f"  {inputs.get(name, name)} (image {name}): {reason}", file=sys.stderr)
    return 1 if failures or registered < result.num_images else 0
