"""``liff detect PATH... --out feats.npz --plot feats.png``: LiFF features of light fields."""

from __future__ import annotations

import argparse
import glob
import os
import sys
import warnings
from contextlib import contextmanager
from typing import Callable, List, NamedTuple, Optional, Tuple

import cv2

from .. import __version__, batch
from .._detector import as_read_in_place
from .._warnings import LiffWarning
from ..feature_file import (Features, centre_view, content_problem, keypoints_in_centre_view,
                            read_meta, save_features)
from ..io.images import write_image
from ..outputs import atomic_output, refuse_inputs
from ..plot import draw_keypoints_by_slope
from . import common, mask


def add_parser(sub) -> None:
    p = sub.add_parser(
        "detect", help="detect LiFF features in light fields",
        description="Detects LiFF features in each light field and writes them to an .npz "
                    "(keypoints as rows x, y, size, angle, response, octave; slopes; "
                    "descriptors; the centre view; how they were made). Several inputs: "
                    "--out is a folder. An output that exists is kept if it was made with the "
                    "same settings from the same input, redone otherwise (and said so).")
    p.add_argument("paths", nargs="*", metavar="PATH",
                   help="light fields (files or folders of views), folders of light fields, or "
                        "quoted glob patterns")
    p.add_argument("--from-list", default=None, metavar="FILE",
                   help="a text file of more inputs, one a line (# comments), so a dataset "
                        "need not fit on the command line; a line may add reader options "
                        "for its input after the path (IMG_1.png --lenslet 14); lines are "
                        "split as a shell would: quote paths with spaces")
    p.add_argument("--out", default=None,
                   help="output .npz (one input) or folder (default: <name>.npz here)")
    p.add_argument("--plot", default=None,
                   help="also draw the features over the centre view: a .png (one input) or "
                        "a folder")
    p.add_argument("--workers", type=common.positive_int, default=1,
                   help="local processes for many inputs (default 1)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run each light field as a task on the Dask cluster of this scheduler "
                        "(e.g. tcp://10.0.0.5:8786; pip install 'liff[dask]'); see "
                        "docs/BATCH.md")
    p.add_argument("--manifest", default=None, metavar="CSV",
                   help="write the run's manifest (input, output, status, features, slope "
                        "range, seconds, CPU seconds, error, worker, notes, format, reader "
                        "options) here, as the run goes "
                        "(default for several inputs: OUT/manifest-<UTC time>.csv, or "
                        "...-2.csv when a run of the same second has taken it)")
    p.add_argument("--hloc", default=None, metavar="FEATS.h5",
                   help="also add every output's features to this hloc features file (a group "
                        "per light field named OUTPUT-NAME.png), for hloc's matchers, "
                        "triangulation and reconstruction; a group of other features than "
                        "before is replaced only with --overwrite, since matches made from it "
                        "are stale")
    p.add_argument("--hloc-images", default=None, metavar="DIR",
                   help="with --hloc: write each centre view here under its group's name (the "
                        "image folder hloc is given)")
    mask.add_mask_option(p)
    p.add_argument("--dry-run", action="store_true",
                   help="list what would be read as what (each input's format, how it was "
                        "recognised and its reader options) and what the folders hold that is "
                        "not an input, then stop: nothing is read or written")
    p.add_argument("--overwrite", action="store_true",
                   help="redo outputs that exist even if made with the same settings, and "
                        "replace files at the output paths that are not liff feature files")
    common.add_reader_options(p)
    common.add_detector_options(p)
    p.set_defaults(run=run, parser=p)


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


def settings(path: str, options: dict, preprocess: bool, parameters: dict,
             mask_spec: Optional[str] = None) -> dict:
    """How a feature file is made, as recorded in its ``meta``: an existing output is
    kept only if these are equal (JSON's view of them: tuples are lists)."""
    return dict(source=os.path.abspath(path), reader_options=options, preprocess=preprocess,
                parameters=parameters, mask=mask_spec, liff_version=__version__)


class Detected(NamedTuple):
    """What :func:`detect_one` found: the feature count, the slope range searched (the
    first and last searched slice's slope), the slices searched and built, where the
    range came from ("automatic", "given", or the reader's: "parameters.cfg"), and the
    warnings about the input (one line each)."""

    features: int
    slope_range: Tuple[float, float]
    searched: int = 0
    built: int = 0
    slopes_from: str = "automatic"
    notes: Tuple[str, ...] = ()


def detect_one(path: str, out: str, plot, options: dict, preprocess: bool,
               parameters: dict, mask_spec: Optional[str] = None) -> Detected:
    """Reads, detects and writes one light field; returns what it found."""
    identity = common.input_identity(path)  # before reading: a change meanwhile is redone
    # the warnings about the input, reading (missing views, lenslet size) and detecting,
    # are its notes: the manifest's, and one line each on stderr
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LiffWarning)
        light_field, metadata = common.read_input(path, options, preprocess)
        # A copy detection would make (Fortran order) is made now, so that it counts.
        light_field = as_read_in_place(light_field)
        resolved, slopes_from = common.slope_range(parameters, metadata)
        detector = common.make_detector(resolved)
        keypoints, descriptors = detector.detectAndCompute(
            light_field, mask.load_mask(mask_spec, light_field, path))
    notes = [str(w.message) for w in caught if issubclass(w.category, LiffWarning)]
    searched, built = detector.getSearchedSlopes(), detector.getSlicesUsed()
    slope_range = (searched[0], searched[-1]) if searched else (float("nan"), float("nan"))
    meta = dict(settings(path, options, preprocess, parameters, mask_spec),
                input_identity=identity, shape=list(light_field.shape),
                slopes_searched=searched, slopes_from=slopes_from,
                plot=os.path.abspath(plot) if plot else None)
    view = centre_view(light_field)
    with atomic_output(out) as partial:
        save_features(partial, Features(tuple(keypoints), descriptors, view, meta))
    if plot:
        with atomic_output(plot) as partial:
            picture = draw_keypoints_by_slope(view, keypoints_in_centre_view(
                keypoints, light_field.shape), (built[0], built[-1]))
            write_image(partial, picture)
    return Detected(len(keypoints), slope_range, len(searched), len(built), slopes_from, notes)


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
    if "reader_options" in old:  # as the command line writes them: --lenslet 14
        old["reader_options"] = common.shown_options(old["reader_options"] or {}) or None
        new["reader_options"] = common.shown_options(new["reader_options"]) or None

    def shown(value):
        return "not given" if value is None else value

    differ = [f"{key.replace('parameters.', '').replace('_', ' ')} {shown(old.get(key))} -> "
              f"{shown(value)}"
              for key, value in new.items() if key != "parameters" and old.get(key) != value]
    if "input_identity" in made:  # size and time, compared for equality
        changed = made["input_identity"] != common.input_identity(wanted["source"])
    else:  # (a feature file made before liff recorded it)
        changed = common.modified_after(wanted["source"], out)
    if not differ and changed:
        differ = ["the input changed after the output was made"]
    if not differ:  # the settings match: keep it only if its content is what was written
        problem = content_problem(out)
        differ = [problem] if problem else []
    if not differ and plot and not os.path.exists(plot):
        return []
    return differ or None


def refuse_foreign_plot(plot: str, out: str) -> None:
    """Raises ValueError if ``plot`` exists and is not the picture ``out``'s run drew
    (as recorded in its feature file): it is not ours to replace."""
    if not os.path.exists(plot):
        return
    made = read_meta(out) if os.path.exists(out) else None
    if made is None or made.get("plot") != os.path.abspath(plot):
        raise ValueError(f"{plot}: exists and is not the plot of {out}; expected a new --plot "
                         "path (or --overwrite to replace it); nothing was written")


def plan(args: argparse.Namespace, options: dict, parameters: dict) -> tuple:
    """(tasks to run, outcomes of outputs kept, {output: reasons} of those redone) for
    ``args.paths`` (and ``--from-list``), ``--out``, ``--plot`` and ``--overwrite``.

    Raises
    ------
    ValueError
        Before anything is written: outputs over inputs, colliding outputs, a file name
        for several inputs, a plot OpenCV cannot write, a foreign file in the way.
    """
    common.expand_args(args, options, args.from_list)
    if not args.paths:
        raise ValueError("no input; expected light fields as PATH arguments or --from-list")
    many = is_batch(args)
    count = max(len(args.paths), 2 if many else 1)  # (a batch writes into folders)
    common.check_output_folder(args.out, ".npz", count, "--out")
    if args.plot:
        common.check_output_folder(args.plot, ".png", count, "--plot")
    tasks, kept, redo, seen = [], [], {}, {}
    for item in args.inputs:
        path, options = item.path, item.options
        out = destination(args.out, path, ".npz", many)
        plot = destination(args.plot, path, ".png", many, force_suffix=False) if args.plot else None
        if plot and not cv2.haveImageWriter(plot):
            raise ValueError(f"{plot}: OpenCV cannot write this kind of image; expected --plot "
                             "with an image ending such as .png or .jpg, or a folder")
        if out in seen:
            raise ValueError(f"{path} and {seen[out]} would both write {out}; expected inputs "
                             "with distinct names (or one --out per run)")
        seen[out] = path
        refuse_inputs([out], common.protected_inputs(args), "--out")
        if plot:
            refuse_inputs([plot], common.protected_inputs(args), "--plot")
            if not args.overwrite:
                refuse_foreign_plot(plot, out)
        mask_spec = getattr(args, "mask", None)  # (liff.batch.detect has no --mask)
        task = batch.Task(path, out, plot, options, args.preprocess, parameters, mask_spec)
        stale = [] if args.overwrite else changes(out, plot, settings(
            path, options, args.preprocess, parameters, mask_spec))
        if stale is None:
            kept.append(batch.Outcome(path, out, "kept", **batch.read_as(options)))
            continue
        if stale:
            redo[out] = stale
        tasks.append(task)
    return tasks, kept, redo


def run_tasks(tasks: List[batch.Task], args: argparse.Namespace,
              done: Optional[Callable[[batch.Outcome], None]] = None) -> List[batch.Outcome]:
    """Runs the tasks on the Dask cluster of ``--scheduler`` or on ``--workers`` local
    processes, with a progress bar; failures are reported as they come, and each
    outcome is handed to ``done`` as it comes (the manifest)."""
    def report(outcome: batch.Outcome) -> None:
        if outcome.error:
            bar.write(failure_line(outcome), file=sys.stderr)
        if done:
            done(outcome)
        common.finished(bar, None if outcome.error else outcome.input)

    if args.scheduler:
        with common.progress(desc="liff detect", total=len(tasks)) as bar:
            return batch.run(tasks, args.scheduler, progress=report,
                             notice=lambda text: bar.write(f"liff detect: {text}", file=sys.stderr))
    outcomes, _ = common.run_batch(batch.run_task, [(task,) for task in tasks], args.workers,
                                   "detect", label=lambda job: job[0].source, done=done,
                                   failed=lambda outcome: bool(outcome.error))
    outcomes = [o or batch.Outcome(t.source, t.output, "failed", error="reported above",
                                   **batch.read_as(t.reader_options))
                for t, o in zip(tasks, outcomes)]
    for outcome in outcomes:
        if outcome.error and outcome.error != "reported above":
            print(failure_line(outcome), file=sys.stderr)
    return outcomes


def failure_line(outcome: batch.Outcome) -> str:
    """``liff detect: <input>: <error>`` for a failed task, as other liff errors read
    (:func:`common.error_line`), without the type of a ValueError (the manifest keeps it)."""
    return common.error_line("detect", outcome.input, outcome.error.removeprefix("ValueError: "))


def wants_run_manifest(args: argparse.Namespace) -> bool:
    """Whether the run writes ``OUT/manifest-<UTC time>.csv`` without a ``--manifest``:
    a batch (several inputs, or --scheduler) into a folder ``--out``."""
    batch_run = is_batch(args) or args.scheduler
    # (called before the run, when a folder --out for several inputs may not exist yet)
    folder = args.out and (os.path.isdir(args.out) or args.out.endswith(os.sep) or is_batch(args))
    return not args.manifest and bool(batch_run and folder)


def is_batch(args: argparse.Namespace) -> bool:
    """Whether the inputs are a batch, written into folders with a manifest: several,
    or given as a list file, a pattern or a folder of light fields (even if it held one:
    its failure, too, has a manifest row), not as a light field itself."""
    def expanded(given: str) -> bool:
        if not os.path.exists(given):
            return glob.has_magic(given)  # a pattern (else a missing path, which fails)
        inside = os.path.join(os.path.abspath(given), "")
        return os.path.isdir(given) and any(os.path.abspath(p).startswith(inside)
                                            for p in args.paths)

    return len(args.paths) > 1 or bool(args.from_list) or any(map(expanded, args.given_paths))


@contextmanager
def manifest_writer(manifest: Optional[str], kept: List[batch.Outcome]):
    """A :class:`batch.ManifestWriter` for ``manifest`` starting with the ``kept``
    outcomes, or None without a manifest."""
    if not manifest:
        yield None
        return
    with batch.ManifestWriter(manifest, kept) as writer:
        yield writer


def check_manifest(manifest: str, args: argparse.Namespace, tasks: List[batch.Task],
                   kept: List[batch.Outcome]) -> None:
    """Raises ValueError, before anything runs, if the manifest would write over an
    input, over another output of the run, or over an existing file that is not a liff
    manifest (unless ``--overwrite``)."""
    refuse_inputs([manifest], common.protected_inputs(args), "--manifest")  # (and a FIFO)
    outputs = [t.output for t in tasks] + [t.plot for t in tasks if t.plot] + [k.output for k in kept]
    if any(os.path.exists(o) and os.path.exists(manifest) and os.path.samefile(o, manifest) or
           os.path.abspath(o) == os.path.abspath(manifest) for o in outputs):
        raise ValueError(f"{manifest}: is also an output of this run; expected a --manifest "
                         "path of its own; nothing was written")
    if os.path.exists(manifest) and not args.overwrite and not batch.is_manifest(manifest):
        raise ValueError(f"{manifest}: exists and is not a liff manifest; expected a new "
                         "--manifest path (or --overwrite to replace it); nothing was written")


def checked_plan(args: argparse.Namespace) -> tuple:
    """:func:`plan`, and every other check the run makes before it writes anything (the
    hloc files, ``--hloc-images``, the manifest): the run and ``--dry-run`` both call it,
    so a dry run refuses exactly what the run refuses.

    Raises
    ------
    ValueError
        As :func:`plan`, :func:`common.check_hloc_output`, :func:`liff.hloc.check_export`
        and :func:`check_manifest`.
    """
    tasks, kept, redo = plan(args, common.reader_options(args),
                             common.detector_parameters(args, given_only=True))
    common.check_hloc_output(args.hloc, common.protected_inputs(args), "--hloc", "features")
    if args.hloc_images and not args.hloc:
        raise ValueError("--hloc-images without --hloc; expected both (the features file and "
                         "its images)")
    if args.hloc_images:
        refuse_inputs([args.hloc_images], common.protected_inputs(args), "--hloc-images")
    if args.hloc:  # before any output is written
        from ..hloc import check_export

        check_export(args.hloc, [task.output for task in tasks] + [o.output for o in kept],
                     args.hloc_images, args.overwrite)
    if args.manifest:
        check_manifest(args.manifest, args, tasks, kept)
    return tasks, kept, redo


def dry_run(args: argparse.Namespace) -> int:
    """``--dry-run``: what would be read as what, and what the folders hold besides,
    after the run's own checks (:func:`checked_plan`)."""
    from .inputs import describe

    tasks, kept, _ = checked_plan(args)
    missing = [item for item in args.inputs if not os.path.lexists(item.path)]
    for item in args.inputs:
        print(f"{item.path}: no such file or folder; the run would fail it" if item in missing
              else describe(item))
    for entry in args.left_out:
        print(f"{entry.path}: {entry.why}")
    print(f"{len(args.inputs) - len(missing)} input(s) would be read"
          + (f", {len(missing)} missing" if missing else "")
          + f"; {len(args.left_out)} file(s) left out; nothing was read or written (--dry-run)")
    return 1 if missing else 0


def describe_slopes(outcome: batch.Outcome) -> str:
    """One line part: the slope range searched, its source and the slices it took."""
    if outcome.searched is None:
        return "slopes: -"
    return (f"slopes {outcome.first_slope:+.2f} to {outcome.last_slope:+.2f} "
            f"({outcome.slopes_from}), {outcome.searched} slices searched of {outcome.built} built")


def run(args: argparse.Namespace) -> int:
    if not args.paths and not args.from_list:
        args.parser.error("the following arguments are required: PATH (or --from-list FILE)")
    if args.scheduler is not None and not args.scheduler.strip():
        args.parser.error("--scheduler is empty; expected a Dask scheduler's address, e.g. "
                          "tcp://10.0.0.5:8786 (or no --scheduler for local processes)")
    common.make_detector(common.detector_parameters(args))  # bad parameters: before any reading
    mask.check_mask_option(getattr(args, "mask", None))
    if args.dry_run:
        return dry_run(args)
    tasks, kept, redo = checked_plan(args)
    manifest = args.manifest
    if not manifest and wants_run_manifest(args):  # a name of its own, taken now (after the checks)
        manifest = batch.new_manifest_name(args.out)
    for out, reasons in redo.items():
        print(f"redoing {out}, out of date: {'; '.join(reasons)}")
    with manifest_writer(manifest, kept) as writer:
        outcomes = run_tasks(tasks, args, writer.add if writer else None)
        if writer:
            writer.outcomes = outcomes + kept  # in the order of the inputs
    for task, outcome in zip(tasks, outcomes):
        if outcome.status == "done":
            print(f"{outcome.input}: {outcome.features} features -> {outcome.output}"
                  + (f", {task.plot}" if task.plot else "") + f"; {describe_slopes(outcome)}")
            for note in filter(None, outcome.notes.split("\n")):
                print(f"liff detect: {outcome.input}: warning: {note}", file=sys.stderr)
    if kept:
        print(f"skipped {len(kept)} input(s) whose outputs exist, made with the same settings "
              "(--overwrite to redo them)")
    failed = sum(outcome.status == "failed" for outcome in outcomes)
    if manifest:
        print(f"manifest: {manifest}")
    if args.hloc:
        from ..hloc import add_feature_files

        written = [o.output for o in outcomes + kept if o.status != "failed"]
        try:
            added = add_feature_files(args.hloc, written, args.hloc_images, args.overwrite)
        except ValueError as error:  # (only what detection decides: the rest was checked)
            if not tasks:
                raise
            raise ValueError(f"{error}; the feature files were written ("
                             f"{', '.join(o.output for o in outcomes if o.status == 'done')})"
                             ) from None
        print(f"hloc: {len(added.names)} light field(s) -> {args.hloc}"
              + (f", centre views -> {args.hloc_images}" if args.hloc_images else ""))
        if added.replaced:
            print(f"hloc: replaced the features of {', '.join(added.replaced)} with other ones: "
                  "matches of them made before are stale (liff match --hloc refuses to add to "
                  "those match files); match them again into a new file", file=sys.stderr)
        if added.replaced_images:
            print(f"hloc: replaced {', '.join(added.replaced_images)} (--overwrite): files "
                  f"--hloc-images held that were not centre views exported with {args.hloc} "
                  "(another features file's images, or your own)", file=sys.stderr)
    if failed:
        print(f"liff detect: {failed} of {len(tasks)} light field(s) failed", file=sys.stderr)
    return 1 if failed else 0
