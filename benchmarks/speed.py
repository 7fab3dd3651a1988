"""Speed and memory of LiFF against SIFT and repeated SIFT (issue: speed).

One run measures, on a Lytro-Illum-sized light field (11x11 views of 376x541
pixels, textured occluding layers, 11 slopes, default parameters):

* LiFF detectAndCompute on the light field;
* cv2.SIFT detectAndCompute on the centre view;
* cv2.SIFT detectAndCompute on all 121 views (the paper's repeated SIFT, without
  the consolidation step);
* the ratios LiFF / SIFT and repeated SIFT / LiFF, the process's peak memory, LiFF's
  per-stage breakdown (thread-summed seconds), and how LiFF's time grows with the
  number of slopes, of views and of pixels, with a least-squares fit of the cost model
      time = a * M * P  +  b * M * N * P  +  c
  (M slopes, N views, P pixels per view: scale spaces, shift-and-sum, fixed costs).

Both libraries use the same number of threads (--threads, default: all cores).
Usage:  python benchmarks/speed.py [--repeats 3] [--threads N] [--quick]
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import sys
import time

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import liff  # noqa: E402
import liff._core as core  # noqa: E402
from lightfields import ILLUM_SHAPE, layered_light_field  # noqa: E402


def best_of(repeats, fn):
    """(smallest wall time in seconds, last result) over ``repeats`` calls."""
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return min(times), result


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def to_uint8(view):
    return np.clip(view * 255.0 + 0.5, 0, 255).astype(np.uint8)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--quick", action="store_true", help="skip the scaling table")
    args = parser.parse_args(argv)
    liff.setNumThreads(args.threads)
    cv2.setNumThreads(args.threads)

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"cv2 {cv2.__version__}, liff core on OpenCV {liff.opencvVersion()}, {args.threads} threads")
    lf = layered_light_field(ILLUM_SHAPE)
    T, S, V, U = lf.shape
    views8 = [to_uint8(lf[t, s]) for t in range(T) for s in range(S)]
    centre8 = views8[(T // 2) * S + S // 2]
    detector = liff.LiFF.create(numSlopes=11)
    sift = cv2.SIFT.create()

    liff_time, (kps, _) = best_of(args.repeats, lambda: detector.detectAndCompute(lf, None))
    sift_time, (skps, _) = best_of(args.repeats, lambda: sift.detectAndCompute(centre8, None))
    repeated_time, counts = best_of(
        1, lambda: [len(sift.detectAndCompute(v, None)[0]) for v in views8])
    print(f"\nlight field {T}x{S} views of {V}x{U}, float32, 11 slopes; best of {args.repeats}")
    print(f"| method | seconds | keypoints |\n|---|---|---|")
    print(f"| LiFF detectAndCompute | {liff_time:.3f} | {len(kps)} |")
    print(f"| SIFT, centre view | {sift_time:.3f} | {len(skps)} |")
    print(f"| SIFT on all {T * S} views | {repeated_time:.3f} | {sum(counts)} in all |")
    print(f"\nLiFF / SIFT(centre view) = {liff_time / sift_time:.2f}   (target <= 4)")
    print(f"repeated SIFT / LiFF     = {repeated_time / liff_time:.1f}   (target >= 30)")

    core._set_profiling(True)
    core._reset_profile()
    start = time.perf_counter()
    detector.detectAndCompute(lf, None)
    wall = time.perf_counter() - start
    stages = core._stage_seconds()
    core._set_profiling(False)
    total = sum(stages.values())
    print(f"\nper-stage breakdown (thread-summed seconds; wall {wall:.3f} s):")
    print("| stage | seconds | share |\n|---|---|---|")
    for name, seconds in stages.items():
        print(f"| {name} | {seconds:.3f} | {100 * seconds / total:.0f}% |")

    if not args.quick:
        scaling(args.repeats)
    print(f"\npeak memory of this process (ru_maxrss): {peak_rss_mb():.0f} MB   (target <= 400)")
    return 0


def scaling(repeats: int) -> None:
    """LiFF time against slopes, views and pixels; fits the cost model."""
    rows = []  # (M, N views, P pixels, seconds)
    base = (11, 11, 188, 270)  # half-size views keep the table quick
    for M in (3, 7, 11, 21):
        rows.append(run_case(base, M, repeats))
    for n in (5, 9, 15):
        rows.append(run_case((n, n, 188, 270), 11, repeats))
    for scale in (0.5, 2.0):
        rows.append(run_case((11, 11, int(188 * scale), int(270 * scale)), 11, repeats))
    print("\nscaling (LiFF detectAndCompute):")
    print("| slopes M | views N | pixels P | seconds |\n|---|---|---|---|")
    for M, N, P, sec in rows:
        print(f"| {M} | {N} | {P} | {sec:.3f} |")
    X = np.array([[M * P, M * N * P, 1.0] for M, N, P, _ in rows])
    y = np.array([r[3] for r in rows])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    pred = X @ coef
    err = np.abs(pred - y) / y
    print(f"cost model time = a*M*P + b*M*N*P + c: a = {coef[0] * 1e9:.2f} ns, "
          f"b = {coef[1] * 1e9:.3f} ns, c = {coef[2] * 1e3:.1f} ms; "
          f"max relative error {100 * err.max():.0f}%")


def run_case(shape, M, repeats):
    lf = layered_light_field(shape)
    detector = liff.LiFF.create(numSlopes=M)
    seconds, _ = best_of(repeats, lambda: detector.detectAndCompute(lf, None))
    return M, shape[0] * shape[1], shape[2] * shape[3], seconds


if __name__ == "__main__":
    sys.exit(main())
