"""Depth from features on a real light field: LiFF slopes against HCI ground truth.

On an HCI 4D benchmark scene (default ../shared/data/hci/cotton), compares each
feature's slope with the ground-truth disparity at its pixel (both in pixels per view
step, same sign), for LiFF over the scene's disparity range with several slope counts,
and for SIFT on the centre view with a naive per-feature disparity from repeated SIFT
(each centre-view feature matched, by descriptor and along its epipolar line, into the
other views of the centre row and column; disparity = median over views of the
shift per view step, needing 3 or more views).

Writes into --out: liff_features.png (features over the centre view coloured by slope)
and, if matplotlib is installed, slope_scatter.png (estimated against true slope).
Usage:  python benchmarks/hci_depth.py [--scene DIR] [--out DIR]
"""

from __future__ import annotations

import argparse
import os
import sys

import cv2
import numpy as np

import liff
from liff.io import read_hci
from liff.plot import draw_keypoints_by_slope

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from lightfields import COTTON  # noqa: E402

DEFAULT_SCENE = str(COTTON)


def truth_at(gt: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Ground truth at the nearest pixel of each (x, y)."""
    V, U = gt.shape
    cols = np.clip(np.round(points[:, 0]).astype(int), 0, U - 1)
    rows = np.clip(np.round(points[:, 1]).astype(int), 0, V - 1)
    return gt[rows, cols]


def error_stats(estimate: np.ndarray, truth: np.ndarray) -> dict:
    err = np.abs(estimate - truth)
    if len(err) == 0:
        return {"n": 0, "median": float("nan"), "p90": float("nan"), "within_0.1": float("nan")}
    return {"n": int(len(err)), "median": float(np.median(err)),
            "p90": float(np.percentile(err, 90)), "within_0.1": float(np.mean(err <= 0.1))}


def repeated_sift_disparity(grey_views: np.ndarray, ratio: float = 0.8, min_views: int = 3):
    """Centre-view SIFT keypoints and a naive disparity for each (NaN if fewer than
    ``min_views`` epipolar matches). ``grey_views`` is uint8 (T, S, V, U)."""
    T, S = grey_views.shape[:2]
    tc, sc = T // 2, S // 2
    sift = cv2.SIFT.create()
    kps, desc = sift.detectAndCompute(grey_views[tc, sc], None)
    if desc is None:
        return (), np.zeros(0)
    centre = np.array([k.pt for k in kps])
    estimates = [[] for _ in kps]
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    others = [(tc, s) for s in range(S) if s != sc] + [(t, sc) for t in range(T) if t != tc]
    for t, s in others:
        vk, vd = sift.detectAndCompute(grey_views[t, s], None)
        if vd is None or len(vk) < 2:
            continue
        other = np.array([k.pt for k in vk])
        for pair in matcher.knnMatch(desc, vd, k=2):
            if len(pair) < 2 or pair[0].distance > ratio * pair[1].distance:
                continue
            i, j = pair[0].queryIdx, pair[0].trainIdx
            dx, dy = other[j] - centre[i]
            if s != sc:  # same row: the shift is along x, x_v = x - d (s - s_c)
                if abs(dy) < 1.0:
                    estimates[i].append(-dx / (s - sc))
            elif abs(dx) < 1.0:  # same column: along y
                estimates[i].append(-dy / (t - tc))
    disparity = np.array([np.median(e) if len(e) >= min_views else np.nan for e in estimates])
    return kps, disparity


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=DEFAULT_SCENE)
    parser.add_argument("--out", default=os.path.join(HERE, "..", "docs", "results"))
    args = parser.parse_args(argv)
    if not os.path.isdir(args.scene):
        print(f"HCI scene not found at {args.scene}; pass --scene DIR", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    scene = read_hci(args.scene)
    lf, gt = scene.light_field, scene.gt_disparity
    T, S, V, U = lf.shape[:4]
    lo, hi = scene.disp_min, scene.disp_max
    print(f"scene {os.path.basename(os.path.normpath(args.scene))}: {T}x{S} views of {V}x{U}, "
          f"disparity range [{lo}, {hi}] (parameters.cfg), ground truth in [{gt.min():.2f}, "
          f"{gt.max():.2f}]")
    print("\n| method | features | with an estimate | median abs error | 90th pct | within 0.1 |")
    print("|---|---|---|---|---|---|")
    main_run = None
    runs = [dict()] + [dict(firstSlope=lo, lastSlope=hi, numSlopes=n) for n in (9, 0, 33)]
    for settings in runs:
        detector = liff.LiFF.create(**settings)
        kps = detector.detect(lf)
        slopes = liff.keypoint_slopes(kps)
        st = error_stats(slopes, truth_at(gt, np.array([k.pt for k in kps]).reshape(-1, 2)))
        searched = detector.getSearchedSlopes()
        label = (f"LiFF, {len(searched)} slopes in [{lo}, {hi}]" if settings else
                 f"LiFF, default (automatic): {len(searched)} slopes searched in "
                 f"[{searched[0]:.2f}, {searched[-1]:.2f}]")
        print(f"| {label} | {len(kps)} | {st['n']} | {st['median']:.3f} | {st['p90']:.3f} | "
              f"{100 * st['within_0.1']:.0f}% |")
        if main_run is None:
            main_run = (kps, slopes)
    grey = np.stack([cv2.cvtColor(lf[t, s], cv2.COLOR_BGR2GRAY) for t in range(T)
                     for s in range(S)]).reshape(T, S, V, U)
    skps, sdisp = repeated_sift_disparity(grey)
    ok = np.isfinite(sdisp)
    spts = np.array([k.pt for k in skps]).reshape(-1, 2) - 0.25  # cv2.SIFT's +1/4 px
    st = error_stats(sdisp[ok], truth_at(gt, spts[ok]))
    print(f"| SIFT (centre view) + repeated-SIFT disparity | {len(skps)} | {st['n']} | "
          f"{st['median']:.3f} | {st['p90']:.3f} | {100 * st['within_0.1']:.0f}% |")

    kps, slopes = main_run
    picture = draw_keypoints_by_slope(lf[T // 2, S // 2], kps, slope_range=(lo, hi), scale=1)
    path = os.path.join(args.out, "liff_features.png")
    cv2.imwrite(path, picture)
    print(f"\nwrote {path}")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: skipped slope_scatter.png (pip install matplotlib)")
        return 0
    fig, ax = plt.subplots(figsize=(4.5, 4.5), dpi=100)
    truth = truth_at(gt, np.array([k.pt for k in kps]).reshape(-1, 2))
    ax.plot([lo, hi], [lo, hi], color="0.6", lw=1)
    ax.scatter(truth, slopes, s=8, label=f"LiFF ({len(kps)})")
    ax.scatter(truth_at(gt, spts[ok]), sdisp[ok], s=8, marker="x", alpha=0.6,
               label=f"repeated SIFT ({ok.sum()})")
    ax.set_xlabel("ground-truth disparity (px per view step)")
    ax.set_ylabel("estimated slope")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo - 0.5, hi + 0.5)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    path = os.path.join(args.out, "slope_scatter.png")
    fig.savefig(path)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
