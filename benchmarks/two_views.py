"""Slopes from two views along the longer axis (stereo pairs, 2x2): why the automatic
range is a narrow [-2, 2] there (docs/SLOPES.md, "Two views").

Textured-layer scenes (liff.synthetic.textured_layers, layers at -0.9, 0.13 and 0.77)
of 2x2 and 1x2 views, and 2x2 crops of HCI cotton (when ../shared is there): the share
of features more than 1 pixel per view step off the true slope, and the median error,
for the default (automatic) range and hand-set ranges of increasing width.

Usage:  python benchmarks/two_views.py
"""

from __future__ import annotations

import os
import warnings

import numpy as np

import liff
import lightfields
from liff import synthetic

COTTON = str(lightfields.COTTON)
RANGES = ({}, {"firstSlope": -2, "lastSlope": 2}, {"firstSlope": -8, "lastSlope": 8})


def slope_errors(lf: np.ndarray, slope_map: np.ndarray, options: dict) -> np.ndarray:
    keypoints = liff.LiFF.create(**options).detect(lf)
    pts = np.array([k.pt for k in keypoints]).reshape(-1, 2)
    idx = np.clip(np.rint(pts).astype(int), 0, np.array(slope_map.shape[::-1]) - 1)
    return np.abs(liff.keypoint_slopes(keypoints) - slope_map[idx[:, 1], idx[:, 0]])


def scenes():
    for shape in ((2, 2, 128, 128), (2, 2, 256, 256), (1, 2, 256, 256)):
        scene = synthetic.textured_layers(shape, (-0.9, 0.13, 0.77), seed=0)
        yield f"textured {shape[0]}x{shape[1]} of {shape[2]}", scene.light_field, scene.slope_map
    if os.path.isdir(COTTON):
        read = liff.io.read_light_field(COTTON)
        disparity = liff.io.read_pfm(os.path.join(COTTON, "gt_disp_lowres.pfm"))
        for t, s in ((3, 3), (4, 3)):
            crop = np.ascontiguousarray(read.light_field[t:t + 2, s:s + 2, 128:384, 128:384])
            yield f"cotton views ({t}, {s}) 2x2, 256 px crop", crop, disparity[128:384, 128:384]
    else:
        print(f"(HCI cotton not found at {COTTON}: its rows are left out)")


def main() -> int:
    warnings.simplefilter("ignore", liff.LiffWarning)
    print(f"liff {liff.__version__}; share of features > 1 off / median |error| (features)\n")
    names = ["automatic (default)", "[-2, 2] by hand", "[-8, 8] by hand"]
    print("| scene | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 1) + "|")
    for name, lf, slope_map in scenes():
        cells = []
        for options in RANGES:
            e = slope_errors(lf, slope_map, options)
            cells.append(f"{np.mean(e > 1):.2f} / {np.median(e):.3f} ({len(e)})")
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
