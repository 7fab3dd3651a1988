"""Sub-slice slope accuracy: the slope each feature gets between its focal slices.

Blob scenes (liff.synthetic: Gaussian blobs, radius 2-5 px, on seven layers between
-1 and 1, shifted by 0.13 per seed) and textured-layer scenes, at 3x3 to 15x15 views of
192x192, each with a hand-set range [-2, 2]: once with the default spacing (one pixel
of parallax at the outermost view: 2 (N - 1) + 1 slices, given explicitly) and once
with 5 slices (coarse: 1 slope unit apart).
Prints the median and 90th percentile of |slope error| (blobs: each found blob's
nearest feature; textured: each feature against the slope map at its pixel).

Run the same command on builds of two commits to compare sub-slice methods.
Usage:  python benchmarks/subslice.py [--seeds 3]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import liff
from liff import synthetic


def errors(n: int, seed: int, num_slopes: int):
    shape = (n, n, 192, 192)
    layers = np.linspace(-1.0, 1.0, 7) + 0.13 * seed
    blobs = synthetic.random_blob_layers(layers, shape, blobs_per_layer=5, radius_range=(2.0, 5.0),
                                         seed=seed, margin=14)
    lf = np.clip(synthetic.render_disks(blobs, shape, profile="gaussian", noise_variance=1e-4,
                                        seed=seed), 0, 1).astype(np.float32)
    detector = liff.LiFF.create(firstSlope=-2, lastSlope=2, numSlopes=num_slopes)
    radii = np.array([b.radius for b in blobs])
    match = synthetic.match_blobs(detector.detect(lf), blobs, np.maximum(2, radii / 2), radii + 2)
    scene = synthetic.textured_layers(shape, (-0.9 + 0.1 * seed, 0.13, 0.77), seed=seed)
    keypoints = detector.detect(scene.light_field)
    pts = np.array([k.pt for k in keypoints]).reshape(-1, 2)
    idx = np.clip(np.rint(pts).astype(int), 0, 191)
    textured = liff.keypoint_slopes(keypoints) - scene.slope_map[idx[:, 1], idx[:, 0]]
    return np.abs(match.slope_errors), np.abs(textured)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args(argv)
    print(f"liff {liff.__version__}; |slope error| median / p90, pixels per view step\n")
    print("| views | slices over [-2, 2] | blobs (found) | textured (features) |")
    print("|---|---|---|---|")
    for n in (3, 5, 9, 15):
        # the default spacing for [-2, 2] (one pixel at the outermost view), given
        # explicitly so that builds with other count rules use the same slices
        for num_slopes, label in ((2 * (n - 1) + 1, f"{2 * (n - 1) + 1} (default spacing)"),
                                  (5, "5 (coarse)")):
            runs = [errors(n, seed, num_slopes) for seed in range(args.seeds)]
            blob = np.concatenate([r[0] for r in runs])
            tex = np.concatenate([r[1] for r in runs])
            print(f"| {n}x{n} | {label} | {np.median(blob):.4f} / {np.percentile(blob, 90):.4f} "
                  f"({len(blob)}) | {np.median(tex):.4f} / {np.percentile(tex, 90):.4f} "
                  f"({len(tex)}) |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
