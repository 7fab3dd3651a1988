"""``liff detect PATH... --out feats.npz --plot feats.png``: LiFF features of light fields."""

from __future__ import annotations

import argparse
import os
from typing import List, Optional

import cv2

from .. import __version__
from ..feature_file import Features, centre_view, read_meta, save_features
from ..io._shared import write_image
from ..outputs import atomic_output, refuse_inputs
from ..plot import draw_keypoints_by_slope
from . import common


def add_parser(sub) -> None:
    p = sub.add_parser(
        "detect", help="detect LiFF features in light fields",
        description="Detects LiFF features in each light field and writes them to an .npz "
                    "(keypoints as rows x, y, size, angle, response, octave; slopes; "
                    "descriptors; the centre view; how they were made). Several inputs: "
                    "--out is a folder. An output that exists is kept if it was made with the "
                    "same settings from the same input, redone otherwise (and said so).")
    p.add_argument("paths", nargs="+", metavar="PATH", help="light field files or folders")
    p.add_argument("--out", default=None,
                   help="output .npz (one input) or folder (default: <name>.npz here)")
    p.add_argument("--plot", default=None,
                   help="also draw the features over the centre view: a .png (one input) or "
                        "a folder")
    p.add_argument("--workers", type=int, default=1, help="processes for many inputs (default 1)")
    p.add_argument("--overwrite", action="store_true",
                   help="redo outputs that exist even if made with the same settings, and "
                        "replace files at the output paths that are not liff feature files")
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


def settings(path: str, options: dict, preprocess: bool, parameters: dict) -> dict:
    """How a feature file is made, as recorded in its ``meta``: an existing output is
    kept only if these are equal (JSON's view of them: tuples are lists)."""
    return dict(source=os.path.abspath(path), reader_options=options, preprocess=preprocess,
                parameters=parameters, liff_version=__version__)


def detect_one(path: str, out: str, plot, options: dict, preprocess: bool,
               parameters: dict) -> int:
    """Reads, detects and writes one light field; returns the feature count."""
    light_field = common.load_light_field(path, options, preprocess)
    detector = common.make_detector(parameters)
    keypoints, descriptors = detector.detectAndCompute(light_field, None)
    meta = dict(settings(path, options, preprocess, parameters), shape=list(light_field.shape))
    view = centre_view(light_field)
    with atomic_output(out) as partial:
        save_features(partial, Features(tuple(keypoints), descriptors, view, meta))
    if plot:
        slope_range = (parameters["firstSlope"], parameters["lastSlope"])
        with atomic_output(plot) as partial:
            write_image(partial, draw_keypoints_by_slope(view, keypoints, slope_range))
    return len(keypoints)


def changes(out: str, plot: Optional[str], wanted: dict) -> Optional[List[str]]:
    """What makes the existing ``out`` (and ``plot``) stale: None if they can be kept,
    [] if missing, else the differences ("nfeatures 0 -> 10", "the input is newer").

    Raises
    ------
    ValueError
        If ``out`` exists and is not a liff feature file: it is not ours to replace.
    """
    if not os.path.exists(out):
        return []
    made = read_meta(out)
    if made is None:
        raise ValueError(f"{out}: exists and is not a liff feature file; expected a new output "
                         "path (or --overwrite to replace it)")
    old = {key: made.get(key) for key in wanted}
    old.update({f"parameters.{k}": v for k, v in (made.get("parameters") or {}).items()})
    new = common.json_like(wanted)
    new.update({f"parameters.{k}": v for k, v in new["parameters"].items()})
    differ = [f"{key.replace('parameters.', '').replace('_', ' ')} {old.get(key)} -> {value}"
              for key, value in new.items() if key != "parameters" and old.get(key) != value]
    if not differ and common.modified_after(wanted["source"], out):
        differ = ["the input changed after the output was made"]
    if not differ and plot and not os.path.exists(plot):
        return []
    return differ or None


def plan(args: argparse.Namespace) -> tuple:
    """(jobs to run, outputs kept, {output: reasons} of outputs to redo)."""
    many = len(args.paths) > 1
    common.check_output_folder(args.out, ".npz", len(args.paths), "--out")
    if args.plot:
        common.check_output_folder(args.plot, ".png", len(args.paths), "--plot")
    jobs, kept, redo, seen = [], 0, {}, {}
    for path in args.paths:
        out = destination(args.out, path, ".npz", many)
        plot = destination(args.plot, path, ".png", many, force_suffix=False) if args.plot else None
        if plot and not cv2.haveImageWriter(plot):
            raise ValueError(f"{plot}: OpenCV cannot write this kind of image; expected --plot "
                             "with an image ending such as .png or .jpg, or a folder")
        if out in seen:
            raise ValueError(f"{path} and {seen[out]} would both write {out}; expected inputs "
                             "with distinct names (or one --out per run)")
        seen[out] = path
        refuse_inputs([out], args.paths, "--out")
        if plot:
            refuse_inputs([plot], args.paths, "--plot")
        job = (path, out, plot, common.reader_options(args), args.preprocess,
               common.detector_parameters(args))
        stale = [] if args.overwrite else changes(out, plot, settings(*job[:1], *job[3:]))
        if stale is None:
            kept += 1
            continue
        if stale:
            redo[out] = stale
        jobs.append(job)
    return jobs, kept, redo


def run(args: argparse.Namespace) -> int:
    jobs, kept, redo = plan(args)
    for out, reasons in redo.items():
        print(f"redoing {out}, out of date: {'; '.join(reasons)}")
    counts, failures = common.run_batch(detect_one, jobs, args.workers, "detect",
                                        label=lambda job: job[0])
    for job, count in zip(jobs, counts):
        if count is not None:
            print(f"{job[0]}: {count} features -> {job[1]}" + (f", {job[2]}" if job[2] else ""))
    if kept:
        print(f"skipped {kept} input(s) whose outputs exist, made with the same settings "
              "(--overwrite to redo them)")
    return 1 if failures else 0
