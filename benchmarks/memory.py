"""Memory estimate against measured memory: the estimate detectAndCompute checks its
limit with, and how much the process's peak RSS grows during the call.

Usage:  python benchmarks/memory.py   (11x11 views of 376x541 uint8 noise, the Lytro
Illum size of benchmarks/speed.py; a few seconds)
"""

from __future__ import annotations

import os
import re
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import liff  # noqa: E402
from speed import peak_rss_mb  # noqa: E402

#: the parts of the core's MemoryError message (cpp/src/liff.cpp, sliceBatch), in MB
PARTS = dict(grey=r"grey light field (\d+) MB", window=r"3 scale spaces of (\d+) MB",
             build=r"(\d+) MB while building one", slices=r"(\d+) focal slices of",
             slice=r"focal slices of ([\d.]+) MB", total=r"needs about (\d+) MB")


def estimate_mb(parts: dict, batch: int) -> float:
    """MemoryEstimate::total(batch) (cpp/src/memory.hpp) from the message's parts: the
    light field, a window of batch + 2 scale spaces, batch being built, and the focal
    slices rendered ahead, max(slicesPerPass, batch + 1). The message gives
    slicesAhead(1) = max(slicesPerPass, 2), which is that max for every batch >= 1."""
    ahead = max(int(parts["slices"]), batch + 1)
    return (parts["grey"] + (batch + 2) * parts["window"] + batch * parts["build"]
            + ahead * parts["slice"])


def main() -> int:
    shape = (11, 11, 376, 541)
    lf = np.random.default_rng(0).integers(0, 255, shape, dtype=np.uint8)
    detector = liff.LiFF.create()
    detector.setMemoryLimitMB(1e-3)  # too small: the error message carries the estimate
    try:
        detector.detect(lf)
        raise SystemExit("expected a MemoryError")
    except MemoryError as error:
        message = str(error)
    print(message)
    found = {k: re.search(v, message) for k, v in PARTS.items()}
    missing = [k for k, m in found.items() if m is None]
    if missing:
        raise SystemExit(f"the MemoryError message lacks {', '.join(missing)}; has its format "
                         f"(cpp/src/liff.cpp, sliceBatch) changed?")
    parts = {k: float(m.group(1)) for k, m in found.items()}
    # The parts are rounded to whole MB, so their sum for one slice is within a few MB
    # of the core's own total.
    print(f"one slice at a time: estimate {estimate_mb(parts, 1):.0f} MB from the parts, "
          f"{parts['total']:.0f} MB in the message")
    batch = liff.getNumThreads()
    estimate = estimate_mb(parts, batch)
    detector.setMemoryLimitMB(0)
    # Noise has no structure: the automatic range says so; memory is what is measured.
    warnings.simplefilter("ignore", liff.SlopeRangeWarning)
    before = peak_rss_mb()
    detector.detectAndCompute(lf, None)
    growth = peak_rss_mb() - before
    print(f"threads {batch}: estimate {estimate:.0f} MB for {batch} slices at once; "
          f"peak RSS grew by {growth:.0f} MB (ratio {growth / estimate:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
