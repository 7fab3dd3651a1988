"""Replays the fuzzing corpus (fuzz/corpus/<reader>/) through the readers without
atheris: every input gives a clean result or a ValueError naming the path. The
reproducers of known reader bugs (fuzz/known_bugs/, listed in fuzz/readers.py) are
strict xfails, so a fix shows up as a failure until its entry is removed."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "fuzz"))
import readers  # noqa: E402

CORPUS = [(r, p) for r in readers.READERS for p in sorted((ROOT / "fuzz" / "corpus" / r.name).iterdir())]
KNOWN = sorted((ROOT / "fuzz" / "known_bugs").glob("*/*"))


def test_every_reader_has_seeds_and_every_corpus_folder_a_reader():
    folders = {p.name for p in (ROOT / "fuzz" / "corpus").iterdir()}
    assert folders == set(readers.BY_NAME)
    for r in readers.READERS:
        assert len(list((ROOT / "fuzz" / "corpus" / r.name).iterdir())) >= 3, r.name


@pytest.mark.parametrize("reader, path", CORPUS, ids=[f"{r.name}/{p.name}" for r, p in CORPUS])
def test_corpus_input_is_read_cleanly(reader, path, tmp_path):
    readers.run_reader(reader, path.read_bytes(), str(tmp_path))


def test_corpus_has_valid_and_invalid_inputs_for_every_reader(tmp_path):
    for r in readers.READERS:
        outcomes = set()
        for i, path in enumerate(sorted((ROOT / "fuzz" / "corpus" / r.name).iterdir())):
            work = tmp_path / f"{r.name}-{i}"
            work.mkdir()
            result = readers.run_reader(r, path.read_bytes(), str(work))
            outcomes.add(isinstance(result, ValueError))
        assert outcomes == {True, False}, r.name


def test_every_known_bug_has_a_reproducer():
    assert {p.name for p in KNOWN} == set(readers.KNOWN_BUGS)
    for p in KNOWN:
        assert readers.KNOWN_BUGS[p.name].reader == p.parent.name


# All reproducers run in one child with its address space capped, so that
# cfg-grid-huge ends in a MemoryError rather than in the machine's memory. The readers
# are pure Python: the child uses the installed liff, without .ci/sanitize.sh's
# sanitized module and preloaded runtimes (ASan reserves terabytes of address space).
REPLAY = """
import os, resource, sys
sys.path.insert(0, sys.argv[1])
import readers
resource.setrlimit(resource.RLIMIT_AS, (1 << 30, resource.RLIM_INFINITY))
for path in sys.argv[2:]:
    reader = readers.BY_NAME[os.path.basename(os.path.dirname(path))]
    try:
        readers.run_reader(reader, open(path, "rb").read())
        outcome = "CLEAN"
    except Exception as e:
        outcome = f"KNOWN-BUG {readers.known_bug(reader, e)} {type(e).__name__}: {str(e)[:200]!r}"
    print(os.path.basename(path), outcome, flush=True)
"""


@pytest.fixture(scope="module")
def replayed():
    """{reproducer name: "CLEAN" or "KNOWN-BUG <id or None> <exception>"}."""
    env = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PYTHONPATH")}
    proc = subprocess.run([sys.executable, "-c", REPLAY, str(ROOT / "fuzz"), *map(str, KNOWN)],
                          capture_output=True, text=True, timeout=300, env=env)
    assert proc.returncode == 0, f"exit {proc.returncode}: {proc.stderr}"
    lines = dict(line.split(" ", 1) for line in proc.stdout.splitlines() if " " in line)
    assert set(lines) >= {p.name for p in KNOWN}, proc.stdout
    return lines


class StillBroken(Exception):
    """The known bug is still there (the only failure the xfail below expects)."""


if KNOWN:  # (an empty parametrisation would show as a skip)
    @pytest.mark.parametrize(
        "path",
        [pytest.param(p, marks=pytest.mark.xfail(strict=True, raises=StillBroken,
                                                 reason=readers.KNOWN_BUGS[p.name].what))
         for p in KNOWN],
        ids=[f"{p.parent.name}/{p.name}" for p in KNOWN],
    )
    def test_known_bug_reproducer(path, replayed):
        outcome = replayed[path.name]
        # The bug is still there exactly as documented (not some other failure) ...
        assert outcome == "CLEAN" or outcome.startswith(f"KNOWN-BUG {path.name} "), outcome
        if outcome != "CLEAN":
            raise StillBroken(outcome)


FIXED = sorted((ROOT / "fuzz" / "corpus").glob("*/bug-*"))


@pytest.mark.parametrize("path", FIXED, ids=[f"{p.parent.name}/{p.name}" for p in FIXED])
def test_fixed_bug_reproducers_are_read_or_refused_by_name(path, tmp_path):
    """Bugs found by fuzzing on 2026-11-23 and fixed: read_hci's parameters.cfg handling
    (a '%' in a value is now plain text; the rest is a ValueError naming
    parameters.cfg), read_views with huge indices in the names, read_numpy on headers
    numpy's parser chokes on and on .npz members that are not .npy. run_reader has
    already checked that a ValueError names the input."""
    reader = readers.BY_NAME[path.parent.name]
    result = readers.run_reader(reader, path.read_bytes(), str(tmp_path))
    if path.name == "bug-cfg-percent":
        assert not isinstance(result, Exception)
    else:
        assert isinstance(result, ValueError), result
        if reader.name == "hci":
            assert "parameters.cfg" in str(result), result
