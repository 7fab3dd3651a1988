#!/usr/bin/env python3
"""Coverage-guided fuzzing of liff's readers with atheris (libFuzzer for Python).

    python fuzz/fuzz_readers.py --list
    python fuzz/fuzz_readers.py READER [libFuzzer options] [CORPUS_DIR ...]

e.g. ``python fuzz/fuzz_readers.py pfm -max_total_time=30 build/fuzz/pfm fuzz/corpus/pfm``
(new inputs go to the first folder). Each input is written to a temporary file or
folder (see fuzz/readers.py) and read; a clean result or a ValueError naming the
path passes, as does a MemoryError naming it (a file claiming more than the memory
budget, which is set to half of the address space the target may still take);
anything else (another exception, an error that does not name the
path, a malformed result, a crash, running out of memory or time) is a finding, and
libFuzzer writes the input to crash-*/oom-*/timeout-* files.

The readers' Python code (liff.io) is instrumented for coverage; numpy and OpenCV
(which decodes the PNG views) are not.
"""

import collections
import inspect
import os
import resource
import shutil
import sys
import tempfile

import atheris

os.environ.setdefault("OPENCV_LOG_LEVEL", "OFF")  # corrupt PNGs are expected here
import cv2  # noqa: F401  (imported before instrumentation: not instrumented)
import numpy  # noqa: F401

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import liff._budget  # noqa: E402
import liff.io  # noqa: E402,F401
import readers  # noqa: E402


def instrument(prefixes) -> int:
    """Adds coverage instrumentation to every function and method defined in the
    loaded modules named by ``prefixes`` (and their submodules). Done after import:
    atheris.instrument_imports skips modules loaded by a custom loader, which an
    editable install of liff is."""
    count = 0
    for name, module in list(sys.modules.items()):
        if not any(name == p or name.startswith(p + ".") for p in prefixes):
            continue
        for obj in list(vars(module).values()):
            if getattr(obj, "__module__", None) != name:
                continue
            members = vars(obj).values() if inspect.isclass(obj) else [obj]
            for f in members:
                if inspect.isfunction(f):
                    atheris.instrument_func(f)
                    count += 1
    return count


INSTRUMENTED = instrument(["liff.io", "readers"])


def limit_memory(extra_mb: int = 1024) -> None:
    """Caps the address space at its current size plus ``extra_mb``, so that a reader
    allocating without bound gets a MemoryError (a finding, or a known bug) instead
    of taking the machine's memory before libFuzzer's RSS check notices."""
    with open("/proc/self/status") as f:
        vm = next(int(line.split()[1]) for line in f if line.startswith("VmSize:"))
    cap = (vm + extra_mb * 1024) * 1024
    resource.setrlimit(resource.RLIMIT_AS, (cap, resource.getrlimit(resource.RLIMIT_AS)[1]))
    # Readers check what a header claims against the budget before allocating: half of
    # what the cap leaves, so that a checked claim is a clean MemoryError and only an
    # unchecked allocation runs into the cap.
    liff._budget.memory_budget_bytes = liff._budget.held_bytes() + extra_mb * 2**20 // 2


def main() -> None:
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        sys.exit(2)
    if sys.argv[1] == "--list":
        print("\n".join(r.name for r in readers.READERS))
        return
    name = sys.argv.pop(1)
    if name not in readers.BY_NAME:
        sys.exit(f"unknown reader {name!r}; expected one of {', '.join(readers.BY_NAME)}")
    reader = readers.BY_NAME[name]
    scratch = tempfile.mkdtemp(prefix=f"liff-fuzz-{name}-")
    hits = collections.Counter()

    def test_one_input(data: bytes) -> None:
        work = tempfile.mkdtemp(dir=scratch)
        try:
            readers.run_reader(reader, data, work)
        except Exception as e:  # noqa: BLE001 - every other exception is a finding
            bug = readers.known_bug(reader, e)
            if bug is None:
                raise
            hits[bug] += 1
            if hits[bug] & (hits[bug] - 1) == 0:  # 1, 2, 4, 8, ... (libFuzzer exits without atexit)
                print(f"\nknown bug {bug} hit {hits[bug]} times (not a new finding): "
                      f"{readers.KNOWN_BUGS[bug].what}", flush=True)
        finally:
            shutil.rmtree(work, ignore_errors=True)

    limit_memory()
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
