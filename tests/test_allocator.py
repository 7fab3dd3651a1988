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
# workers (MALLOC_TRIM_THRESHOLD_=65536: freed memory goes back to the system); prints
# the page faults and the allocator's free memory after the second, with or without
# reuse_freed_memory first.
# (5 x 5 views of 160 x 200: LiFF's largest buffers stay under MMAP_THRESHOLD_BYTES.)
SCRIPT = """
import json, resource, sys
import numpy as np
import liff
from liff import _allocator
if sys.argv[1] == "reuse":
    _allocator.reuse_freed_memory()
rng = np.random.default_rng(0)
lf = rng.random((5, 5, 160, 200)).astype(np.float32)
liff.setNumThreads(1)
detector = liff.LiFF.create(firstSlope=-1, lastSlope=1)
detector.detectAndCompute(lf, None)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
detector.detectAndCompute(lf, None)
faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
print(json.dumps({"faults": faults, "free": _allocator.free_heap_bytes()}))
"""


def run(mode: str) -> dict:
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    out = subprocess.run([sys.executable, "-c", SCRIPT, mode], capture_output=True, text=True,
                         check=True, timeout=120, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_second_detection_reuses_the_first_ones_memory():
    default, reuse = run("default"), run("reuse")
    # Returned to the system, the freed buffers are faulted in again by the second
    # call. Kept, they are reused.
    assert default["faults"] > 2000
    assert reuse["faults"] < 0.1 * default["faults"]
    assert reuse["free"] > 8 * 2**20  # the freed buffers, kept


def test_free_memory_is_not_counted_as_held():
    psutil = pytest.importorskip("psutil")  # (comes with distributed)
    assert _allocator.free_heap_bytes() > 0
    assert 0 <= _allocator.held_bytes() <= psutil.Process().memory_info().rss
