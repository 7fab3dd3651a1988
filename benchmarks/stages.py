"""LiFF's time per stage on the speed benchmark's light field (issue: speed).

For comparing one change with the next: the median wall time of detectAndCompute
over --calls calls, then the thread-seconds of each stage (summed over threads,
averaged over as many calls with profiling on), on the light field of
benchmarks/speed.py (11x11 views of 376x541, 11 slopes, default parameters).
The machine's speed drifts, so compare runs made one after another.

Usage:  python benchmarks/stages.py [--calls 7] [--threads N]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import liff  # noqa: E402
import liff._core as core  # noqa: E402
from lightfields import ILLUM_SHAPE, layered_light_field  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=7)
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    args = parser.parse_args(argv)
    liff.setNumThreads(args.threads)
    lf = layered_light_field(ILLUM_SHAPE)
    detector = liff.LiFF.create(firstSlope=-1, lastSlope=1, numSlopes=11)  # the paper's Illum setting
    keypoints, _ = detector.detectAndCompute(lf, None)  # first call: allocations
    walls = []
    for _ in range(args.calls):
        start = time.perf_counter()
        detector.detectAndCompute(lf, None)
        walls.append(time.perf_counter() - start)
    core._hooks.set_profiling(True)
    core._hooks.reset_profile()
    for _ in range(args.calls):
        detector.detectAndCompute(lf, None)
    stages = core._hooks.stage_seconds()
    core._hooks.set_profiling(False)
    print(f"{len(keypoints)} keypoints; wall median {np.median(walls):.3f} s "
          f"(min {min(walls):.3f}) over {args.calls} calls on {args.threads} threads")
    print("thread-seconds per call: " + ", ".join(
        f"{name} {seconds / args.calls:.3f}" for name, seconds in stages.items()) +
        f"; sum {sum(stages.values()) / args.calls:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
