"""``liff detect PATH... --out feats.npz --plot feats.png``: LiFF features of light fields."""

from __future__ import annotations

import argparse
import os

from .. import __version__
from ..feature_file import Features, centre_view, save_features
from ..io.images import write_image
from ..plot import draw_keypoints_by_slope
from . import common, mask


def add_parser(sub) -> None:
    p = sub.add_parser(
        "detect", help="detect LiFF features in light fields",
        description="Detects LiFF features in each light field and writes them to an .npz "
                    "(keypoints as rows x, y, size, angle, response, octave; slopes; "
                    "descriptors; the centre view). Several inputs: --out is a folder.")
    p.add_argument("paths", nargs="+", metavar="PATH", help="light field files or folders")
    p.add_argument("--out", default=None,
                   help="output .npz (one input) or folder (default: <name>.npz here)")
    p.add_argument("--plot", default=None,
                   help="also draw the features over the centre view: a .png (one input) or "
                        "a folder")
    p.add_argument("--workers", type=int, default=1, help="processes for many inputs (default 1)")
    p.add_argument("--overwrite", action="store_true", help="redo outputs that already exist")
    mask.add_mask_option(p)
    common.add_reader_options(p)
    common.add_detector_options(p)
    p.set_defaults(run=run)


def destination(given, path: str, suffix: str, many: bool, force_suffix: bool = True) -> str:
    """Where the output for ``path`` goes: ``given`` itself for one input (unless it is
    a folder, or ends with a path separator), else ``given``/<name><suffix>.

    ``force_suffix``: a single ``given`` without ``suffix`` gets it appended (numpy's
    savez does that anyway; say, and check, the real file name); False keeps ``given``
    as it is (an image, whose ending chooses the format)."""
    if given is None:
        return common.output_name(path, suffix)
    if many or os.path.isdir(given) or given.endswith(tuple(filter(None, (os.sep, os.altsep)))):
        return os.path.join(given, common.output_name(path, suffix))
    return given if given.endswith(suffix) or not force_suffix else given + suffix


def detect_one(path: str, out: str, plot, options: dict, preprocess: bool,
               parameters: dict, mask_spec=None) -> int:
    """Reads, detects and writes one light field; returns the feature count."""
    light_field = common.load_light_field(path, options, preprocess)
    detector = common.make_detector(parameters)
    keypoints, descriptors = detector.detectAndCompute(
        light_field, mask.load_mask(mask_spec, light_field, path))
    meta = dict(source=os.path.abspath(path), shape=list(light_field.shape),
                parameters=parameters, preprocess=preprocess, mask=mask_spec,
                liff_version=__version__)
    view = centre_view(light_field)
    save_features(out, Features(tuple(keypoints), descriptors, view, meta))
    if plot:
        used = detector.getSlicesUsed()  # the range the detector searched
        slope_range = (used[0], used[-1]) if len(used) > 1 else None
        write_image(plot, draw_keypoints_by_slope(view, keypoints, slope_range))
    return len(keypoints)


def run(args: argparse.Namespace) -> int:
    many = len(args.paths) > 1
    for folder in (args.out, args.plot):
        if many and folder and os.path.exists(folder) and not os.path.isdir(folder):
            raise ValueError(f"{folder}: exists and is not a folder; expected a folder for "
                             f"{len(args.paths)} inputs")
    jobs, skipped, seen = [], 0, {}
    for path in args.paths:
        out = destination(args.out, path, ".npz", many)
        plot = destination(args.plot, path, ".png", many, force_suffix=False) if args.plot else None
        if out in seen:
            raise ValueError(f"{path} and {seen[out]} would both write {out}; expected inputs "
                             "with distinct names (or one --out per run)")
        seen[out] = path
        if not args.overwrite and os.path.exists(out) and (plot is None or os.path.exists(plot)):
            skipped += 1
            continue
        for target in (out, plot):
            if target and os.path.dirname(target):
                os.makedirs(os.path.dirname(target), exist_ok=True)
        jobs.append((path, out, plot, common.reader_options(args), args.preprocess,
                     common.detector_parameters(args), args.mask))
    counts, failures = common.run_batch(detect_one, jobs, args.workers, "detect",
                                        label=lambda job: job[0])
    for job, count in zip(jobs, counts):
        if count is not None:
            print(f"{job[0]}: {count} features -> {job[1]}" + (f", {job[2]}" if job[2] else ""))
    if skipped:
        print(f"skipped {skipped} input(s) whose outputs exist (--overwrite to redo them)")
    return 1 if failures else 0
