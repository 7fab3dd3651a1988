"""Whether two builds of liff give the same features (issue: speed, "nothing else changes").

Run it with one build to save its features, then with the other to compare:

    python benchmarks/same_features.py --save before.npz     # with the old build
    python benchmarks/same_features.py --against before.npz  # with the new one

Scenes, default parameters, one thread: benchmarks/lightfields.py's Illum-size textured
scene and HCI cotton (../shared/data/hci/cotton, when present). Each keypoint of the
saved set is paired with the nearest of the new set in (x, y, slope, orientation,
size); it counts as the same when x and y are within 0.01 px, the slope within 0.001
and the size within 0.01 px. Printed per scene: the counts, whether the searched slopes
are equal, the share of keypoints the same, and for those the descriptors' relative
difference |d_new - d_old| / |d_old| (median, 99th percentile, max, share above 1e-3)
and the largest angle and response differences; then the keypoints that differ.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import liff  # noqa: E402
from lightfields import COTTON, ILLUM_SHAPE, layered_light_field  # noqa: E402


def scenes() -> dict:
    out = {"illum": layered_light_field(ILLUM_SHAPE)}
    if COTTON.is_dir():
        from liff.io import read_light_field

        out["cotton"] = read_light_field(str(COTTON)).light_field
    return out


def detect(lf: np.ndarray) -> dict:
    detector = liff.LiFF.create()
    keypoints, descriptors = detector.detectAndCompute(lf, None)
    rows = np.array([(k.pt[0], k.pt[1], k.size, k.angle, k.response) for k in keypoints])
    return {"rows": rows.reshape(-1, 5), "slopes": liff.keypoint_slopes(keypoints),
            "descriptors": descriptors if descriptors is not None else np.zeros((0, 128)),
            "searched": np.array(detector.getSearchedSlopes())}


def features(rows: np.ndarray, slopes: np.ndarray) -> np.ndarray:
    """Position, slope (x100), orientation (as a unit vector x10) and size, for pairing."""
    angle = np.radians(rows[:, 3])
    return np.c_[rows[:, :2], 100 * slopes, 10 * np.cos(angle), 10 * np.sin(angle), rows[:, 2]]


def compare(name: str, old: dict, new: dict) -> None:
    from scipy.spatial import cKDTree

    print(f"{name}: {len(old['rows'])} keypoints before, {len(new['rows'])} now; searched slopes "
          f"{'equal' if np.array_equal(old['searched'], new['searched']) else 'DIFFER'}")
    if not len(old["rows"]) or not len(new["rows"]):
        return
    _, j = cKDTree(features(new["rows"], new["slopes"])).query(features(old["rows"], old["slopes"]))
    a, b = old["rows"], new["rows"][j]
    same = ((np.abs(a[:, :2] - b[:, :2]) < 0.01).all(axis=1)
            & (np.abs(old["slopes"] - new["slopes"][j]) < 0.001) & (np.abs(a[:, 2] - b[:, 2]) < 0.01))
    print(f"  the same (0.01 px, 0.001 slope, 0.01 px size): {same.sum()} = {100 * same.mean():.2f}%")
    if same.any():
        da, db = old["descriptors"][same], new["descriptors"][j[same]]
        rel = np.linalg.norm(da - db, axis=1) / np.maximum(np.linalg.norm(da, axis=1), 1e-12)
        angle = np.abs((a[same, 3] - b[same, 3] + 180) % 360 - 180)
        print(f"  descriptors' relative difference: median {np.median(rel):.1e}, 99th percentile "
              f"{np.percentile(rel, 99):.1e}, max {rel.max():.1e}, above 1e-3: "
              f"{100 * np.mean(rel > 1e-3):.2f}%; angle max {angle.max():.1e} deg, response "
              f"max {np.max(np.abs(a[same, 4] - b[same, 4]) / np.abs(a[same, 4])):.1e} relative")
    for i in np.flatnonzero(~same)[:10]:
        print(f"  differs: x {a[i, 0]:.3f} y {a[i, 1]:.3f} size {a[i, 2]:.2f} slope "
              f"{old['slopes'][i]:+.4f} -> x {b[i, 0]:.3f} y {b[i, 1]:.3f} size {b[i, 2]:.2f} "
              f"slope {new['slopes'][j[i]]:+.4f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", help="write this build's features to this .npz")
    group.add_argument("--against", help="compare this build's features with this .npz")
    args = parser.parse_args(argv)
    liff.setNumThreads(1)
    found = {name: detect(lf) for name, lf in scenes().items()}
    if args.save:
        np.savez(args.save, **{f"{name}.{key}": value for name, result in found.items()
                               for key, value in result.items()})
        print(f"saved the features of {', '.join(found)} to {args.save}")
        return 0
    saved = np.load(args.against)
    for name, new in found.items():
        if f"{name}.rows" not in saved:
            print(f"{name}: not in {args.against}")
            continue
        compare(name, {key: saved[f"{name}.{key}"] for key in new}, new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
