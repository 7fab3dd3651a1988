"""The inputs of a command: PATH arguments, folders, quoted globs and list files,
expanded into light fields (:mod:`liff.io.layout`), each with the format and the reader
options it is read with.

Reader options given on the command line apply to the inputs whose format takes them
(``--lenslet`` to lenslet images, ``--key`` to npz, mat and hdf5 files): an option no
input takes is an error naming it. A list file (``--from-list``) may give options of
its own on a line, after the path (``lytro/IMG_1.png --lenslet 14 --keep-views 11``);
they apply to that line's inputs, over the command line's, and must fit their format.
"""

from __future__ import annotations

import argparse
import glob
import os
import shlex
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

from ..io.formats import FORMATS, OPTIONS, formats_taking
from ..io.layout import Entry, expand as expand_path, expand_match
from ..io.views import compile_pattern
from .._paths import refuse_special
from . import common


@dataclass
class Input:
    """A light field to read.

    Attributes
    ----------
    path : str
    format : str or None
        The format it is read as (None: told by the reader, or a feature file).
    options : dict
        ``liff.io.read_light_field`` keywords, ``format`` included when known.
    why : str
        How it was recognised (``liff detect --dry-run`` shows it).
    listed : dict
        The options its list file's line gave.
    """

    path: str
    format: Optional[str]
    options: dict = field(default_factory=dict)
    why: str = ""
    listed: dict = field(default_factory=dict)


def list_line_parser() -> argparse.ArgumentParser:
    """The options a line of a list file may give: ``--format`` and the reader options."""
    parser = argparse.ArgumentParser(prog="--from-list line", add_help=False,
                                     exit_on_error=False)
    common.add_reader_options(parser)
    return parser


def read_list(path: str) -> List[Tuple[str, dict]]:
    """(path, options) of each line of a list file: every line is split as a shell
    would (quotes, ``#`` comments), into a path and reader options; blank and comment
    lines are skipped. Quote a path with spaces, quotes, ``#`` or `` --`` in it.

    Raises
    ------
    ValueError
        Naming the file (and line): unreadable, more than one path on a line, or
        options that do not parse.
    """
    refuse_special(path, "a text file of light field paths, one a line")
    try:
        with open(path, encoding="utf-8") as f:
            lines = [line.strip() for line in f]
    except (OSError, UnicodeDecodeError) as error:
        reason = getattr(error, "strerror", None) or "not UTF-8 text"
        raise ValueError(f"{path}: cannot read the list ({reason}); expected a text file of "
                         "light field paths, one a line") from None
    parser, listed = list_line_parser(), []
    expected = "expected a path (quoted if it holds spaces), then reader options such as --lenslet 14"
    for number, line in enumerate(lines, 1):
        try:
            words = shlex.split(line, comments=True)
            if not words:
                continue
            parsed, unknown = parser.parse_known_args(words[1:])
        except (ValueError, argparse.ArgumentError) as error:
            raise ValueError(f"{path}, line {number}: {error}; {expected}") from None
        if unknown and not any(word.startswith("-") for word in unknown):
            raise ValueError(f"{path}, line {number}: {shlex.join([words[0]] + unknown)} are "
                             f"{len(unknown) + 1} words; {expected}")
        if unknown:
            raise ValueError(f"{path}, line {number}: {' '.join(unknown)} is not a reader option; "
                             f"expected {', '.join(['--format'] + [o.flag for o in OPTIONS.values()])}")
        listed.append((words[0], common.reader_options(parsed)))
    return listed


def expand(paths: Sequence[str], options: dict, from_list: Optional[str] = None,
           features: bool = False) -> Tuple[List[Input], List[Entry]]:
    """(the inputs, the entries of folders left out) that PATH arguments and the list
    file ``from_list`` name; ``options`` are the command line's reader options (as
    :func:`common.reader_options` gives them). Repeats are dropped. ``features``: liff
    feature files are inputs too.

    Raises
    ------
    ValueError
        Naming the pattern, folder or list file that gave no light field, a ``--pattern``
        that is not a views pattern or matches no file of a folder of views, a list line's
        option that does not fit its input's format, or a command-line option that fits
        no input's format.
    """
    given = [(path, {}) for path in paths] + (read_list(from_list) if from_list else [])
    compile_pattern(options.get("pattern"), None, "--pattern")
    for _, listed in given:
        compile_pattern(listed.get("pattern"), from_list, "--pattern")
    inputs: List[Input] = []
    left_out: List[Entry] = []
    for path, listed in given:
        fmt = listed.get("format", options.get("format"))
        pattern = listed.get("pattern", options.get("pattern"))
        globbed = not os.path.exists(path) and glob.has_magic(path)
        if globbed:
            matches = common.glob_paths(path)
            if not matches:
                raise ValueError(f"{path}: no file matches the pattern; expected light fields")
        else:
            matches = [path]
        found, folders = 0, {}
        for match in matches:
            taken, skipped = (expand_match(match, fmt, pattern, features, folders) if globbed
                              else expand_path(match, fmt, pattern, features))
            inputs += [Input(e.path, e.format, why=e.why, listed=listed) for e in taken]
            left_out += skipped
            found += len(taken)
        if not found and globbed:
            raise ValueError(f"{path}: none of the {len(matches)} path(s) it matches is a light "
                             "field (see --dry-run); expected light field files and folders")
        if not found:
            raise ValueError(f"{path}: no light field in the folder; expected view images "
                             "(one light field) or light field files and folders")
    unique, seen = [], set()
    for item in inputs:
        if os.path.realpath(item.path) not in seen:
            seen.add(os.path.realpath(item.path))
            unique.append(item)
    resolve_options(unique, options, from_list)
    return unique, left_out


def resolve_options(inputs: List[Input], options: dict, from_list: Optional[str]) -> None:
    """Sets each input's ``options``: the command line's that its format takes, then its
    list line's (which must fit). Raises ValueError naming the flag when a list line's
    option does not fit its format, or a command-line option fits no input."""
    given = {k: v for k, v in options.items() if k != "format"}
    used = set()
    for item in inputs:
        fmt = FORMATS.get(item.format) if item.format else None
        takes = fmt.takes() if fmt is not None else tuple(OPTIONS)
        misfits = [k for k in item.listed if k != "format" and k not in takes]
        if misfits:
            raise ValueError(f"{from_list}: {item.path}: {', '.join(OPTIONS[k].flag for k in misfits)} "
                             f"do not apply to format {item.format!r}; expected "
                             f"{', '.join(OPTIONS[k].flag for k in takes)}")
        fitting = {k: v for k, v in given.items() if k in takes}
        used |= set(fitting)
        item.options = dict(fitting, **{k: v for k, v in item.listed.items() if k != "format"})
        if item.format is not None:
            item.options["format"] = item.format
    unused = [k for k in given if k not in used]
    if unused and inputs:
        formats = sorted({item.format for item in inputs if item.format})
        takes = [k for k in OPTIONS if all(k in FORMATS[f].takes() for f in formats)]
        raise ValueError(
            f"option(s) {', '.join(OPTIONS[k].flag for k in unused)} do not apply to format "
            f"{', '.join(repr(f) for f in formats)} of any input ("
            + "; ".join(f"{OPTIONS[k].flag}: {', '.join(formats_taking(k))}" for k in unused)
            + f"); expected {', '.join(OPTIONS[k].flag for k in takes)}")


def describe(item: Input) -> str:
    """One line of ``liff detect --dry-run``: the input, its format, why, its options."""
    shown = common.shown_options(item.options)
    return (f"{item.path}: {item.format or 'told when read'} ({item.why})"
            + (f"; {shown}" if shown else ""))
