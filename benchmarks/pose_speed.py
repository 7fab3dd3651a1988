"""Speed of metric pose matching: liff.estimate_relative_pose per pair, ``liff pose``, and
``liff sfm --camera`` against its detection and database step (docs/BENCHMARKS.md).

The scene is ``liff synth poses`` (a box scene at N poses, 7x7 views of 240x320,
~730 features each); the camera is the one ``poses.truth.json`` gives (focal 300 px,
baseline 0.0409 m, principal point (159.5, 119.5), focus distance 5.09 m).

1. Per pair: liff.estimate_relative_pose on every pair of the N captures' features (from
   ``liff detect``, the detector's defaults as ``liff sfm`` uses them), wall and CPU
   seconds, with the translation and rotation error against the truth (the accuracy
   check: the same figures before and after a speed change).
2. ``liff pose A.npz B.npz --camera ...`` in a fresh process, against a fresh process
   that only imports the command line and reads the two feature files: the difference
   is what the pose costs beyond reading its inputs (imports of its own included).
3. ``liff sfm POSES --workspace WS --camera ...`` (with --workers W for each W given)
   against ``liff colmap POSES --database ... --image-dir ...`` (the detection and
   database step alone, same detector and workers), both fresh processes; and the
   sfm's own "matching every pair ... done in" time.
4. Growth with the number of captures: match_by_pose's total for N = each of --scaling
   (all N (N - 1) / 2 pairs) and per pair; extrapolated to N = 100 (4950 pairs).
5. Growth with the number of features: the pairs of the first 3 captures with each
   capture's features cut to the K strongest (``liff detect --nfeatures K``) for each K
   of --features.

Usage:  python benchmarks/pose_speed.py [--poses N] [--workers W ...] [--scaling N ...]
        [--features K ...] [--repeats R] [--quick]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

import liff
from liff.feature_file import load_features
from liff.matching import ratio_matches

CAMERA_ARGS = ["--camera", "300", "0.0409", "159.5", "119.5", "--focus-distance", "5.09"]
CAMERA = liff.LightFieldCamera(300.0, 0.0409, (159.5, 119.5), 5.09)


def children_cpu() -> float:
    """CPU seconds (user + system) of this process's finished children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(command) -> tuple:
    """(wall s, CPU s of the process and its children, CompletedProcess) of a command."""
    start, cpu = time.perf_counter(), children_cpu()
    done = subprocess.run(command, capture_output=True, text=True)
    return time.perf_counter() - start, children_cpu() - cpu, done


def liff_cli(*args) -> float:
    """Runs ``python -m liff ARGS`` in a fresh process; its wall seconds (raises on
    failure; ``liff_cli.cpu`` holds its CPU seconds, ``liff_cli.last`` the process)."""
    seconds, liff_cli.cpu, done = run([sys.executable, "-m", "liff", *args])
    if done.returncode != 0:
        raise RuntimeError(f"liff {' '.join(args)} failed ({done.returncode}): {done.stderr[-2000:]}")
    liff_cli.last = done
    return seconds


def make_poses(folder: str, n: int, nfeatures: int = 0) -> tuple:
    """(light field paths, feature file paths, truth) of ``liff synth poses`` at n poses,
    features cut to the ``nfeatures`` strongest (0: all)."""
    poses = os.path.join(folder, f"poses{n}")
    feats = os.path.join(folder, f"feats{n}-{nfeatures}")
    if not os.path.exists(poses):
        liff_cli("synth", "poses", "--out", poses, "--poses", str(n))
    if not os.path.exists(feats):  # made once per n and nfeatures
        liff_cli("detect", poses, "--out", feats, "--nfeatures", str(nfeatures))
    names = sorted(f[:-4] for f in os.listdir(poses) if f.endswith(".npz"))
    with open(poses + ".truth.json", encoding="utf-8") as f:
        truth = {p["name"]: (np.array(p["rotation"]), np.array(p["translation"]))
                 for p in json.load(f)["poses"]}
    return ([os.path.join(poses, f"{m}.npz") for m in names],
            [os.path.join(feats, f"{m}.npz") for m in names], [truth[m] for m in names])


def pair_timings(feature_paths, truth, repeats: int):
    """Per pair: (wall s, CPU s, putative matches, inliers, t err %, R err deg), best of
    ``repeats`` for the times."""
    features = [load_features(p) for p in feature_paths]
    rows = []
    # one pose first, untimed: imports (pycolmap, SciPy) are paid once per process
    liff.estimate_relative_pose(features[0].keypoints, features[0].descriptors,
                                features[1].keypoints, features[1].descriptors, CAMERA)
    for i, j in itertools.combinations(range(len(features)), 2):
        a, b = features[i], features[j]
        walls, cpus = [], []
        for _ in range(repeats):
            w0, c0 = time.perf_counter(), time.process_time()
            R, t, matches = liff.estimate_relative_pose(a.keypoints, a.descriptors, b.keypoints,
                                                        b.descriptors, CAMERA)
            walls.append(time.perf_counter() - w0)
            cpus.append(time.process_time() - c0)
        (R1, t1), (R2, t2) = truth[i], truth[j]
        R_true = R2 @ R1.T
        t_true = t2 - R_true @ t1
        t_err = 100 * np.linalg.norm(t - t_true) / np.linalg.norm(t_true)
        R_err = np.degrees(np.arccos(np.clip((np.trace(R @ R_true.T) - 1) / 2, -1, 1)))
        putative = len(ratio_matches(a.descriptors, b.descriptors, 0.8))
        rows.append((min(walls), min(cpus), putative, len(matches), t_err, R_err))
    return np.array(rows)


def pose_command(folder, feature_paths, repeats: int):
    """(liff pose wall s, CPU s; read-only wall s, CPU s), medians of ``repeats`` fresh
    processes each."""
    a, b = feature_paths[0], feature_paths[1]
    reader = ("import liff.cli, liff.cli.pose; from liff.feature_file import load_features; "
              f"load_features({a!r}); load_features({b!r})")
    pose, read = [], []
    for _ in range(repeats):
        pose.append((liff_cli("pose", a, b, *CAMERA_ARGS), liff_cli.cpu))
        wall, cpu, done = run([sys.executable, "-c", reader])
        done.check_returncode()
        read.append((wall, cpu))
    return tuple(np.median(pose, axis=0)) + tuple(np.median(read, axis=0))


def sfm_command(folder, poses_dir, workers: int):
    """(sfm wall s, its matching step s, colmap (detection + database) wall s, sfm CPU s,
    colmap CPU s)."""
    ws = os.path.join(folder, f"ws{workers}")
    sfm = liff_cli("sfm", poses_dir, "--workspace", ws, "--overwrite", "--workers", str(workers),
                   *CAMERA_ARGS)
    sfm_cpu = liff_cli.cpu
    found = re.search(r"by their metric pose: done in ([0-9.]+) s", liff_cli.last.stderr)
    matching = float(found.group(1)) if found else float("nan")
    db = os.path.join(folder, f"db{workers}")
    colmap = liff_cli("colmap", poses_dir, "--database", os.path.join(db, "database.db"), "--image-dir",
                      os.path.join(db, "images"), "--overwrite", "--workers", str(workers))
    return sfm, matching, colmap, sfm_cpu, liff_cli.cpu


def scaling(folder, sizes, workers: int):
    """Per N: (N, pairs, match_by_pose seconds) on ``workers`` processes."""
    from liff import colmap
    from liff.cli.colmap import features_for_colmap
    from liff.keypoint_rows import rows_to_keypoints

    out = []
    for n in sizes:
        paths, feature_paths, _ = make_poses(folder, n)
        images = []
        for path in feature_paths:
            view, rows, descriptors = features_for_colmap(path, {}, False, {})
            images.append(colmap.FeatureImage(os.path.basename(path)[:-4] + ".png", view,
                                              rows_to_keypoints(rows), descriptors))
        database = os.path.join(folder, f"scaling{n}.db")
        colmap.write_database(database, os.path.join(folder, f"scaling{n}"), images,
                              focal=CAMERA.focal_length, principal_point=CAMERA.principal_point)
        kwargs = {} if workers == 1 else {"workers": workers}
        start = time.perf_counter()
        poses = colmap.match_by_pose(database, images, CAMERA, **kwargs)
        out.append((n, len(poses), time.perf_counter() - start))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=5, help="captures of the main scene (default 5)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="liff sfm --workers runs")
    parser.add_argument("--scaling", type=int, nargs="*", default=[3, 5, 8],
                        help="capture counts for the growth table (none: skip)")
    parser.add_argument("--features", type=int, nargs="*", default=[150, 300, 600],
                        help="features kept per capture for the feature-growth table (none: skip)")
    parser.add_argument("--repeats", type=int, default=3, help="timings per measurement (best or median)")
    parser.add_argument("--quick", action="store_true",
                        help="--workers 1 --scaling 3 5 --features 300 --repeats 1")
    args = parser.parse_args()
    if args.quick:
        args.workers, args.scaling, args.features, args.repeats = [1], [3, 5], [300], 1
    print(f"# python benchmarks/pose_speed.py {' '.join(sys.argv[1:])}; liff from "
          f"{os.path.dirname(liff.__file__)}, {os.cpu_count()} CPUs, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    with tempfile.TemporaryDirectory() as folder:
        paths, feature_paths, truth = make_poses(folder, args.poses)
        poses_dir = os.path.dirname(paths[0])

        rows = pair_timings(feature_paths, truth, args.repeats)
        print(f"\n## 1. liff.estimate_relative_pose, {len(rows)} pairs of {args.poses} captures "
              f"(best of {args.repeats})\n")
        print("| pair | wall s | CPU s | putative | inliers | t err | R err (deg) |")
        print("|---|---|---|---|---|---|---|")
        for (i, j), r in zip(itertools.combinations(range(args.poses), 2), rows):
            print(f"| {i}-{j} | {r[0]:.3f} | {r[1]:.3f} | {r[2]:.0f} | {r[3]:.0f} | {r[4]:.3f}% | {r[5]:.4f} |")
        print(f"\nwall per pair: median {np.median(rows[:, 0]):.3f} s, max {rows[:, 0].max():.3f} s; CPU median "
              f"{np.median(rows[:, 1]):.3f} s; t err median {np.median(rows[:, 4]):.3f}%, max "
              f"{rows[:, 4].max():.3f}%; R err max {rows[:, 5].max():.4f} deg")
        slope, intercept = np.polyfit(rows[:, 2], rows[:, 1], 1)
        print(f"CPU per pair ~ {intercept:.3f} s + {1e3 * slope:.3f} ms x putative matches (least squares "
              f"over these pairs, {rows[:, 2].min():.0f}-{rows[:, 2].max():.0f} putative)")

        pose, pose_cpu, read, read_cpu = pose_command(folder, feature_paths, args.repeats)
        print(f"\n## 2. liff pose A.npz B.npz --camera ... (fresh processes, median of {args.repeats})\n")
        print(f"liff pose {pose:.2f} s wall, {pose_cpu:.2f} s CPU; import + read both feature files "
              f"{read:.2f} s wall, {read_cpu:.2f} s CPU; beyond reading its inputs {pose - read:.2f} s "
              f"wall, {pose_cpu - read_cpu:.2f} s CPU")

        print("\n## 3. liff sfm --camera against its detection and database step (fresh processes)\n")
        print("| workers | liff sfm s | its pose matching s | liff colmap (detection + database) s | ratio "
              "| CPU s: sfm, colmap, ratio |")
        print("|---|---|---|---|---|---|")
        for w in args.workers:
            sfm, matching, colmap, sfm_cpu, colmap_cpu = sfm_command(folder, poses_dir, w)
            print(f"| {w} | {sfm:.2f} | {matching:.2f} | {colmap:.2f} | {sfm / colmap:.2f} | {sfm_cpu:.2f}, "
                  f"{colmap_cpu:.2f}, {sfm_cpu / colmap_cpu:.2f} |")

        if args.scaling:
            print("\n## 4. Growth with the number of captures (liff.colmap.match_by_pose, 1 process)\n")
            print("| captures N | pairs | seconds | per pair |\n|---|---|---|---|")
            per_pair = []
            for n, pairs, seconds in scaling(folder, args.scaling, 1):
                per_pair.append(seconds / pairs)
                print(f"| {n} | {pairs} | {seconds:.2f} | {seconds / pairs:.3f} |")
            mean = float(np.mean(per_pair))
            print(f"\nN = 100: 4950 pairs, every one matched (exhaustive), ~{4950 * mean / 60:.0f} min on one "
                  f"process at {mean:.3f} s per pair, ~{4950 * mean / 60 / max(os.cpu_count() or 1, 1):.0f} "
                  f"min on {os.cpu_count()} workers")
        if args.features:
            print("\n## 5. Growth with the number of features (pairs of the first 3 captures)\n")
            print("| features kept | features (mean) | putative (mean) | wall s per pair (median) | CPU s |")
            print("|---|---|---|---|---|")
            for k in args.features + [0]:
                _, feature_paths, truth = make_poses(folder, 3, k)
                counts = [len(load_features(p).keypoints) for p in feature_paths]
                rows = pair_timings(feature_paths, truth, args.repeats)
                print(f"| {k or 'all'} | {np.mean(counts):.0f} | {rows[:, 2].mean():.0f} | "
                      f"{np.median(rows[:, 0]):.3f} | {np.median(rows[:, 1]):.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
