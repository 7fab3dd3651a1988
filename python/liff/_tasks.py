"""A batch run's tasks: each input's outputs (where they go, whether one made before
with the same settings is kept), checked before anything is written (:func:`plan`), and
one task run where it is: read, detect, write (:func:`detect_one`). ``liff detect``
and :func:`liff.batch.detect` both plan and run their tasks here.

Layer: the batch runs' (tests/test_layers.py).
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import warnings
from dataclasses import dataclass
from typing import Dict, List, NamedTuple, Optional, Tuple

import cv2

from ._detection import load_mask, make_detector, read_input, slope_range
from ._detector import as_read_in_place
from ._flags import shown_options
from ._inputs import expand_args, input_identity, modified_after, protected_inputs
from ._version import __version__
from ._warnings import LiffWarning
from .feature_file import Features, centre_view, content_problem, keypoints_in_centre_view, read_meta, save_features
from .io.images import IMAGE_SUFFIXES, write_image
from .outputs import atomic_output, refuse_inputs
from .plot import draw_keypoints_by_slope


class Task(NamedTuple):
    """One light field to detect: the arguments of :func:`detect_one`."""

    source: str
    output: str
    plot: Optional[str]
    reader_options: dict
    preprocess: bool
    parameters: dict
    mask: Optional[str] = None  # liff detect --mask: an image, or "auto"


@dataclass
class Outcome:
    """One row of a run's manifest (:func:`write_manifest`).

    ``status`` is "done", "failed" or "kept" (an output made with the same settings
    was there); ``first_slope``/``last_slope`` the slopes of the first and last slice
    searched, ``searched``/``built`` the focal slices searched and built, and
    ``slopes_from`` where the range came from ("automatic", "given", a reader's
    "parameters.cfg", or, where the ends differ, two joined by " + ": "given +
    automatic"); ``seconds`` the task's time on its worker (reading, detecting,
    writing) and ``cpu_seconds`` the processor time it took (all of LiFF's threads);
    ``notes`` the warnings about the input, one per line."""

    input: str
    output: str
    status: str
    features: Optional[int] = None
    first_slope: Optional[float] = None
    last_slope: Optional[float] = None
    searched: Optional[int] = None
    built: Optional[int] = None
    slopes_from: str = ""
    seconds: Optional[float] = None
    cpu_seconds: Optional[float] = None
    error: str = ""
    worker: str = ""
    notes: str = ""
    format: str = ""
    reader_options: str = ""


def read_as(options: dict) -> dict:
    """The manifest's ``format`` and ``reader_options`` (as the command line writes
    them: ``--lenslet 14``) of an input read with ``options``."""
    return {"format": options.get("format") or "", "reader_options": shown_options(options)}


FILE_ENDINGS = IMAGE_SUFFIXES + (".npz", ".npy", ".db")


def output_name(path: str, suffix: str) -> str:
    """``scene.png`` -> ``scene<suffix>``; a folder ``a/scene/`` -> ``scene<suffix>``."""
    base = os.path.basename(os.path.normpath(path))
    stem = base if os.path.isdir(path) else os.path.splitext(base)[0]
    if stem.endswith(".eslf"):  # scene.eslf.png -> scene
        stem = stem[:-len(".eslf")]
    return (stem or "light_field") + suffix


def json_like(value):
    """``value`` as it reads back from JSON (tuples become lists), for comparing
    settings with those recorded in a file."""
    return json.loads(json.dumps(value))


def check_output_folder(given: Optional[str], suffix: str, inputs: int, option: str) -> None:
    """Several inputs write into a folder: refuses ``--out x.npz`` (a file's name, which
    would become a folder) and an existing file, before anything is created."""
    if inputs <= 1 or not given or os.path.isdir(given):
        return
    if os.path.exists(given):
        raise ValueError(f"{given}: exists and is not a folder; expected a folder for "
                         f"{option} with {inputs} inputs")
    if given.lower().endswith((suffix,) + FILE_ENDINGS):
        raise ValueError(f"{given}: a file name for {inputs} inputs; expected a folder for "
                         f"{option} (a name without a file ending, or ending with '/'); "
                         "nothing was written")


def destination(given, path: str, suffix: str, many: bool, force_suffix: bool = True) -> str:
    """Where the output for ``path`` goes: ``given`` itself for one input (unless it is
    a folder, or ends with a path separator), else ``given``/<name><suffix>.

    ``force_suffix``: a single ``given`` without ``suffix`` gets it appended (numpy's
    savez does that anyway; say, and check, the real file name); False keeps ``given``
    as it is (an image, whose ending chooses the format)."""
    if given is None:
        return output_name(path, suffix)
    if many or os.path.isdir(given) or given.endswith(tuple(filter(None, (os.sep, os.altsep)))):
        return os.path.join(given, output_name(path, suffix))
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
    identity = input_identity(path)  # before reading: a change meanwhile is redone
    # the warnings about the input, reading (missing views, lenslet size) and detecting,
    # are its notes: the manifest's, and one line each on stderr
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LiffWarning)
        light_field, metadata = read_input(path, options, preprocess)
        # A copy detection would make (Fortran order) is made now, so that it counts.
        light_field = as_read_in_place(light_field)
        resolved, slopes_from = slope_range(parameters, metadata)
        detector = make_detector(resolved)
        keypoints, descriptors = detector.detectAndCompute(
            light_field, load_mask(mask_spec, light_field, path))
    notes = tuple(str(w.message) for w in caught if issubclass(w.category, LiffWarning))
    searched, built = detector.getSearchedSlopes(), detector.getSlicesUsed()
    searched_range = (searched[0], searched[-1]) if searched else (float("nan"), float("nan"))
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
    return Detected(len(keypoints), searched_range, len(searched), len(built), slopes_from, notes)


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
    new = json_like(wanted)
    new.update({f"parameters.{k}": v for k, v in new["parameters"].items()})
    if "reader_options" in old:  # as the command line writes them: --lenslet 14
        old["reader_options"] = shown_options(old["reader_options"] or {}) or None
        new["reader_options"] = shown_options(new["reader_options"]) or None

    def shown(value):
        return "not given" if value is None else value

    differ = [f"{key.replace('parameters.', '').replace('_', ' ')} {shown(old.get(key))} -> "
              f"{shown(value)}"
              for key, value in new.items() if key != "parameters" and old.get(key) != value]
    if "input_identity" in made:  # size and time, compared for equality
        changed = made["input_identity"] != input_identity(wanted["source"])
    else:  # (a feature file made before liff recorded it)
        changed = modified_after(wanted["source"], out)
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
    expand_args(args, options, args.from_list)
    if not args.paths:
        raise ValueError("no input; expected light fields as PATH arguments or --from-list")
    many = is_batch(args)
    count = max(len(args.paths), 2 if many else 1)  # (a batch writes into folders)
    check_output_folder(args.out, ".npz", count, "--out")
    if args.plot:
        check_output_folder(args.plot, ".png", count, "--plot")
    tasks: List[Task] = []
    kept: List[Outcome] = []
    redo: Dict[str, List[str]] = {}
    seen: Dict[str, str] = {}
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
        refuse_inputs([out], protected_inputs(args), "--out")
        if plot:
            refuse_inputs([plot], protected_inputs(args), "--plot")
            if not args.overwrite:
                refuse_foreign_plot(plot, out)
        mask_spec = getattr(args, "mask", None)  # (liff.batch.detect has no --mask)
        task = Task(path, out, plot, options, args.preprocess, parameters, mask_spec)
        stale = [] if args.overwrite else changes(out, plot, settings(
            path, options, args.preprocess, parameters, mask_spec))
        if stale is None:
            kept.append(Outcome(path, out, "kept", **read_as(options)))
            continue
        if stale:
            redo[out] = stale
        tasks.append(task)
    return tasks, kept, redo


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
