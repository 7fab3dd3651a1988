"""liff._allocator: a task's process keeps freed memory for the next task (glibc)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest

from liff import _allocator

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's allocator")

# Two detections of one light field in a fresh process started as Dask's nanny starts
# workers (MALLOC_TRIM_THRESHOLD_=65536: freed memory goes back to the system), in the
# main thread or, as a Dask task runs, in another thread; prints the page faults of the
# second and the allocator's free memory after it, with or without reuse_freed_memory
# first. The uint8 light field (9 x 9 views of 400 x 560) is 73 MB in float: over a
# thread arena's heap (64 MiB), were it one buffer.
SCRIPT = """
import json, resource, sys, threading
import numpy as np
import liff
from liff import _allocator
if sys.argv[1] == "reuse":
    _allocator.reuse_freed_memory()
rng = np.random.default_rng(0)
lf = rng.integers(0, 256, (9, 9, 400, 560), dtype=np.uint8)
liff.setNumThreads(1)
detector = liff.LiFF.create(firstSlope=-1, lastSlope=1, numSlopes=3)
faults = []
def detect_twice():
    detector.detectAndCompute(lf, None)
    before = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
    detector.detectAndCompute(lf, None)
    faults.append(resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - before)
if sys.argv[2] == "thread":
    worker = threading.Thread(target=detect_twice)
    worker.start()
    worker.join()
else:
    detect_twice()
print(json.dumps({"faults": faults[0], "free": _allocator.free_heap_bytes()}))
"""


def run(mode: str, where: str) -> dict:
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    out = subprocess.run([sys.executable, "-c", SCRIPT, mode, where], capture_output=True,
                         text=True, check=True, timeout=120, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("where", ["main thread", "thread"])
def test_a_second_detection_reuses_the_first_ones_memory(where):
    where = where.split()[0]
    default, reuse = run("default", where), run("reuse", where)
    # Returned to the system, the freed buffers are faulted in again by the second
    # call. Kept, they are reused.
    assert default["faults"] > 2000
    assert reuse["faults"] < 0.1 * default["faults"]
    assert reuse["free"] > 8 * 2**20  # the freed buffers, kept


RELEASE_SCRIPT = """
import json, threading
import numpy as np
import liff
from liff import _allocator
_allocator.reuse_freed_memory(256 * 2**20)  # keeps at most a quarter: 64 MiB
lf = np.random.default_rng(0).integers(0, 256, (9, 9, 400, 560), dtype=np.uint8)
liff.setNumThreads(1)
detector = liff.LiFF.create(firstSlope=-1, lastSlope=1, numSlopes=3)
worker = threading.Thread(target=detector.detectAndCompute, args=(lf, None))
worker.start()
worker.join()
before = _allocator.free_heap_bytes()
_allocator.release_excess()
print(json.dumps({"before": before, "after": _allocator.free_heap_bytes(),
                  "retain": _allocator._RETAIN}))
"""


def test_free_memory_beyond_the_bound_is_released_after_a_task():
    # A thread arena keeps every heap it made (TOP_PAD_BYTES); release_excess holds the
    # process to its bound.
    out = subprocess.run([sys.executable, "-c", RELEASE_SCRIPT], capture_output=True,
                         text=True, check=True, timeout=120)
    sizes = json.loads(out.stdout.strip().splitlines()[-1])
    assert sizes["retain"] == 64 * 2**20
    assert sizes["before"] > sizes["retain"]
    assert sizes["after"] <= sizes["retain"]


def test_free_memory_is_not_counted_as_held():
    psutil = pytest.importorskip("psutil")  # (comes with distributed)
    assert _allocator.free_heap_bytes() > 0
    assert 0 <= _allocator.held_bytes() <= psutil.Process().memory_info().rss



# Free memory in a thread arena's heap, then part of it madvised as numpy does for its
# large arrays (huge pages), which splits the heap's mapping in /proc/self/maps: the
# free memory counted before and after, in a fresh process.
SPLIT_HEAP_SCRIPT = r"""
import ctypes, json, mmap, threading
from liff import _allocator
_allocator.reuse_freed_memory(2**30)
libc = ctypes.CDLL("libc.so.6")
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = [ctypes.c_void_p]
libc.madvise.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
sizes = {}
def in_a_thread():
    size = 24 * 2**20
    block = libc.malloc(size)
    ctypes.memset(block, 1, size)  # resident
    keep = libc.malloc(4096)  # (so that the block is not the heap's top alone)
    libc.free(block)
    sizes["before"] = _allocator.free_heap_bytes()
    page = mmap.PAGESIZE
    middle = (block + 8 * 2**20) // page * page
    sizes["madvise"] = libc.madvise(middle, 8 * 2**20, 14)  # MADV_HUGEPAGE
    sizes["after"] = _allocator.free_heap_bytes()
thread = threading.Thread(target=in_a_thread)
thread.start()
thread.join()
print(json.dumps(sizes))
"""


def test_a_heap_split_by_madvise_still_counts_as_free():
    out = subprocess.run([sys.executable, "-c", SPLIT_HEAP_SCRIPT], capture_output=True,
                         text=True, check=True, timeout=120)
    sizes = json.loads(out.stdout.strip().splitlines()[-1])
    if sizes["madvise"] != 0:
        pytest.skip("madvise(MADV_HUGEPAGE) refused here (no transparent huge pages)")
    assert sizes["before"] >= 20 * 2**20
    assert sizes["after"] >= sizes["before"] - 2**20
