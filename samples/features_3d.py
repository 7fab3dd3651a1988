"""Features in 3-D: (x, y, slope) of every LiFF feature, coloured by slope, as in the
paper's 3-D scene figure. Slope is disparity (pixels per view step), so nearer points
have larger slopes.

    python samples/features_3d.py --out features_3d.png [--hci PATH]

Uses the HCI "cotton" scene when given (or found at ../shared/data/hci/cotton), with
its ground-truth disparity beside the estimates; otherwise the built-in layered scene,
whose three layers should appear as three planes.
"""

import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import liff  # noqa: E402
from liff import synthetic  # noqa: E402

HCI_DEFAULT = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "hci", "cotton")


def load(hci_path):
    """(light field, slope range, ground-truth slope map or None, title)."""
    if hci_path and os.path.isdir(hci_path):
        from liff.io import read_hci

        scene = read_hci(hci_path)
        return scene.light_field, (-2.0, 2.0), scene.gt_disparity, "HCI cotton"
    scene = synthetic.textured_layers((9, 9, 160, 200), noise_variance=1e-4)
    return scene.light_field, (-1.0, 1.0), scene.slope_map, "built-in layers (-0.6, 0.1, 0.7)"


def plot_features(xy, slopes, slope_range, title):
    """The 3-D scatter (x, slope, y) coloured by slope, with a colour bar far enough
    right that the y label, which matplotlib puts on the right edge, stays visible."""
    figure = plt.figure(figsize=(8, 6))
    axes = figure.add_subplot(projection="3d")
    points = axes.scatter(xy[:, 0], slopes, xy[:, 1], c=slopes, cmap="turbo", s=6,
                          vmin=slope_range[0], vmax=slope_range[1])
    axes.set_xlabel("x (px)")
    axes.set_ylabel("slope (px / view)", labelpad=12)
    axes.set_zlabel("y (px)")
    axes.invert_zaxis()  # image rows grow downwards
    axes.set_title(title)
    figure.colorbar(points, label="slope", shrink=0.7, pad=0.15)
    return figure


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="features_3d.png")
    parser.add_argument("--hci", default=HCI_DEFAULT, help="HCI scene folder (optional)")
    args = parser.parse_args()

    lf, (first, last), truth, title = load(args.hci)
    detector = liff.LiFF.create(firstSlope=first, lastSlope=last,
                                numSlopes=int(round((last - first) / 0.125)) + 1)
    keypoints = detector.detect(lf)
    xy = np.array([k.pt for k in keypoints])
    slopes = liff.keypoint_slopes(keypoints)

    figure = plot_features(xy, slopes, (first, last), f"{len(keypoints)} LiFF features, {title}")
    figure.savefig(args.out, dpi=120, bbox_inches="tight")

    if truth is not None:
        rows = np.clip(np.round(xy[:, 1]).astype(int), 0, truth.shape[0] - 1)
        cols = np.clip(np.round(xy[:, 0]).astype(int), 0, truth.shape[1] - 1)
        error = np.abs(slopes - truth[rows, cols])
        print(f"{len(keypoints)} features; median |slope - ground truth| {np.median(error):.3f}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
