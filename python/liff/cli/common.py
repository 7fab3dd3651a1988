"""What the subcommands share: detector and reader options, input loading, batches."""

from __future__ import annotations

import argparse
import os
import re
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Callable, List, Sequence, Tuple

import numpy as np

from .._detector import PARAMETERS, LiFF


def add_reader_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("reading light fields (docs/INPUTS.md)")
    group.add_argument("--format", default=None,
                       help="hci, views, eslf, mosaic, npy, npz, mat or hdf5 (default: from the "
                            "path)")
    group.add_argument("--grid", type=int, nargs=2, metavar=("T", "S"), default=None,
                       help="view grid (mosaics; overrides what view names say)")
    group.add_argument("--lenslet", type=int, default=None, metavar="N",
                       help="lenslet size of an ESLF image (default: detected from the image; "
                            "14 in the Stanford Lytro archive, 15 from the Light Field Toolbox)")
    group.add_argument("--keep-views", type=int, default=None, metavar="K",
                       help="ESLF: keep the centre K x K views (e.g. 11 of a Lytro's 14)")
    group.add_argument("--pattern", default=None,
                       help="views: regex with named groups t and s (or index) for the file names")
    group.add_argument("--key", default=None,
                       help="npz, mat, hdf5: the array, variable or dataset holding the light field")
    group.add_argument("--bit-depth", type=int, default=None, metavar="B",
                       help="the values are B-bit (e.g. 10 or 12 for sensor data in 16-bit files, "
                            "8 for floats in 0..255): rescale them to the dtype's range")
    group.add_argument("--preprocess", action="store_true",
                       help="the paper's SfM preprocessing: luminance, gamma 0.5, "
                            "histogram equalisation")


def reader_options(args: argparse.Namespace) -> dict:
    """Keyword arguments for liff.io.read_light_field from the parsed options."""
    options = {}
    if args.format:
        options["format"] = args.format
    if args.grid:
        options["grid"] = tuple(args.grid)
    if args.lenslet:
        options["n"] = args.lenslet
    if args.keep_views:
        options["keep"] = args.keep_views
    if args.pattern:
        options["pattern"] = args.pattern
    if args.key:
        options["key"] = args.key
    if args.bit_depth is not None:
        options["bit_depth"] = args.bit_depth
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
        else:
            group.add_argument(option_name(p.name), dest=p.name, type=p.type, default=p.default,
                               metavar=p.type.__name__.upper(), help=text.replace("%", "%%"))


def detector_parameters(args: argparse.Namespace) -> dict:
    """Every create() keyword with its value from the parsed options."""
    return {p.name: getattr(args, p.name) for p in PARAMETERS}


def make_detector(parameters: dict) -> LiFF:
    return LiFF.create(**parameters)


def load_light_field(path: str, options: dict, preprocess: bool) -> np.ndarray:
    """Reads a light field (any liff.io format) and optionally preprocesses it."""
    from .. import io

    light_field = io.read_light_field(path, **options).light_field
    if preprocess:
        from ..preprocess import prepare

        light_field = prepare(light_field)
    return light_field


def output_name(path: str, suffix: str) -> str:
    """``scene.png`` -> ``scene<suffix>``; a folder ``a/scene/`` -> ``scene<suffix>``."""
    base = os.path.basename(os.path.normpath(path))
    stem = base if os.path.isdir(path) else os.path.splitext(base)[0]
    if stem.endswith(".eslf"):  # scene.eslf.png -> scene
        stem = stem[:-len(".eslf")]
    return (stem or "light_field") + suffix


def run_batch(function: Callable, jobs: Sequence[tuple], workers: int, command: str,
              label: Callable[[tuple], str]) -> Tuple[List, int]:
    """Runs ``function(*job)`` for every job, on ``workers`` processes (1 = here), with a
    progress bar on stderr for more than one job. A job that raises is reported as
    ``liff <command>: <label>: <error>`` and the rest go on.

    Returns (results in job order, None for failures; number of failures).
    """
    results: List = [None] * len(jobs)
    failures = 0
    progress = _progress(len(jobs), command)

    def report(i: int, error: BaseException) -> None:
        nonlocal failures
        failures += 1
        name, text = label(jobs[i]), str(error)
        # readers' messages already start with the path
        message = f"liff {command}: " + (text if text.startswith(name) else f"{name}: {text}")
        (progress.write(message, file=sys.stderr) if progress else print(message, file=sys.stderr))

    if workers <= 1 or len(jobs) <= 1:
        for i, job in enumerate(jobs):
            try:
                results[i] = function(*job)
            except (ValueError, OSError, MemoryError) as error:
                report(i, error)
            if progress:
                progress.update()
    else:
        # Each worker gets its share of the cores: LiFF uses all of them by default, and
        # N processes that each did would oversubscribe the machine N times over.
        threads = max(1, (os.cpu_count() or 1) // workers)
        with ProcessPoolExecutor(max_workers=workers, initializer=_set_threads,
                                 initargs=(threads,)) as pool:
            futures = {pool.submit(function, *job): i for i, job in enumerate(jobs)}
            for future in as_completed(futures):
                i = futures[future]
                try:
                    results[i] = future.result()
                except (ValueError, OSError, MemoryError) as error:
                    report(i, error)
                if progress:
                    progress.update()
    if progress:
        progress.close()
    return results, failures


def _set_threads(threads: int) -> None:
    """Worker initializer: LiFF's thread count for this process."""
    import liff

    liff.setNumThreads(threads)


def _progress(total: int, command: str):
    """A tqdm bar for batches (None for a single job or when stderr is not a terminal
    and LIFF_PROGRESS is unset)."""
    if total <= 1:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=f"liff {command}", unit="file", file=sys.stderr,
                disable=None if "LIFF_PROGRESS" not in os.environ else False)
