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

With --layers, a second table: liff.synthetic.textured_layers scenes (three layers,
occluding one another, reflected at the borders) of 3x3 to 15x15 views, detected with
the automatic range; "wrong" is a slope more than 0.5 from the slope map at the feature.
It shows what a rule at the borders costs where the scene itself is not a ghost.

Usage:  python benchmarks/view_borders.py [--seeds 0 1] [--layers]
"""

from __future__ import annotations

import argparse

import numpy as np

import liff
from liff.synthetic import textured_layers, textured_plane

LAYOUTS = ((3, 3, 256, 256, -4.0), (3, 3, 256, 256, 3.0), (5, 5, 200, 240, -2.5),
           (9, 9, 160, 160, 1.2), (1, 9, 160, 200, -2.0), (11, 11, 200, 200, 0.6))


def count(lf: np.ndarray, slope: float, detector) -> tuple:
    """(features, wrong slope, wrong at a border, right slope, band area, inner area) of
    one detection (areas in pixels)."""
    T, S, V, U = lf.shape
    band = abs(slope) * (max(T, S) - 1) / 2 + 10
    inner = max(0.0, V - 2 * band) * max(0.0, U - 2 * band)
    keypoints = detector.detect(lf)
    if not keypoints:
        return 0, 0, 0, 0, V * U - inner, inner
    slopes = liff.keypoint_slopes(keypoints)
    pts = np.array([k.pt for k in keypoints])
    to_border = np.minimum.reduce([pts[:, 0], pts[:, 1], U - 1 - pts[:, 0], V - 1 - pts[:, 1]])
    wrong = np.abs(slopes - slope) > 0.5
    return (len(keypoints), int(wrong.sum()), int((wrong & (to_border < band)).sum()),
            int((~wrong).sum()), V * U - inner, inner)


def row(label: str, sums: np.ndarray) -> str:
    """A table row: the counts, then wrong-slope features per 10^4 pixels at a border
    and inside (the same density means the borders add no ghosts of their own)."""
    features, wrong, at_border, right, band_area, inner_area = sums
    inside = wrong - at_border
    density = (f"{1e4 * at_border / band_area:.1f} / "
               f"{(1e4 * inside / inner_area) if inner_area else float('nan'):.1f}")
    return f"| {label} | {int(features)} | {int(wrong)} | {int(at_border)} | {int(right)} | {density} |"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--layers", action="store_true",
                        help="also the textured_layers table (what the border rule costs)")
    args = parser.parse_args(argv)
    liff.setNumThreads(2)
    print(f"liff {liff.__file__}")
    print("| views | slope | range | features | wrong slope | wrong at a border | right slope "
          "| wrong per 10^4 px, border / inside |")
    print("|---|---|---|---|---|---|---|---|")
    totals = {}
    for T, S, V, U, m in LAYOUTS:
        for name in ("automatic", "hand-set"):
            detector = (liff.LiFF.create() if name == "automatic" else
                        liff.LiFF.create(firstSlope=-abs(m) - 2, lastSlope=abs(m) + 2))
            sums = np.zeros(6)
            for seed in args.seeds:
                sums += count(textured_plane((T, S, V, U), m, seed), m, detector)
            totals[name] = totals.get(name, np.zeros(6)) + sums
            print(row(f"{T}x{S} of {V}x{U} | {m:+.1f} | {name}", sums))
    for name, sums in totals.items():
        print(row(f"all | | {name}", sums))
    if args.layers:
        layered(args.seeds)
    return 0


def layered(seeds) -> None:
    """The --layers table: features and wrong-slope features per layout."""
    print()
    print("| views | layers | features | wrong slope (> 0.5 from the slope map) |")
    print("|---|---|---|---|")
    total = np.zeros(2, int)
    for n in (3, 5, 9, 15):
        for layers in ((-4.0, -1.0, 3.0), (-2.0, 0.5, 1.5), (-6.0, 0.0, 5.0)):
            sums = np.zeros(2, int)
            for seed in seeds:
                scene = textured_layers((n, n, 160, 160), layers, seed=seed)
                keypoints = liff.LiFF.create().detect(scene.light_field)
                slopes = liff.keypoint_slopes(keypoints)
                pts = np.round(np.array([k.pt for k in keypoints])).astype(int).clip(0, 159)
                truth = scene.slope_map[pts[:, 1], pts[:, 0]]
                sums += (len(keypoints), int((np.abs(slopes - truth) > 0.5).sum()))
            total += sums
            print(f"| {n}x{n} of 160x160 | {', '.join(f'{m:+g}' for m in layers)} | "
                  f"{sums[0]} | {sums[1]} |")
    print(f"| all | | {total[0]} | {total[1]} |")


if __name__ == "__main__":
    raise SystemExit(main())
