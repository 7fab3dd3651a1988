"""``liff detect PATH... --out feats.npz --plot feats.png``: LiFF features of light fields."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Callable, List, Optional

from .. import batch
from .._inputs import describe

# Named here as before they moved to the batch runs' layer (liff._tasks, liff.batch).
from .._tasks import Detected, changes, destination, detect_one, is_batch, plan, refuse_foreign_plot, settings  # noqa: F401
from ..batch import check_manifest, manifest_writer
from ..outputs import refuse_inputs
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
        common.finished(bar, outcome.input, failed=bool(outcome.error))

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
        # lazy: defers pycolmap (optional: liff[sfm]) and SciPy (liff.hloc imports liff.colmap)
        from ..hloc import check_export

        check_export(args.hloc, [task.output for task in tasks] + [o.output for o in kept],
                     args.hloc_images, args.overwrite)
    if args.manifest:
        check_manifest(args.manifest, args, tasks, kept)
    return tasks, kept, redo


def dry_run(args: argparse.Namespace) -> int:
    """``--dry-run``: what would be read as what, and what the folders hold besides,
    after the run's own checks (:func:`checked_plan`)."""
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
        # lazy: defers pycolmap (optional: liff[sfm]) and SciPy (liff.hloc imports liff.colmap)
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
