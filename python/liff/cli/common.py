"""What the subcommands share: argparse options and types (the detector's parameters,
the readers' options), and the names the subcommands use from the layers below (the
inputs, their tasks and the local pool: liff._inputs, liff._tasks, liff._processes;
reading and making a detector: liff._detection; flags in messages: liff._flags)."""

from __future__ import annotations

import argparse
import math
import os
from typing import List, Optional, Sequence

import numpy as np

# Named here for the subcommands (common.X), and as liff.cli.common.X was before they moved.
from .._budget import held_bytes  # noqa: F401
from .._detection import SLOPE_BOUNDS, make_detector, read_input, slope_range, with_defaults  # noqa: F401
from .._detector import PARAMETERS
from .._flags import (  # noqa: F401
    PREPROCESS_HELP,
    PREPROCESSING,
    add_reader_options,
    error_line,
    keyword_flags,
    name_flags,
    option_name,
    reader_dest,
    reader_options,
    shown_options,
)
from .._inputs import expand_args, expand_inputs, input_identity, input_options, modified_after, protected_inputs  # noqa: F401
from .._processes import finished, run_batch  # noqa: F401
from .._progress import progress, step  # noqa: F401
from .._tasks import FILE_ENDINGS, check_output_folder, json_like, output_name  # noqa: F401
from ..outputs import refuse_inputs


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


def detector_parameters(args: argparse.Namespace, given_only: bool = False) -> dict:
    """Every create() keyword with its value from the parsed options; a slope bound not
    given is its default, or None with ``given_only`` (for :func:`slope_range`)."""
    values = {p.name: getattr(args, p.name) for p in PARAMETERS}
    return values if given_only else with_defaults(values)


def light_field_flags(args: argparse.Namespace) -> List[str]:
    """The flags given that apply to light fields only: the detector's whose value is not
    its default, and ``--preprocess``; named in the error when every input is a feature
    file (:func:`liff._inputs.resolve_options`)."""
    flags = [option_name(p.name) for p in PARAMETERS
             if getattr(args, p.name) != (None if p.name in SLOPE_BOUNDS else p.default)]
    return flags + (["--preprocess"] if getattr(args, "preprocess", False) else [])


def load_light_field(path: str, options: dict, preprocess: bool) -> np.ndarray:
    """Reads a light field (any liff.io format) and optionally preprocesses it."""
    return read_input(path, options, preprocess)[0]


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
    refuse_inputs([path], inputs, flag)
    try:
        import h5py
    except ImportError as error:
        raise ImportError(f"{flag} needs h5py, a dependency of liff that is not installed "
                          "here: pip install h5py") from error
    if os.path.exists(path) and not h5py.is_hdf5(path):
        raise ValueError(f"{path}: exists and is not an HDF5 file; expected a new {flag} path "
                         "or an hloc file to add to; nothing was written")
    # lazy: defers pycolmap (optional: liff[sfm]) and SciPy (liff.hloc imports liff.colmap)
    from ..hloc import check_file_kind

    try:
        check_file_kind(path, kind)
    except ValueError as error:
        raise ValueError(f"{flag}: {error}; nothing was written") from None


