"""Structure from motion, as the paper's SfM table: LiFF against SIFT through COLMAP.

Scenes (liff.captures): textured boxes, panels, a floor and a back wall, seen by a
camera array of VIEWS at POSES poses along a 40-degree arc, slopes spanning [-1, 1]
(back wall to nearest object) as the paper's Lytro sub-aperture views. Each scene is
run in three conditions:

- clean;
- occluders: the same scene behind a fence of thin dark bars at slope about 1;
- low contrast + noise: the clean render with the texture amplitude scaled by CONTRAST
  about 0.5 and Gaussian noise added to every view, of variance 1e-4 (moderate) and
  1e-3 (strong: where SIFT began to fail on the paper's noise scene, benchmarks/noise.py).

Both methods see the same 8-bit input, the paper's greyscale (luminance, gamma 0.5,
histogram stretch with one mapping for the whole light field, as the authors' code;
liff.preprocess via liff.colmap.prepare_light_field): LiFF the
whole light field (11 slopes in [-1, 1]), SIFT (cv2.SIFT) its centre view. Thresholds
are identical: contrastThreshold 0.02 (the paper's peak threshold 0.0066 = 0.02 / 3 on
|DoG|), edgeThreshold 10, first octave -1, 3 layers per octave; both descriptors are
RootSIFT by one function (liff.colmap.root_sift). Matching, verification and mapping are
identical (liff.colmap), with COLMAP's default mapper and a permissive one. The known
focal length is given to COLMAP as a prior (shared camera).

Columns, per scene then averaged over the scenes that passed (the paper's averaging:
its keypoint counts differ between its default and permissive rows): see
liff.colmap.table_metrics. "intersect" rows take only the scenes both methods passed.
Usage:  python benchmarks/sfm.py [--quick] [--out FILE]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time

import cv2
import numpy as np

import liff
from liff import captures, colmap

HERE = os.path.dirname(os.path.abspath(__file__))
CONTRAST_THRESHOLD = 0.02  # = the paper's VLFeat peak threshold 0.0066 x 3 layers
EDGE_THRESHOLD = 10.0
SLOPES = dict(firstSlope=-1.0, lastSlope=1.0, numSlopes=11)
CONTRAST = 0.25
NOISE = {"low contrast + noise 1e-4": 1e-4, "low contrast + noise 1e-3": 1e-3}
FULL = dict(scenes=6, poses=5, views=(9, 9), size=(240, 320))
QUICK = dict(scenes=2, poses=4, views=(5, 5), size=(180, 240))
CONDITIONS = ("clean", "occluders") + tuple(NOISE)
METHODS = ("LiFF", "SIFT")
MAPPERS = ("default", "permissive")
COLUMNS = [("% pass", None), ("% images registered", "registered"), ("keypts / img", "keypoints_per_image"),
           ("putative / img", "putative_matches_per_image"),
           ("inliers / img", "inlier_matches_per_image"), ("match ratio", "match_ratio"),
           ("precision", "precision"), ("matching score", "matching_score"),
           ("3D points", "points3D"), ("track len", "track_length")]


def features(lf_uint8: np.ndarray, method: str):
    """Keypoints and RootSIFT descriptors of one prepared light field (T, S, V, U)."""
    if method == "LiFF":
        detector = liff.LiFF.create(contrastThreshold=CONTRAST_THRESHOLD,
                                    edgeThreshold=EDGE_THRESHOLD, **SLOPES)
        keypoints, descriptors = detector.detectAndCompute(lf_uint8)
    else:
        T, S = lf_uint8.shape[:2]
        detector = cv2.SIFT.create(contrastThreshold=CONTRAST_THRESHOLD, edgeThreshold=EDGE_THRESHOLD)
        keypoints, descriptors = detector.detectAndCompute(lf_uint8[T // 2, S // 2], None)
    return keypoints, colmap.root_sift(descriptors)  # None (no keypoints) gives (0, 128)


def prepare(capture: captures.Capture, equalize: str) -> list:
    """The 8-bit greyscale light field (T, S, V, U) of every pose: both methods' input."""
    return [colmap.prepare_light_field(lf, equalise=equalize) for lf in capture.light_fields]


def run_colmap(capture: captures.Capture, greys: list, method: str, workdir: str) -> dict:
    """Features, matching and both mappers on one capture, given its prepared light
    fields (:func:`prepare`): {mapper: metrics}."""
    images = []
    for i, grey in enumerate(greys):
        keypoints, descriptors = features(grey, method)
        T, S = grey.shape[:2]
        images.append(colmap.FeatureImage(f"pose{i:02d}.png", grey[T // 2, S // 2], keypoints, descriptors))
    database, image_dir = os.path.join(workdir, "database.db"), os.path.join(workdir, "images")
    k = capture.intrinsics
    colmap.write_database(database, image_dir, images, focal=k.focal, principal_point=(k.cx, k.cy))
    colmap.match(database)
    out = {}
    for mapper in MAPPERS:
        result = colmap.reconstruct(database, image_dir, os.path.join(workdir, f"sparse-{mapper}"), mapper)
        out[mapper] = colmap.table_metrics(database, result)
    return out


def scene_captures(seed: int, setup: dict):
    """The conditions of one scene: two renders, the noisy ones made from the clean one."""
    common = dict(n_poses=setup["poses"], views=setup["views"], size=setup["size"])
    clean = captures.make_capture(seed, **common)
    yield "clean", clean
    for condition, variance in NOISE.items():
        yield condition, captures.degrade(clean, CONTRAST, variance, seed=seed)
    del clean
    yield "occluders", captures.make_capture(seed, occluders=True, **common)


def run(setup: dict, progress: bool = True, equalize: str = "stretch") -> list:
    """Rows of (scene, condition, method, {mapper: metrics})."""
    try:
        from tqdm import tqdm
    except ImportError:  # progress bar is optional
        tqdm = None
    total = setup["scenes"] * len(CONDITIONS) * len(METHODS)
    bar = tqdm(total=total, file=sys.stderr, disable=not progress) if tqdm else None
    rows = []
    for seed in range(setup["scenes"]):
        for condition, capture in scene_captures(seed, setup):
            greys = prepare(capture, equalize)  # once: both methods see the same input
            for method in METHODS:
                workdir = tempfile.mkdtemp(prefix="liff-sfm-")
                try:
                    rows.append((seed, condition, method, run_colmap(capture, greys, method, workdir)))
                finally:
                    shutil.rmtree(workdir, ignore_errors=True)
                if bar:
                    bar.set_postfix_str(f"scene {seed} {condition} {method}")
                    bar.update()
            del greys
    if bar:
        bar.close()
    return rows


def block(rows, conditions, mapper, intersect: bool) -> list:
    """Table lines (one per method) for the scenes of ``conditions`` with ``mapper``."""
    per = {(s, c, m): r[mapper] for s, c, m, r in rows if c in conditions}
    scenes = sorted({(s, c) for s, c, _ in per})
    both = [sc for sc in scenes if all(per[sc + (m,)]["passed"] for m in METHODS)]
    lines = []
    for method in METHODS:
        passed = both if intersect else [sc for sc in scenes if per[sc + (method,)]["passed"]]
        cells = [f"{100 * len(passed) / len(scenes):.0f} ({len(passed)}/{len(scenes)})"]
        for _, key in COLUMNS[1:]:
            values = [per[sc + (method,)][key] for sc in passed]
            value = float(np.nanmean(values)) if values and not np.all(np.isnan(values)) else float("nan")
            cells.append(_format(100 * value if key == "registered" else value, key))
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return lines


def _format(value: float, key: str) -> str:
    if np.isnan(value):
        return "-"
    if key in ("match_ratio", "precision", "matching_score"):
        return f"{value:.3f}"
    return f"{value:.2f}" if key == "track_length" else f"{value:.0f}"


def tables(rows) -> str:
    out = []
    for name, conditions in [(c, (c,)) for c in CONDITIONS] + [("all conditions", CONDITIONS)]:
        out.append(f"\n{name}:\n")
        out.append("| method | " + " | ".join(c for c, _ in COLUMNS) + " |")
        out.append("|---" * (len(COLUMNS) + 1) + "|")
        for intersect in (False, True):
            for mapper in MAPPERS:
                label = f"COLMAP {mapper}" + (" intersect" if intersect else "")
                out.append(f"| *{label}* |" + " |" * len(COLUMNS))
                out += block(rows, conditions, mapper, intersect)
    return "\n".join(out)


def per_scene(rows) -> str:
    """One line per scene, condition and method: pass, inliers/img, 3D points (both mappers)."""
    out = ["\n| scene | condition | method | " + " | ".join(f"{k}: pass, inliers/img, 3D pts" for k in MAPPERS)
           + " |", "|---|---|---|---|---|"]
    for s, c, m, r in rows:
        cells = [f"{'yes' if r[k]['passed'] else 'no'}, {r[k]['inlier_matches_per_image']:.0f}, "
                 f"{r[k]['points3D']}" for k in MAPPERS]
        out.append(f"| {s} | {c} | {m} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 small scenes of 5x5 views (about a minute)")
    parser.add_argument("--out", default=os.path.join(HERE, "..", "docs", "results", "sfm_table.md"),
                        help="markdown file for the tables (default docs/results/sfm_table.md)")
    parser.add_argument("--no-progress", action="store_true")
    parser.add_argument("--equalize", choices=("stretch", "cdf"), default="stretch",
                        help="histogram step of the preprocessing (liff.preprocess.equalize): "
                             "the authors' code's stretch (default) or classic equalisation")
    args = parser.parse_args(argv)
    import pycolmap

    pycolmap.logging.minloglevel = 2  # COLMAP's INFO/WARNING lines would drown the tables
    setup = QUICK if args.quick else FULL
    start = time.time()
    rows = run(setup, progress=not args.no_progress, equalize=args.equalize)
    T, S = setup["views"]
    header = (f"{setup['scenes']} scenes x {len(CONDITIONS)} conditions, {setup['poses']} poses of "
              f"{T}x{S} views of {setup['size'][1]}x{setup['size'][0]} px; contrastThreshold "
              f"{CONTRAST_THRESHOLD}, edgeThreshold {EDGE_THRESHOLD:g}, LiFF {SLOPES['numSlopes']} slopes "
              f"in [{SLOPES['firstSlope']:g}, {SLOPES['lastSlope']:g}]; low contrast {CONTRAST}; "
              f"histogram {args.equalize}; "
              f"{time.time() - start:.0f} s")
    text = header + "\n" + tables(rows) + "\n" + per_scene(rows) + "\n"
    print(text)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        f.write(text)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
