"""The ``liff`` console command: ``liff detect|match|pose|colmap|sfm|synth|demo``.

Every subcommand lives in its own module here and registers itself with
``add_parser(subparsers)``; errors about the user's files are reported as
``liff <command>: <file>: <what was wrong>`` with a non-zero exit status, and so is a
missing optional dependency (``liff sfm`` without pycolmap).
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
import warnings
from typing import List, Optional

from .. import _progress as progress  # (liff.cli.progress: --quiet sets progress.QUIET)
from .._core import opencvVersion
from .._version import __version__
from .._warnings import LiffWarning
from . import colmap, common, demo, detect, match, pose, synth

COMMANDS = (detect, match, pose, colmap, synth, demo)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="liff", description="Light field features in scale and depth (LiFF).",
        epilog="Axis order, slope sign and file formats: docs/CONVENTIONS.md, docs/INPUTS.md.")
    import cv2  # two OpenCVs in one process: liff's core and pip's cv2 (README, "What does not cross over")

    parser.add_argument("--version", action="version",
                        version=f"liff {__version__} (core on OpenCV {opencvVersion()}; "
                                f"cv2 {cv2.__version__})")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub)
    for subparser in sub.choices.values():
        subparser.add_argument("--quiet", action="store_true",
                               help="print no progress or step lines on stderr (errors and "
                                    "warnings still show)")
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM (kill, timeout, a batch system's cancel), raised where the command is, as
    Ctrl-C is: cleanups run (a Dask run restores its workers' profiler) and partial
    outputs are left only under hidden temporary names."""


def _terminate(signum, frame):
    raise Terminated


def _warning_line(command: str):
    """A ``warnings.showwarning`` printing one line, ``liff COMMAND: warning: MESSAGE``
    with the flags named (not Python's ``file:line: Category: message`` and the source
    line); a warning that is not liff's keeps its category's name."""
    def show(message, category, filename, lineno, file=None, line=None):
        kind = "" if issubclass(category, LiffWarning) else f"{category.__name__}: "
        print(f"liff {command}: warning: {kind}{common.name_flags(str(message))}",
              file=file or sys.stderr, flush=True)
    return show


def main(argv: Optional[List[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    progress.QUIET = args.quiet
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main_thread else None
    try:
        with warnings.catch_warnings() if in_main_thread else contextlib.nullcontext():
            if in_main_thread:  # (the warnings module's state is the process's)
                warnings.showwarning = _warning_line(args.command)
                warnings.simplefilter("always", LiffWarning)  # each input's, not the first only
            return int(args.run(args) or 0)
    except Terminated:
        print(f"liff {args.command}: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        print(f"liff {args.command}: interrupted", file=sys.stderr)
        return 130
    except (ValueError, OSError, MemoryError, ImportError) as error:
        print(f"liff {args.command}: {common.name_flags(str(error))}", file=sys.stderr)
        return 1
    finally:
        progress.QUIET = False
        if in_main_thread:  # (None: a handler not set from Python; the default stands for it)
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
