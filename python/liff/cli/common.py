"""What the subcommands share: detector and reader options, input loading, batches."""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import _budget
from .._budget import held_bytes  # noqa: F401 (liff.cli.common.held_bytes)
from .._detector import PARAMETERS, LiFF
from .._processes import stop_now
from .progress import progress, step  # noqa: F401 (liff.cli.common.progress, .step)
from ..io.images import IMAGE_SUFFIXES

FILE_ENDINGS = IMAGE_SUFFIXES + (".npz", ".npy", ".db")


def add_reader_options(parser: argparse.ArgumentParser) -> None:
    """``--format``, one flag per reader option and ``--preprocess``, from the format
    registry (liff.io.formats: choices, help and the formats each option applies to)."""
    from ..io.formats import FORMATS, OPTIONS, flag_help, format_help

    group = parser.add_argument_group("reading light fields (docs/INPUTS.md)")
    group.add_argument("--format", default=None, choices=list(FORMATS), metavar="FORMAT",
                       help=format_help())
    for option in OPTIONS.values():
        group.add_argument(option.flag, dest=reader_dest(option.flag), type=option.type,
                           nargs=option.nargs, metavar=option.metavar, default=None,
                           help=flag_help(option))
    group.add_argument("--preprocess", action="store_true", help=PREPROCESS_HELP)


#: what liff.preprocess.prepare does, as the README says it (tests/test_input_registry.py)
PREPROCESSING = "luminance, gamma 0.5, one histogram stretch over the whole light field"
#: --preprocess's help
PREPROCESS_HELP = f"the paper's SfM preprocessing: {PREPROCESSING} (off unless asked for)"


def reader_dest(flag: str) -> str:
    """The attribute argparse keeps a flag's value in: ``--keep-views`` -> ``keep_views``."""
    return flag[2:].replace("-", "_")


def reader_options(args: argparse.Namespace) -> dict:
    """Keyword arguments for liff.io.read_light_field from the parsed options (those
    given: the format and each reader option of the registry)."""
    from ..io.formats import OPTIONS

    options = {"format": args.format} if getattr(args, "format", None) else {}
    for option in OPTIONS.values():
        given = getattr(args, reader_dest(option.flag), None)
        if given is not None:
            options[option.keyword] = option.value(given)
    return options


def option_name(parameter: str) -> str:
    """The command-line flag of a create() keyword: ``contrastThreshold`` ->
    ``--contrast-threshold``, ``nOctaveLayers`` -> ``--n-octave-layers``."""
    return "--" + re.sub(r"(?<!^)(?=[A-Z])", "-", parameter).lower()


def add_detector_options(parser: argparse.ArgumentParser) -> None:
    """One option per detector parameter, from liff.PARAMETERS (defaults and help
    included), so the command line always offers what create() takes."""
    group = parser.add_argument_group("detector (liff.LiFF.create parameters)")
    for p in PARAMETERS:
        text = f"{p.help} (default {p.default})"
        if p.type is bool:
            group.add_argument(option_name(p.name), dest=p.name, default=p.default,
                               action=argparse.BooleanOptionalAction, help=p.help)
        elif p.name in SLOPE_BOUNDS:  # None: not given (liff detect may use a reader's range)
            group.add_argument(option_name(p.name), dest=p.name, type=slope_bound, default=None,
                               metavar="FLOAT", help=(text + "; automatic at this end: "
                               f"{option_name(p.name)}={'-' if p.name == 'firstSlope' else ''}inf"
                               ).replace("%", "%%"))
        else:
            group.add_argument(option_name(p.name), dest=p.name, type=p.type, default=p.default,
                               metavar=p.type.__name__.upper(), help=text.replace("%", "%%"))


#: The slope range's create() keywords: on the command line, not giving one differs
#: from giving its default (liff detect then takes a reader's range, docs/SLOPES.md).
SLOPE_BOUNDS = ("firstSlope", "lastSlope")


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1 (view counts, sizes, workers)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}; expected a whole number >= 1")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (thresholds in pixels, ratios)."""
    return _finite(text, above=0.0)


def ratio(text: str) -> float:
    """argparse type: a ratio test's threshold, in (0, 1]."""
    value = _finite(text, above=0.0)
    if value > 1:
        raise argparse.ArgumentTypeError(f"{text!r}; expected a number in (0, 1]")
    return value


def nonnegative_float(text: str) -> float:
    """argparse type: a finite number >= 0 (noise variances)."""
    return _finite(text, at_least=0.0)


def _number(text: str) -> float:
    """``text`` as a float, NaN if it is not a number."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def _finite(text: str, above: float = -math.inf, at_least: float = -math.inf) -> float:
    value = _number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r}; expected a finite number")
    if not (value > above and value >= at_least):
        bound = f"> {above:g}" if value <= above else f">= {at_least:g}"
        raise argparse.ArgumentTypeError(f"{text!r}; expected a number {bound}")
    return value


def slope_bound(text: str) -> float:
    """argparse type of --first-slope / --last-slope: a number, or -inf / inf."""
    value = _number(text)
    if math.isnan(value):
        raise argparse.ArgumentTypeError(f"{text!r}; expected a number, or -inf / inf for the "
                                         "automatic range")
    return value


def keyword_flags() -> Dict[str, str]:
    """Python keyword -> command-line flag for the reader options (from the format
    registry, ``keep`` -> ``--keep-views``) and detector parameters
    (``contrastThreshold`` -> ``--contrast-threshold``)."""
    from ..io.formats import OPTIONS

    flags = {p.name: option_name(p.name) for p in PARAMETERS}
    flags.update({o.keyword: o.flag for o in OPTIONS.values()})
    return flags


def name_flags(message: str) -> str:
    """``message`` with the readers' and the detector's Python keywords named as the
    command line's flags: "keep = 20" -> "--keep-views = 20", "(n=N)" -> "(--lenslet N)",
    "format='mosaic'" -> "--format mosaic",
    "option(s) key do not apply ...; expected n, keep" -> "option(s) --key ...; expected
    --lenslet, --keep-views"."""
    from ..io.formats import OPTIONS

    flags = keyword_flags()

    def in_list(match: re.Match) -> str:
        return re.sub(r"(?<![\w-])\w+", lambda word: OPTIONS[word.group(0)].flag
                      if word.group(0) in OPTIONS else word.group(0), match.group(0))

    # format='mosaic' (the Python keyword): --format mosaic, once where both are named
    message = re.sub(r"format='(\w+)', --format \1\b", r"--format \1", message)
    message = re.sub(r"(?<![\w.-])format='(\w+)'", r"--format \1", message)
    if " do not apply to format " in message:  # liff.io.read_light_field's option check
        message = re.sub(r"(?<=option\(s\) ).*", in_list, message, flags=re.S)
    for option in OPTIONS.values():  # "n=N" as the command line writes it: "--lenslet N"
        message = re.sub(rf"(?<![\w.-]){option.keyword}=(?=\S)", option.flag + " ", message)
    for keyword, flag in flags.items():
        camel = keyword != keyword.lower()  # detector parameters: unique words, named anywhere
        pattern = rf"(?<![\w.-]){keyword}\b" + ("" if camel else r"(?= ?=| \(| \d)")
        message = re.sub(pattern, flag, message)
    return message


def detector_parameters(args: argparse.Namespace, given_only: bool = False) -> dict:
    """Every create() keyword with its value from the parsed options; a slope bound not
    given is its default, or None with ``given_only`` (for :func:`slope_range`)."""
    values = {p.name: getattr(args, p.name) for p in PARAMETERS}
    return values if given_only else with_defaults(values)


def with_defaults(parameters: dict) -> dict:
    """``parameters`` with each one not given (None) at its create() default."""
    defaults = {p.name: p.default for p in PARAMETERS}
    return {name: defaults[name] if value is None else value for name, value in parameters.items()}


def slope_range(parameters: dict, metadata: dict) -> Tuple[dict, str]:
    """The create() keywords to use, and where the slope range comes from, for
    ``parameters`` whose slope bounds are None where the user gave none.

    Each bound the user gave is kept (-inf / inf: automatic at that end); each one not
    given comes from the range a reader knows (an HCI scene's parameters.cfg disp_min
    and disp_max) if it has one and it does not cross the bound given, else is
    automatic. The source says which: "given" (finite bounds given), "parameters.cfg",
    "automatic", or two of them joined by " + " (given first)."""
    lo, hi = metadata.get("disp_min"), metadata.get("disp_max")
    hint = ({"firstSlope": float(lo), "lastSlope": float(hi)}
            if lo is not None and hi is not None and lo < hi else {})
    given = {name: parameters[name] for name in SLOPE_BOUNDS if parameters.get(name) is not None}
    if len(given) == 1 and hint:  # the reader's other end only where it keeps the order
        (name, value), = given.items()
        other = "lastSlope" if name == "firstSlope" else "firstSlope"
        if (hint[other] > value) != (other == "lastSlope"):
            hint = {}
    resolved, sources = dict(parameters, **hint), []
    for name in SLOPE_BOUNDS:
        if name in given:
            resolved[name] = given[name]
            sources.append("given" if math.isfinite(given[name]) else "automatic")
        else:
            sources.append("parameters.cfg" if name in hint else "automatic")
    order = ["given", "parameters.cfg", "automatic"]
    return with_defaults(resolved), " + ".join(sorted(set(sources), key=order.index))


def make_detector(parameters: dict) -> LiFF:
    """A detector with ``parameters``; under a ``liff._budget.memory_budget_bytes``, its memory
    limit (setMemoryLimitMB) is what the budget leaves of what the process holds now,
    so a light field read before the detector is made counts against the budget."""
    detector = LiFF.create(**parameters)
    budget = _budget.memory_budget_bytes
    if budget is not None:
        held = held_bytes()
        if held >= budget:
            raise MemoryError(f"the process holds {held / 1e6:.0f} MB with the light field "
                              f"read, all of its memory budget of {budget / 1e6:.0f} "
                              "MB, leaving LiFF none; expected more memory for the task")
        detector.setMemoryLimitMB(max(1, int((budget - held) / 2**20)))
    return detector


def read_input(path: str, options: dict, preprocess: bool) -> Tuple[np.ndarray, dict]:
    """Reads a light field (any liff.io format), optionally preprocessed, and the
    reader's metadata (e.g. an HCI scene's disparity range and camera). A lenslet image
    read with ``--lenslet`` must hold 8 lenslets a side
    (:func:`liff.io.eslf.check_given_lenslets`)."""
    from .. import io

    from ..io.eslf import check_given_lenslets

    read = io.read_light_field(path, **options)
    check_given_lenslets(read)  # --lenslet: at least 8 lenslets a side
    light_field = read.light_field
    if preprocess:
        from ..preprocess import prepare

        light_field = prepare(light_field)
    return light_field, read.metadata


def load_light_field(path: str, options: dict, preprocess: bool) -> np.ndarray:
    """Reads a light field (any liff.io format) and optionally preprocesses it."""
    return read_input(path, options, preprocess)[0]


def expand_inputs(paths: Sequence[str], options: dict, from_list: Optional[str] = None,
                  features: bool = False) -> List[str]:
    """The light fields that PATH arguments name: each is a light field, a folder of
    light fields (each entry recognised by its names and content: liff.io.layout) or a
    glob pattern (quoted, so the shell left it); ``from_list`` is a text file of more,
    one a line, each perhaps with reader options of its own (liff.cli.inputs). Repeats
    are dropped.

    Raises
    ------
    ValueError
        Naming the pattern, folder or list file that gave no light field.
    """
    from .inputs import expand

    return [item.path for item in expand(paths, options, from_list, features)[0]]


def input_options(paths: Sequence[str], args: argparse.Namespace) -> List[dict]:
    """The reader options each of ``paths`` (light fields given by themselves: ``liff
    pose A B``, ``liff match A B``) is read with: its format as liff.io.layout tells it,
    and the command line's options that format takes, resolved over all of them as for
    a batch (ValueError naming a flag that no input takes, or a folder holding more than
    one light field)."""
    from .inputs import expand

    inputs = expand(paths, reader_options(args), features=True)[0]
    found = {os.path.realpath(item.path): item.options for item in inputs}
    for path in paths:
        if os.path.realpath(path) not in found:
            raise ValueError(f"{path}: a folder of {len(inputs)} light fields or more; expected "
                             "one light field (a file, or a folder of views)")
    return [found[os.path.realpath(path)] for path in paths]


def shown_options(options: dict) -> str:
    """Reader options as the command line writes them: ``--lenslet 14 --keep-views 11``
    (the format left out)."""
    from ..io.formats import OPTIONS

    return " ".join(OPTIONS[k].shown(v) for k, v in options.items() if k in OPTIONS)


def glob_paths(pattern: str) -> List[str]:
    """The paths a glob pattern given as an input matches (:mod:`liff.cli.inputs`).

    ``glob.glob(pattern, recursive=True)``, sorted, except that ``**`` does not descend
    into symbolic links to folders (glob's does, and a link back up makes it loop, for
    ever with two such links): ``**`` goes through pathlib, which does not follow them.
    As with glob, hidden names match only a pattern with a part starting with '.'."""
    import glob
    from pathlib import Path

    parts = Path(pattern).parts
    if "**" not in parts:  # (** inside a name is *, for glob as for pathlib)
        return sorted(glob.glob(pattern))
    first = next(i for i, part in enumerate(parts) if glob.has_magic(part))
    base, rest = Path(*parts[:first]) if first else Path("."), parts[first:]
    hidden_asked = any(part.startswith(".") for part in rest)
    return sorted(str(match) for match in base.glob(str(Path(*rest)))
                  if hidden_asked or not any(name.startswith(".")
                                             for name in match.relative_to(base).parts))


def expand_args(args: argparse.Namespace, options: dict, from_list: Optional[str] = None,
                features: bool = False) -> None:
    """``args.paths`` expanded (:func:`expand_inputs`), ``args.inputs`` the inputs with
    their format and reader options (liff.cli.inputs.Input), ``args.left_out`` what the
    folders held that is not an input; the paths as given stay in ``args.given_paths``:
    a folder given is an input too, so nothing is written inside it (a later run over
    the folder would read the outputs as light fields)."""
    from .inputs import expand

    args.given_paths = list(args.paths)
    args.inputs, args.left_out = expand(args.paths, options, from_list, features)
    args.paths = [item.path for item in args.inputs]


def protected_inputs(args: argparse.Namespace) -> List[str]:
    """What no output may be or lie inside: the light fields and the paths as given."""
    return args.paths + getattr(args, "given_paths", [])


def check_hloc_output(path: Optional[str], inputs: Sequence[str], flag: str, kind: str) -> None:
    """Before anything runs: an hloc file ``path`` (if given) is none of ``inputs`` nor
    inside them, h5py is there, and a file already at ``path`` is an HDF5 file of that
    ``kind`` ("features" or "matches", :func:`liff.hloc.check_file_kind`; its other
    groups are kept).

    Raises
    ------
    ValueError
        For an input, a file that is not HDF5, or an hloc file of the other kind, at ``path``.
    ImportError
        Without h5py.
    """
    if path is None:
        return
    from ..outputs import refuse_inputs

    refuse_inputs([path], inputs, flag)
    try:
        import h5py
    except ImportError as error:
        raise ImportError(f"{flag} needs h5py, a dependency of liff that is not installed "
                          "here: pip install h5py") from error
    if os.path.exists(path) and not h5py.is_hdf5(path):
        raise ValueError(f"{path}: exists and is not an HDF5 file; expected a new {flag} path "
                         "or an hloc file to add to; nothing was written")
    from ..hloc import check_file_kind

    try:
        check_file_kind(path, kind)
    except ValueError as error:
        raise ValueError(f"{flag}: {error}; nothing was written") from None


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


def modified_after(source: str, output: str) -> bool:
    """Whether the input ``source`` (a file, or a folder's files) changed after
    ``output`` was written (for feature files that predate :func:`input_identity`)."""
    made = os.path.getmtime(output)
    if os.path.isdir(source):
        with os.scandir(source) as entries:
            return any(e.stat().st_mtime > made for e in entries)
    return os.path.exists(source) and os.path.getmtime(source) > made


def input_identity(source: str) -> Optional[str]:
    """The input's size and modification time (ns): of the file, or of every file in the
    folder but hidden ones (.DS_Store), with their names (a digest). An output records
    it, and a re-run redoes the output when it differs either way: a replaced input with
    an older time (``cp -p``, ``rsync -a``, ``mv``) is caught, as a newer one is. None if
    ``source`` is missing."""
    import hashlib

    try:
        if not os.path.isdir(source):
            stat = os.stat(source)
            return f"{stat.st_size}:{stat.st_mtime_ns}"
        with os.scandir(source) as entries:
            listing = sorted((e.name, e.stat().st_size, e.stat().st_mtime_ns)
                             for e in entries if e.is_file() and not e.name.startswith("."))
    except OSError:
        return None
    return "folder:" + hashlib.sha256(repr(listing).encode()).hexdigest()[:32]


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


def error_line(command: str, name: str, error: str) -> str:
    """``liff <command>: <name>: <error>``, naming the input once: readers' messages
    already start with its path."""
    text = name_flags(error)
    return f"liff {command}: " + (text if text.startswith(name) else f"{name}: {text}")


def run_batch(function: Callable, jobs: Sequence[tuple], workers: int, command: str,
              label: Callable[[tuple], str],
              done: Optional[Callable[[object], None]] = None,
              failed: Callable[[object], bool] = lambda result: False) -> Tuple[List, int]:
    """Runs ``function(*job)`` for every job, on ``workers`` processes (1 = here), with a
    progress bar on stderr (see :func:`progress`). A job that raises is reported as
    ``liff <command>: <label>: <error>`` and the rest go on; ``done(result)`` is called
    with each job's result as it comes (e.g. to write a manifest as the run goes).
    The progress names each job that finished (``label``), unless it raised or
    ``failed(result)``: its error line names it.

    Returns (results in job order, None for failures; number of failures).
    """
    results: List = [None] * len(jobs)
    failures = 0
    progress = _progress(len(jobs), command)

    def report(i: int, error: BaseException) -> None:
        nonlocal failures
        failures += 1
        message = error_line(command, label(jobs[i]), str(error))
        (progress.write(message, file=sys.stderr) if progress else print(message, file=sys.stderr))

    if workers <= 1 or len(jobs) <= 1:
        for i, job in enumerate(jobs):
            try:
                results[i] = function(*job)
                if done:
                    done(results[i])
                finished(progress, None if failed(results[i]) else label(jobs[i]))
            except (ValueError, OSError, MemoryError) as error:
                report(i, error)
                finished(progress, None)
    else:
        # Each worker gets its share of the cores: LiFF uses all of them by default, and
        # N processes that each did would oversubscribe the machine N times over.
        threads = max(1, (os.cpu_count() or 1) // workers)
        pool = ProcessPoolExecutor(max_workers=workers, initializer=_set_threads,
                                   initargs=(threads,))
        try:
            futures = {pool.submit(function, *job): i for i, job in enumerate(jobs)}
            for future in as_completed(futures):
                i = futures[future]
                try:
                    results[i] = future.result()
                    if done:
                        done(results[i])
                    finished(progress, None if failed(results[i]) else label(jobs[i]))
                except (ValueError, OSError, MemoryError) as error:
                    report(i, error)
                    finished(progress, None)
        except BaseException:  # Ctrl-C, SIGTERM: stop now, not after the queued jobs
            stop_now(pool)
            raise
        pool.shutdown()
    if progress:
        progress.close()
    return results, failures


def finished(bar, item: Optional[str]) -> None:
    """Counts an input done on the progress ``bar`` (None: no bar), naming ``item``: tqdm's
    postfix, the log line's ``last ITEM``; None for one that failed, which its error line
    names already."""
    if bar is not None:
        bar.set_postfix_str(item or "", refresh=False)
        bar.update()


def _set_threads(threads: int) -> None:
    """Worker initializer: LiFF's thread count for this process, and SIGTERM's default
    action (a forked worker inherits the CLI's handler, which would let it finish its
    light field before the pool could end it)."""
    import signal

    import liff

    signal.signal(signal.SIGTERM, signal.SIG_DFL)

    liff.setNumThreads(threads)


def _progress(total: int, command: str):
    """A bar for the jobs of a batch (even one: a large light field takes seconds)."""
    return progress(desc=f"liff {command}", total=total) if total else None
