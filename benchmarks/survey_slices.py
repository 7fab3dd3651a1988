"""Slices the automatic slope range builds and searches per scene, and features found:
a check that a change to the survey (docs/SLOPES.md) does not widen the plan where the
scenes hold nothing new.

Scenes: benchmarks/core_speed.py's Illum-size textured scene and HCI cotton (when
../shared has it), benchmarks/slopes.py's blob scenes, and rows of views with small
disks (liff.synthetic.paper_disks, radius 2.5, slopes -0.8..0.8). For each: slices
built, slices searched, features, and (for the disk scenes) disks found by the
automatic range and by [-1, 1] set by hand.

Usage:  python benchmarks/survey_slices.py
"""

from __future__ import annotations

import os
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import liff  # noqa: E402
from core_speed import scenes  # noqa: E402
from liff import synthetic  # noqa: E402
from slopes import blob_scene  # noqa: E402

ROWS = ((1, 17, 96, 128), (1, 25, 96, 128), (1, 51, 96, 128), (1, 51, 192, 256),
        (51, 1, 128, 96), (9, 9, 96, 128))


def detect(lf, **parameters):
    d = liff.LiFF.create(**parameters)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", liff.SlopeRangeWarning)
        keypoints = d.detect(lf)
    return d.getSlopeRangeReport(), keypoints


def main() -> int:
    liff.setNumThreads(2)
    cases = dict(scenes(False))
    for lo, hi, n in ((-1, 1, 9), (-4, 3, 5), (-0.5, 2.0, 9), (-2, 2, 15)):
        cases[f"blobs {n}x{n} [{lo}, {hi}] (slopes.py)"] = blob_scene(lo, hi, n)[0]
    print("| scene | slices built | searched | features | disks found (automatic / [-1, 1]) |")
    print("|---|---|---|---|---|")
    for name, lf in cases.items():
        report, keypoints = detect(lf)
        print(f"| {name} | {len(report.slicesUsed)} | {len(report.searchedSlopes)} | "
              f"{len(keypoints)} | |")
    for shape in ROWS:
        blobs = synthetic.paper_disks(n=8, shape=shape, slope_range=(-0.8, 0.8), seed=0,
                                      contrast=0.3)
        lf = synthetic.render_disks(blobs, shape, noise_variance=1e-4, seed=1).astype(np.float32)
        report, keypoints = detect(lf)
        _, by_hand = detect(lf, firstSlope=-1.0, lastSlope=1.0)
        found = synthetic.match_blobs(keypoints, blobs, 2.0, 5.0).found.sum()
        found_by_hand = synthetic.match_blobs(by_hand, blobs, 2.0, 5.0).found.sum()
        name = "x".join(map(str, shape[:2])) + " views of " + "x".join(map(str, shape[:1:-1]))
        print(f"| 8 disks, {name} | {len(report.slicesUsed)} | {len(report.searchedSlopes)} | "
              f"{len(keypoints)} | {found} / {found_by_hand} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
