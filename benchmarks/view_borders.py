"""Features at a wrong slope near the views' borders (hostile files issue, borders).

Near a border, at a slope far from the scene's, the outer views' samples of a point
leave the frame: the focal slice there averages fewer views, which are as sharp at a
wrong slope as at the right one, and detection reads them as structure. The scenes are
fronto-parallel textured planes at a known slope m whose world continues beyond the
frame (liff.synthetic.textured_plane: each view a window onto a larger texture, as a
camera array or gantry sees it), in several layouts: 3x3 views at |m| of 3-4 px per
view step (a block of a Stanford gantry scene), 5x5, 9x9, 11x11 and a 1x9 row. Each is
detected with the automatic slope range and with a hand-set range reaching 2 px per view
step beyond the plane either side, [-|m| - 2, |m| + 2]. A feature is counted wrong when
its slope is more than 0.5 from m; "at a border" when it lies within |m| (views - 1) / 2
+ 10 px of a border (the band that not every view sees, and a feature's width more).

Usage:  python benchmarks/view_borders.py [--seeds 0 1]
"""

from __future__ import annotations

import argparse

import numpy as np

import liff
from liff.synthetic import textured_plane

LAYOUTS = ((3, 3, 256, 256, -4.0), (3, 3, 256, 256, 3.0), (5, 5, 200, 240, -2.5),
           (9, 9, 160, 160, 1.2), (1, 9, 160, 200, -2.0), (11, 11, 200, 200, 0.6))


def count(lf: np.ndarray, slope: float, detector) -> tuple:
    """(features, wrong slope, wrong at a border, right slope) of one detection."""
    T, S, V, U = lf.shape
    keypoints = detector.detect(lf)
    if not keypoints:
        return 0, 0, 0, 0
    slopes = liff.keypoint_slopes(keypoints)
    pts = np.array([k.pt for k in keypoints])
    to_border = np.minimum.reduce([pts[:, 0], pts[:, 1], U - 1 - pts[:, 0], V - 1 - pts[:, 1]])
    band = abs(slope) * (max(T, S) - 1) / 2 + 10
    wrong = np.abs(slopes - slope) > 0.5
    return len(keypoints), int(wrong.sum()), int((wrong & (to_border < band)).sum()), int((~wrong).sum())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = parser.parse_args(argv)
    liff.setNumThreads(2)
    print(f"liff {liff.__file__}")
    print("| views | slope | range | features | wrong slope | wrong at a border | right slope |")
    print("|---|---|---|---|---|---|---|")
    totals = {}
    for T, S, V, U, m in LAYOUTS:
        for name in ("automatic", "hand-set"):
            detector = (liff.LiFF.create() if name == "automatic" else
                        liff.LiFF.create(firstSlope=-abs(m) - 2, lastSlope=abs(m) + 2))
            sums = np.zeros(4, int)
            for seed in args.seeds:
                sums += count(textured_plane((T, S, V, U), m, seed), m, detector)
            totals[name] = totals.get(name, np.zeros(4, int)) + sums
            print(f"| {T}x{S} of {V}x{U} | {m:+.1f} | {name} | " + " | ".join(map(str, sums)) + " |")
    for name, sums in totals.items():
        print(f"| all | | {name} | " + " | ".join(map(str, sums)) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
