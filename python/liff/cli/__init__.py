"""The ``liff`` console command: ``liff detect|match|pose|colmap|sfm|synth|demo``.

Every subcommand lives in its own module here and registers itself with
``add_parser(subparsers)``; errors about the user's files are reported as
``liff <command>: <file>: <what was wrong>`` with a non-zero exit status, and so is a
missing optional dependency (``liff sfm`` without pycolmap).
"""

from __future__ import annotations

import argparse
import sys
from typing import List, Optional

from .. import __version__, opencvVersion
from . import colmap, common, demo, detect, match, pose, synth

COMMANDS = (detect, match, pose, colmap, synth, demo)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="liff", description="Light field features in scale and depth (LiFF).",
        epilog="Axis order, slope sign and file formats: docs/CONVENTIONS.md, docs/INPUTS.md.")
    parser.add_argument("--version", action="version",
                        version=f"liff {__version__} (OpenCV {opencvVersion()})")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print(f"liff {args.command}: interrupted", file=sys.stderr)
        return 130
    except (ValueError, OSError, MemoryError, ImportError) as error:
        print(f"liff {args.command}: {common.name_flags(str(error))}", file=sys.stderr)
        return 1
