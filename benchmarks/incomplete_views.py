"""Depth from features when only a cross or a star of views exists.

Some datasets ship only the views through the centre: the centre row and column (a
cross) or those plus the diagonals (a star). liff reads such a folder as the whole grid
with alpha 0 for the missing views (docs/INPUTS.md). This compares LiFF on those subsets
of an HCI scene (default ../shared/data/hci/cotton) with LiFF on the full grid: each
subset is written as a folder of views named like a Lytro dataset's
(``0421_RR_CC.png``, scene id first), read back with ``liff.io.read_views``, and each
feature's slope compared with the ground-truth disparity at its pixel, as
benchmarks/hci_depth.py does. Slopes span a hand-set -2..2. A control row drops the alpha channel of the cross, so
that the missing views count as black views.

Usage:  python benchmarks/incomplete_views.py [--scene DIR] [--num-slopes N ...]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

import cv2
import numpy as np

import liff
from liff.io import read_hci, read_views

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hci_depth import DEFAULT_SCENE, error_stats, truth_at  # noqa: E402


def subsets(T: int, S: int) -> dict:
    """{name: set of (t, s)}: the full grid, the star and the cross through the centre,
    and as a control the cross with its alpha dropped (the missing views black)."""
    tc, sc = T // 2, S // 2
    full = {(t, s) for t in range(T) for s in range(S)}
    cross = {(t, s) for t, s in full if t == tc or s == sc}
    diagonals = {(t, s) for t, s in full if abs(t - tc) == abs(s - sc)}
    return {"full": full, "star": cross | diagonals, "cross": cross,
            "cross, alpha dropped": cross}


def read_subset(lf: np.ndarray, views: set, folder: str) -> np.ndarray:
    """Writes ``views`` of ``lf`` as ``0421_RR_CC.png`` and reads the folder back."""
    for t, s in sorted(views):
        cv2.imwrite(os.path.join(folder, f"0421_{t:02d}_{s:02d}.png"), lf[t, s])
    result = read_views(folder)
    assert len(result.metadata["missing"]) == lf.shape[0] * lf.shape[1] - len(views)
    return result.light_field


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=DEFAULT_SCENE)
    parser.add_argument("--num-slopes", type=int, nargs="+", default=[9, 17],
                        help="slope counts to try (0: the default, odd >= views)")
    args = parser.parse_args(argv)
    if not os.path.isdir(args.scene):
        print(f"HCI scene not found at {args.scene}; pass --scene DIR", file=sys.stderr)
        return 2
    scene = read_hci(args.scene)
    lf, gt = scene.light_field, scene.gt_disparity
    T, S, V, U = lf.shape[:4]
    print(f"scene {os.path.basename(os.path.normpath(args.scene))}: {T}x{S} views of {V}x{U}; "
          f"slopes -2..2; error = |feature slope - ground-truth disparity at its pixel|")
    print("\n| views | slopes | features | median abs error | 90th pct | within 0.1 | "
          "full-grid features found (1.5 px) |")
    print("|---|---|---|---|---|---|---|")
    for num_slopes in args.num_slopes:
        full_points = None
        for name, views in subsets(T, S).items():
            with tempfile.TemporaryDirectory() as folder:
                subset = read_subset(lf, views, folder)
            if "alpha dropped" in name:
                subset = subset[..., :-1]
            detector = liff.LiFF.create(firstSlope=-2, lastSlope=2, numSlopes=num_slopes)
            kps = detector.detect(subset)
            points = np.array([k.pt for k in kps]).reshape(-1, 2)
            st = error_stats(liff.keypoint_slopes(kps), truth_at(gt, points))
            if full_points is None:
                full_points, found = points, "-"
            else:
                d = (np.sqrt(((full_points[:, None] - points[None]) ** 2).sum(-1)).min(1)
                     if len(points) else np.full(len(full_points), np.inf))
                found = f"{int((d <= 1.5).sum())}/{len(full_points)}"
            print(f"| {name} ({len(views)}) | {len(detector.slopesFor(T, S))} | {len(kps)} | "
                  f"{st['median']:.3f} | {st['p90']:.3f} | {100 * st['within_0.1']:.0f}% | {found} |"
                  if len(kps) else
                  f"| {name} ({len(views)}) | {len(detector.slopesFor(T, S))} | 0 | - | - | - | {found} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
