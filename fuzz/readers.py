"""The readers under test, shared by the fuzz target (fuzz_readers.py), the corpus
replay (tests/io/test_fuzz_corpus_replay.py) and the reader property tests.

Every light field format of liff.io's registry (liff.io.formats.FORMATS, its ``fuzz``
field: the input's name ending and the options to read it with) is a target, named as
the format (also its corpus folder, fuzz/corpus/<name>/); READERS adds the targets that
are not formats: a name, the function, and how the fuzz bytes become its input:
``file(".ext")`` writes them to one file, ``FOLDER`` unpacks them into a folder
(see unpack_folder). The contract every reader is held to: a clean result, or a
ValueError (or, for a file claiming more than the memory budget, a MemoryError) that
names the path it was given; anything else is a finding.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

import liff
import liff.io


def read_parameters(path: str) -> np.ndarray:
    """``LiFF.read(path)``: the parameters a file sets, as an array (a clean result)."""
    detector = liff.LiFF.create()
    detector.read(path)
    return np.array([getattr(detector, "get" + p.accessor)() for p in liff.PARAMETERS], float)


@dataclass(frozen=True)
class Reader:
    name: str
    read: Callable
    suffix: Optional[str]  # the input file's name ending; None: the input is a folder


def file(suffix: str) -> Optional[str]:
    return suffix


FOLDER = None

def _registered() -> list:
    """A target per format of liff.io's registry (liff.io.formats.FORMATS): its reader,
    with the registry's fuzz options, on an input with the registry's name ending."""
    from functools import partial

    return [Reader(f.name, partial(f.read, **f.fuzz[1]) if f.fuzz[1] else f.read, f.fuzz[0])
            for f in liff.io.formats.FORMATS.values() if f.fuzz is not None]


READERS = _registered() + [
    Reader("pfm", liff.io.read_pfm, file(".pfm")),
    Reader("eslf-detect", liff.io.read_eslf, file("_eslf.png")),  # lenslet size detected
    Reader("any", liff.io.read_light_field, file(".npz")),
    # a parameter file (YAML, JSON or XML, told by its content): nesting, size, values
    Reader("parameters", read_parameters, file(".yml")),
]
BY_NAME = {r.name: r for r in READERS}


@dataclass(frozen=True)
class KnownBug:
    reader: str
    exception: type  # the exception raised (or chained to the Finding)
    message: str  # a regular expression its message matches
    what: str


# Reader bugs found by fuzzing, reported and not yet fixed. The fuzz target lets an
# input that hits one pass, so that a run goes on to find new ones, and counts the
# hits. Each has a reproducer fuzz/known_bugs/<reader>/<id> that
# tests/io/test_fuzz_corpus_replay.py replays as a strict xfail: once the bug is fixed that test
# fails until the entry below is removed and the reproducer moved into
# fuzz/corpus/<reader>/. The six parameters.cfg bugs of read_hci found on 2026-11-23
# are fixed; their reproducers are fuzz/corpus/hci/bug-*.
KNOWN_BUGS: dict = {}


def known_bug(reader: Reader, error: BaseException) -> Optional[str]:
    """The id of the known bug ``error`` is an instance of, or None."""
    for bug_id, bug in KNOWN_BUGS.items():
        if bug.reader != reader.name:
            continue
        for e in (error, error.__cause__):
            if isinstance(e, bug.exception) and re.search(bug.message, str(e)):
                return bug_id
    return None

# Folder inputs are a sequence of files, each introduced by a line "%%file NAME":
#   %%file parameters.cfg\n<bytes>\n%%file input_Cam000.png\n<bytes>...
# (the newline before a header belongs to the header). Names are single path
# components; anything before the first header, and files with names that are not
# plain, are ignored.
_HEADER = re.compile(rb"(?:^|\n)%%file ([^\n]{1,100})\n")
_PLAIN = re.compile(r"^[A-Za-z0-9_.-]+$")


def pack_folder(files: dict) -> bytes:
    """The fuzz input that unpacks to ``files`` ({name: bytes})."""
    return b"".join(b"%%file " + name.encode() + b"\n" + data + b"\n" for name, data in files.items())


def unpack_folder(data: bytes, folder: str) -> None:
    parts = _HEADER.split(data)
    for i in range(1, len(parts) - 1, 2):
        try:
            name = parts[i].decode("ascii")
        except UnicodeDecodeError:
            continue
        if _PLAIN.match(name) and name not in (".", ".."):
            content = parts[i + 1]
            with open(os.path.join(folder, name), "wb") as f:
                f.write(content[:-1] if i + 2 < len(parts) and content.endswith(b"\n") else content)


def materialise(reader: Reader, data: bytes, workdir: str) -> str:
    """Writes ``data`` as the reader's input inside ``workdir``; returns its path."""
    if reader.suffix is None:
        path = os.path.join(workdir, "scene")
        os.mkdir(path)
        unpack_folder(data, path)
    else:
        path = os.path.join(workdir, "input" + reader.suffix)
        with open(path, "wb") as f:
            f.write(data)
    return path


class Finding(AssertionError):
    """A reader broke its contract."""


def check_result(reader: Reader, result) -> None:
    """What a clean result looks like: arrays are finite-sized numpy arrays; a scene
    object has a light field of shape (T, S, V, U[, C])."""
    arrays = [result] if isinstance(result, np.ndarray) else []
    lf = getattr(result, "light_field", None)
    if lf is not None or hasattr(result, "light_field"):
        if not isinstance(lf, np.ndarray) or lf.ndim not in (4, 5) or lf.size == 0:
            raise Finding(f"{reader.name}: light_field is {type(lf).__name__} "
                          f"{getattr(lf, 'shape', '')}; expected a non-empty (T, S, V, U[, C]) array")
        arrays.append(lf)
    if not arrays:
        raise Finding(f"{reader.name}: returned {type(result).__name__}, no array")
    for a in arrays:
        if a.size == 0:
            raise Finding(f"{reader.name}: returned an empty array of shape {a.shape}")


def run_reader(reader: Reader, data: bytes, workdir: Optional[str] = None):
    """Feeds ``data`` to ``reader``. Returns the result, or the ValueError or
    MemoryError it raised (whose message must name the path: a file claiming more than
    the memory budget is refused with a MemoryError naming it). Raises Finding, or
    lets any other exception through, when the contract is broken."""
    own = workdir is None
    workdir = tempfile.mkdtemp(prefix="liff-fuzz-") if own else workdir
    try:
        path = materialise(reader, data, workdir)
        try:
            result = reader.read(path)
        except (ValueError, MemoryError) as e:
            if path not in str(e):
                raise Finding(f"{reader.name}: {type(e).__name__} does not name the input "
                              f"{path!r}: {e}") from e
            return e
        check_result(reader, result)
        return result
    finally:
        if own:
            shutil.rmtree(workdir, ignore_errors=True)
