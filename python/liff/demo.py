"""The main job on a built-in example: LiFF on a synthetic light field.

The scene: textured layers at known slopes (isolated Gaussian blobs), a partial
occluder in front, and sensor noise. LiFF finds the blobs and their slopes; the
picture shows the features over the centre view coloured by slope.
"""

from __future__ import annotations

import os
import time

import cv2
import numpy as np

from . import synthetic
from ._detector import LiFF
from .outputs import atomic_output
from .plot import draw_keypoints_by_slope

DEMO_SHAPE = (9, 9, 192, 192)
DEMO_SLOPES = (-0.8, -0.4, 0.0, 0.4)


def demo_light_field(noise_variance: float = 1e-3, seed: int = 0):
    """The demo scene: (light field float32 (T, S, V, U), list of ground-truth Blob)."""
    blobs = synthetic.random_blob_layers(DEMO_SLOPES, shape=DEMO_SHAPE, blobs_per_layer=12,
                                         seed=seed)
    lf = synthetic.render_disks(blobs, DEMO_SHAPE, background=0.4, profile="gaussian")
    # A partial occluder: thin vertical bars at slope 0.9 (nearest), in front of everything.
    T, S, V, U = DEMO_SHAPE
    xs = np.arange(U, dtype=np.float64)
    for t in range(T):
        for s in range(S):
            shifted = xs + 0.9 * (s - (S - 1) / 2)  # x in the centre view
            bars = (np.mod(shifted, 48.0) < 3.0)
            lf[t, s][:, bars] = 0.15
    if noise_variance > 0:
        lf += np.random.default_rng(seed).normal(0, np.sqrt(noise_variance), lf.shape)
    return lf.astype(np.float32), blobs


def match_to_truth(keypoints, blobs) -> synthetic.BlobMatch:
    """The demo's counts: a blob is found within 1.5 px of its centre; a feature is
    spurious beyond 3 px of every blob centre."""
    return synthetic.match_blobs(keypoints, blobs, found_within=1.5, spurious_beyond=3.0)


def run_demo(out_dir: str, noise_variance: float = 1e-3) -> int:
    lf, blobs = demo_light_field(noise_variance)
    T, S, V, U = lf.shape
    detector = LiFF.create()
    start = time.perf_counter()
    keypoints, descriptors = detector.detectAndCompute(lf)
    elapsed = time.perf_counter() - start
    centre = lf[T // 2, S // 2]
    sift_keypoints = cv2.SIFT.create().detect(
        np.clip(centre * 255 + 0.5, 0, 255).astype(np.uint8), None)

    match = match_to_truth(keypoints, blobs)
    # cv2.SIFT's first-octave positions sit 0.25 px right/below; LiFF corrects that.
    sift_keypoints = [cv2.KeyPoint(k.pt[0] - 0.25, k.pt[1] - 0.25, k.size) for k in sift_keypoints]
    sift_match = match_to_truth(sift_keypoints, blobs)
    used = detector.getSlicesUsed()
    picture = draw_keypoints_by_slope(centre, keypoints, slope_range=(used[0], used[-1]),
                                      truth=(np.array([(b.x, b.y) for b in blobs]), match.found))
    path = os.path.join(out_dir, "features.png")
    with atomic_output(path) as partial:
        cv2.imwrite(partial, picture)

    print(f"light field: {T}x{S} views of {V}x{U} pixels, noise variance {noise_variance:g}, "
          f"{len(blobs)} blobs at slopes {', '.join(f'{s:+.1f}' for s in DEMO_SLOPES)} "
          f"behind a partial occluder")
    searched = detector.getSearchedSlopes()
    print(f"LiFF: {len(keypoints)} features in {elapsed:.2f} s, {len(searched)} slopes searched "
          f"(automatic): {', '.join(f'{s:+.2f}' for s in searched)}")
    print(f"  blobs found (within 1.5 px): {match.found.sum()}/{len(blobs)}, spurious features "
          f"(> 3 px from any blob): {match.spurious}")
    print(f"  cv2.SIFT on the centre view: {sift_match.found.sum()}/{len(blobs)} found, "
          f"{sift_match.spurious} spurious")
    errors = match.slope_errors
    if len(errors):
        print(f"  slope error of found blobs: median |e| = {np.median(np.abs(errors)):.3f}, "
              f"max |e| = {np.abs(errors).max():.3f} px per view step")
    print(f"  descriptors: {descriptors.shape if descriptors is not None else None}")
    print(f"picture of the features coloured by slope, blobs marked + found, x missed: {path}")
    return 0
