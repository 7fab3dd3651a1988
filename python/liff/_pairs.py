"""The pose estimates of :func:`liff.colmap.match_by_pose`, one per image pair, in this
process or in worker processes (``concurrent.futures``; each worker receives every
image's features once, then pair indices). Every pair is estimated with the same seed,
so the poses do not depend on the number of workers or the order pairs finish in."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor, as_completed

import numpy as np

from ._processes import stop_now
from .keypoint_rows import rows_to_keypoints
from .pose import PoseEstimationError, estimate_relative_pose


def _pair_pose(first, second, camera, ratio: float, seed: int):
    """One pair's (R, t, inlier index pairs (k, 2) uint32, covariance), or None where
    :func:`liff.estimate_relative_pose` finds no pose. ``first`` and ``second`` are
    (keypoint rows, descriptors): arrays, which worker processes can receive."""
    try:
        R, t, matches, details = estimate_relative_pose(
            rows_to_keypoints(first[0]), first[1], rows_to_keypoints(second[0]), second[1],
            camera, ratio=ratio, seed=seed, return_details=True)
    except PoseEstimationError:
        return None
    pairs = np.array([(m.queryIdx, m.trainIdx) for m in matches], np.uint32).reshape(-1, 2)
    return R, t, pairs, details.covariance


#: a worker process's images for :func:`_worker_pair_pose` (set by its initializer)
_WORKER_IMAGES: list = []


def _init_pair_worker(images) -> None:
    global _WORKER_IMAGES
    _WORKER_IMAGES = images


def _worker_pair_pose(i: int, j: int, camera, ratio: float, seed: int):
    return _pair_pose(_WORKER_IMAGES[i], _WORKER_IMAGES[j], camera, ratio, seed)


def pair_poses(features, pairs, camera, ratio, seed, workers: int, progress) -> list:
    """The pose of every pair of images.

    Parameters
    ----------
    features : list of (ndarray (N_i, 7), ndarray (N_i, 128))
        Each image's keypoint rows (:func:`liff.keypoint_rows.keypoints_to_rows`) and
        descriptors.
    pairs : list of (int, int)
        Indices into ``features``: (first, second) as COLMAP orders them.
    camera : liff.LightFieldCamera
    ratio : float
        Lowe's ratio for the putative matches.
    seed : int
        RANSAC's seed, the same for every pair.
    workers : int
        Processes (1: this one).
    progress : callable or None
        Called with no argument as each pair is done (in the order they finish).

    Returns
    -------
    list
        Per pair, in the order of ``pairs``: (R (3, 3), t (3,) metres, inlier index
        pairs (k, 2) uint32, covariance (6, 6)), or None where no pose was found.
    """
    results = [None] * len(pairs)
    if workers <= 1 or len(pairs) <= 1:
        for k, (i, j) in enumerate(pairs):
            results[k] = _pair_pose(features[i], features[j], camera, ratio, seed)
            if progress is not None:
                progress()
        return results
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_init_pair_worker, initargs=(features,))
    try:
        futures = {pool.submit(_worker_pair_pose, i, j, camera, ratio, seed): k
                   for k, (i, j) in enumerate(pairs)}
        for future in as_completed(futures):
            results[futures[future]] = future.result()
            if progress is not None:
                progress()
    except BaseException:  # Ctrl-C, SIGTERM or a worker's error: stop now, not after the queue
        stop_now(pool)
        raise
    pool.shutdown()
    return results
