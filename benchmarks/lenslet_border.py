"""Spurious features at a lenslet capture's black border, and what ``--mask auto`` removes.

Synthetic lenslet captures (``liff.synthetic.lenslet_capture`` of ``textured_layers``:
11x11 views of 192x256, vignetted lenslet edges with alpha 0 beyond the lenslet circle)
are made twice: without and with the main lens's black border (intensities falling to 0
over ``border`` of the image size: 0.02 is a near step, 0.10 a gentle ramp). A feature
of the bordered capture farther than 2 px from every feature of the border-free one is
counted as spurious. For each mask (none; ``liff.preprocess.border_mask`` with several
margins) the table gives the features, the spurious ones, how many of the border-free
capture's features inside the kept region are still found (within 2 px), and the share
of pixels kept.

Usage:  python benchmarks/lenslet_border.py [--seeds 0 1]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import liff
from liff import synthetic
from liff.preprocess import border_mask


def nearest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """For each row of a, the distance to the nearest row of b (inf if b is empty)."""
    if len(b) == 0:
        return np.full(len(a), np.inf)
    return np.sqrt(((a[:, None] - b[None]) ** 2).sum(-1)).min(1)


def points(keypoints) -> np.ndarray:
    return np.array([k.pt for k in keypoints]).reshape(-1, 2)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--borders", type=float, nargs="+", default=[0.02, 0.10])
    parser.add_argument("--margins", type=int, nargs="+", default=[0, 8, 16])
    args = parser.parse_args(argv)
    print("| border | seed | mask | features | spurious | border-free features found in the "
          "kept region | pixels kept |")
    print("|---|---|---|---|---|---|---|")
    detector = liff.LiFF.create()
    for border in args.borders:
        for seed in args.seeds:
            scene = synthetic.textured_layers((11, 11, 192, 256), seed=seed).light_field
            clean = points(detector.detect(synthetic.lenslet_capture(scene, border=0)))
            capture = synthetic.lenslet_capture(scene, border=border)
            for margin in [None] + args.margins:
                mask = None if margin is None else border_mask(capture, margin=margin)
                found = points(detector.detect(capture, mask))
                keep = np.full(capture.shape[2:4], 255, np.uint8) if mask is None else mask
                inside = keep[np.round(clean[:, 1]).astype(int), np.round(clean[:, 0]).astype(int)] > 0
                label = "none" if margin is None else f"auto, margin {margin}"
                print(f"| {border:.2f} | {seed} | {label} | {len(found)} | "
                      f"{int((nearest(found, clean) > 2).sum())} | "
                      f"{int((nearest(clean[inside], found) <= 2).sum())}/{int(inside.sum())} | "
                      f"{100 * (keep > 0).mean():.0f}% |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
