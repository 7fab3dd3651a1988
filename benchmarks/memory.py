"""Memory estimate against measured memory: the estimate detectAndCompute checks its
limit with, and how much the process's peak RSS grows during the call.

Usage:  python benchmarks/memory.py   (11x11 views of 376x541 uint8 noise, the Lytro
Illum size of benchmarks/speed.py; a few seconds)
"""

from __future__ import annotations

import re
import resource

import numpy as np

import liff


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # Linux: kB


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
    parts = dict(grey=r"grey light field (\d+) MB", window=r"3 scale spaces of (\d+) MB",
                 build=r"(\d+) MB while building one")
    mb = {k: float(re.search(v, message).group(1)) for k, v in parts.items()}
    batch = liff.getNumThreads()
    estimate = mb["grey"] + (batch + 2) * mb["window"] + batch * mb["build"]
    detector.setMemoryLimitMB(0)
    before = peak_mb()
    detector.detectAndCompute(lf, None)
    growth = peak_mb() - before
    print(f"threads {batch}: estimate {estimate:.0f} MB for {batch} slices at once; "
          f"peak RSS grew by {growth:.0f} MB (ratio {growth / estimate:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
