"""The inputs of a command: PATH arguments, folders, quoted globs and list files,
expanded into light fields (:mod:`liff.io.layout`), each with the format and the reader
options it is read with; the identity of an input (size and time), by which a re-run
tells a changed input; the inputs no output may overwrite.

Reader options given on the command line apply to the inputs whose format takes them
(``--lenslet`` to lenslet images, ``--key`` to npz, mat and hdf5 files): an option no
input takes is an error naming it. A list file (``--from-list``) may give options of
its own on a line, after the path (``lytro/IMG_1.png --lenslet 14 --keep-views 11``);
they apply to that line's inputs, over the command line's, and must fit their format.

Layer: the batch runs' (tests/test_layers.py): ``liff detect`` and
:func:`liff.batch.detect` expand their inputs here.
"""

from __future__ import annotations

import argparse
import glob
import hashlib
import os
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

from ._flags import add_reader_options, reader_options, shown_options
from ._paths import refuse_special
from .io.formats import FORMATS, OPTIONS, formats_taking
from .io.layout import FEATURE_FILE, Entry, expand_match
from .io.layout import expand as expand_path
from .io.views import compile_pattern


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
    add_reader_options(parser)
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
        with open(path, encoding="utf-8-sig") as f:  # a byte order mark (Notepad) is not a path
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
        listed.append((words[0], reader_options(parsed)))
    return listed


def expand(paths: Sequence[str], options: dict, from_list: Optional[str] = None,
           features: bool = False, light_field_flags: Sequence[str] = ()
           ) -> Tuple[List[Input], List[Entry]]:
    """(the inputs, the entries of folders left out) that PATH arguments and the list
    file ``from_list`` name; ``options`` are the command line's reader options (as
    :func:`liff._flags.reader_options` gives them). Repeats are dropped. ``features``: liff
    feature files are inputs too; ``light_field_flags``: the other flags given that
    apply to light fields only (the detector's, ``--preprocess``), an error when every
    input is a feature file (:func:`resolve_options`).

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
            matches = _glob(path)
            if not matches:
                raise ValueError(f"{path}: no file matches the pattern; expected light fields")
        else:
            matches = [path]
        found = 0
        folders: dict = {}  # expand_match's record of the folders seen
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
    resolve_options(unique, options, from_list, light_field_flags)
    return unique, left_out


def is_feature_input(item: Input) -> bool:
    """Whether ``item`` is a feature file of ``liff detect`` (its features used as stored)."""
    return item.format is None and item.why == FEATURE_FILE


def resolve_options(inputs: List[Input], options: dict, from_list: Optional[str],
                    light_field_flags: Sequence[str] = ()) -> None:
    """Sets each input's ``options``: the command line's that its format takes, then its
    list line's (which must fit). Raises ValueError naming the flag when a list line's
    option does not fit its format, or a command-line option fits no input: a feature
    file takes none, and when every input is one, ``light_field_flags`` (the detector's
    flags given, ``--preprocess``) are named with the reader options given."""
    given = {k: v for k, v in options.items() if k != "format"}
    features = [item for item in inputs if is_feature_input(item)]
    if inputs and len(features) == len(inputs) and (given or light_field_flags):
        flags = [OPTIONS[k].flag for k in given] + list(light_field_flags)
        raise ValueError(
            f"option(s) {', '.join(flags)} do not apply: the inputs are feature files "
            f"({', '.join(item.path for item in features[:3])}"
            f"{', ...' if len(features) > 3 else ''}), whose features are used as stored; "
            "expected light fields (read and detected with these options), or none of them")
    used = set()
    for item in inputs:
        fmt = FORMATS.get(item.format) if item.format else None
        takes = (() if is_feature_input(item) else fmt.takes() if fmt is not None
                 else tuple(OPTIONS))
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
        takes = tuple(k for k in OPTIONS if all(k in FORMATS[f].takes() for f in formats))
        stored = (f" (and {len(features)} feature file(s), whose features are used as stored)"
                  if features else "")
        raise ValueError(
            f"option(s) {', '.join(OPTIONS[k].flag for k in unused)} do not apply to format "
            f"{', '.join(repr(f) for f in formats)} of any input{stored} ("
            + "; ".join(f"{OPTIONS[k].flag}: {', '.join(formats_taking(k))}" for k in unused)
            + f"); expected {', '.join(OPTIONS[k].flag for k in takes)}")


def describe(item: Input) -> str:
    """One line of ``liff detect --dry-run``: the input, its format, why, its options."""
    shown = shown_options(item.options)
    return (f"{item.path}: {item.format or 'told when read'} ({item.why})"
            + (f"; {shown}" if shown else ""))


def expand_inputs(paths: Sequence[str], options: dict, from_list: Optional[str] = None,
                  features: bool = False) -> List[str]:
    """The light fields that PATH arguments name: each is a light field, a folder of
    light fields (each entry recognised by its names and content: liff.io.layout) or a
    glob pattern (quoted, so the shell left it); ``from_list`` is a text file of more,
    one a line, each perhaps with reader options of its own (:func:`expand`). Repeats
    are dropped.

    Raises
    ------
    ValueError
        Naming the pattern, folder or list file that gave no light field.
    """
    return [item.path for item in expand(paths, options, from_list, features)[0]]


def input_options(paths: Sequence[str], args: argparse.Namespace,
                  light_field_flags: Sequence[str] = ()) -> List[dict]:
    """The reader options each of ``paths`` (light fields given by themselves: ``liff
    pose A B``, ``liff match A B``) is read with: its format as liff.io.layout tells it,
    and the command line's options that format takes, resolved over all of them as for
    a batch (ValueError naming a flag that no input takes, or a folder holding more than
    one light field; or, when both are feature files, naming the reader options and
    ``light_field_flags`` given, which do not apply to them)."""
    inputs = expand(paths, reader_options(args), features=True,
                    light_field_flags=light_field_flags)[0]
    found = {os.path.realpath(item.path): item.options for item in inputs}
    for path in paths:
        if os.path.realpath(path) not in found:
            raise ValueError(f"{path}: a folder of {len(inputs)} light fields or more; expected "
                             "one light field (a file, or a folder of views)")
    return [found[os.path.realpath(path)] for path in paths]


def _glob(pattern: str) -> List[str]:
    """``glob.glob(pattern, recursive=True)``, sorted, except that ``**`` does not descend
    into symbolic links to folders (glob's does, and a link back up makes it loop, for
    ever with two such links): ``**`` goes through pathlib, which does not follow them.
    As with glob, hidden names match only a pattern with a part starting with '.'."""
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
                features: bool = False, light_field_flags: Sequence[str] = ()) -> None:
    """``args.paths`` expanded (:func:`expand_inputs`), ``args.inputs`` the inputs with
    their format and reader options (:class:`Input`), ``args.left_out`` what the
    folders held that is not an input; the paths as given stay in ``args.given_paths``:
    a folder given is an input too, so nothing is written inside it (a later run over
    the folder would read the outputs as light fields)."""
    args.given_paths = list(args.paths)
    args.inputs, args.left_out = expand(args.paths, options, from_list, features,
                                        light_field_flags)
    args.paths = [item.path for item in args.inputs]


def protected_inputs(args: argparse.Namespace) -> List[str]:
    """What no output may be or lie inside: the light fields and the paths as given."""
    return args.paths + getattr(args, "given_paths", [])


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
