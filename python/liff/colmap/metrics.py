"""What a run made, read back from its database and model: the columns of the paper's
SfM table (:func:`table_metrics`) and why each image left out of the model is
(:func:`left_out_images`)."""

from __future__ import annotations

from itertools import combinations
from typing import Dict, List, Optional, Tuple

import numpy as np
import pycolmap

from .database import PathLike, require_database
from .mapping import SfmResult


def table_metrics(database_path: PathLike, result: Optional[SfmResult] = None) -> dict:
    """The paper's SfM table columns for one scene (one database and its reconstruction).

    Definitions (the paper, Sec. 4.3 and Table 1, after Schoenberger et al. 2017); a "match" is one
    correspondence between two images, counted once per image pair:

    - ``keypoints_per_image``: keypoints in the database / images.
    - ``putative_matches_per_image``: matches from the matcher (ratio test, cross check)
      summed over all pairs / images.
    - ``inlier_matches_per_image``: those of them that two-view verification kept (the
      inliers of each pair's geometry, 0 for pairs that failed) / images.
    - ``match_ratio``: "the proportion of detected features that yield putative
      matches": keypoints in at least one putative match / keypoints.
    - ``precision``: "the proportion of putative matches yielding inlier matches":
      inlier matches / putative matches.
    - ``matching_score``: "the proportion of features yielding inlier matches":
      keypoints in at least one inlier match / keypoints.
    - ``points3D``: 3-D points of the reconstructed model (the one with the most
      registered images), 0 if none.
    - ``track_length``: "the mean number of images over which a feature is
      successfully tracked": mean observations per 3-D point of that model.
    - ``passed``: COLMAP produced a model (the paper's "% pass", per scene), which may
      hold as few as two images; ``registered``: fraction of the images in that model.

    Ratios with a zero denominator are NaN.
    """
    with pycolmap.Database.open(require_database(database_path)) as db:
        images = {im.image_id: im for im in db.read_all_images()}
        num_keypoints = {i: db.num_keypoints_for_image(i) for i in images}
        putative_used = {i: np.zeros(n, bool) for i, n in num_keypoints.items()}
        inlier_used = {i: np.zeros(n, bool) for i, n in num_keypoints.items()}
        putative = inliers = 0
        for i, j in combinations(sorted(images), 2):
            pairs = db.read_matches(i, j) if db.exists_matches(i, j) else np.zeros((0, 2))
            good = (db.read_two_view_geometry(i, j).inlier_matches
                    if db.exists_two_view_geometry(i, j) else np.zeros((0, 2)))
            for found, used in ((pairs, putative_used), (good, inlier_used)):
                matches = np.asarray(found, dtype=np.int64).reshape(-1, 2)
                used[i][matches[:, 0]] = True
                used[j][matches[:, 1]] = True
            putative += len(pairs)
            inliers += len(good)
    n_images, n_keypoints = len(images), sum(num_keypoints.values())
    ratio = lambda a, b: float(a) / b if b else float("nan")  # noqa: E731
    best = result.best if result is not None else None
    has_points = best is not None and best.num_points3D() > 0
    return {
        "passed": bool(result is not None and result.success),
        "registered": ratio(best.num_reg_images(), n_images) if best is not None else 0.0,
        "keypoints_per_image": ratio(n_keypoints, n_images),
        "putative_matches_per_image": ratio(putative, n_images),
        "inlier_matches_per_image": ratio(inliers, n_images),
        "match_ratio": ratio(sum(u.sum() for u in putative_used.values()), n_keypoints),
        "precision": ratio(inliers, putative),
        "matching_score": ratio(sum(u.sum() for u in inlier_used.values()), n_keypoints),
        "points3D": best.num_points3D() if best is not None else 0,
        "track_length": (best.compute_mean_track_length() if has_points and best is not None
                         else float("nan")),
    }


def left_out_images(database_path: PathLike, result: Optional[SfmResult] = None) -> List[Tuple[str, str]]:
    """Each image of the database outside the largest model, with why, in database order.

    The first reason that holds, checked in the order a feature goes through the pipeline:

    - ``"no features (0 keypoints)"``: nothing to match (a blank or featureless capture,
      or thresholds too strict for it);
    - ``"no verified match with any other image"``: its keypoints matched no other image
      well enough for two-view geometry (the most putative matches with one image are
      named; too little overlap, or another scene);
    - ``"in another model"``: COLMAP put it in a smaller model, not joined to the
      largest (the images it was verified with are in that model too);
    - ``"verified with ... but not registered"``: it has verified pairs (the strongest is
      named), but the mapper could not register it (too few of those inliers seen in the
      model's 3-D points, or too little baseline).

    Parameters
    ----------
    database_path : str or os.PathLike
        A database that :func:`write_database` wrote and :func:`match` or
        :func:`match_by_pose` matched.
    result : SfmResult, optional
        What :func:`reconstruct` or :func:`reconstruct_from_poses` returned; without one
        (or without a model) every image is left out.

    Returns
    -------
    list of (str, str)
        (image name, reason) for each image not in ``result.best``; empty when all are in.
    """
    best = result.best if result is not None else None
    registered = {best.image(i).name for i in best.reg_image_ids()} if best is not None else set()
    others = [{model.image(i).name for i in model.reg_image_ids()}
              for model in (result.reconstructions.values() if result is not None else ())
              if model is not best]
    with pycolmap.Database.open(require_database(database_path)) as db:
        images = {im.image_id: im.name for im in db.read_all_images()}
        keypoints = {i: db.num_keypoints_for_image(i) for i in images}
        matched: Dict[int, Dict[str, int]] = {i: {} for i in images}   # image id -> {other name: putative matches}
        verified: Dict[int, Dict[str, int]] = {i: {} for i in images}  # image id -> {other name: inlier matches}
        for i, j in combinations(sorted(images), 2):
            putative = db.read_matches(i, j).shape[0] if db.exists_matches(i, j) else 0
            inliers = (db.read_two_view_geometry(i, j).inlier_matches.shape[0]
                       if db.exists_two_view_geometry(i, j) else 0)
            for a, b in ((i, j), (j, i)):
                if putative:
                    matched[a][images[b]] = putative
                if inliers:
                    verified[a][images[b]] = inliers
    out = []
    for i, name in sorted(images.items()):
        if name in registered:
            continue
        if keypoints[i] == 0:
            reason = "no features (0 keypoints)"
        elif not verified[i]:
            most = max(matched[i].items(), key=lambda kv: kv[1], default=None)
            reason = (f"no verified match with any other image ({keypoints[i]} keypoints; "
                      + (f"the most putative matches, {most[1]}, with {most[0]}" if most
                         else "no putative matches") + ")")
        elif any(name in model for model in others):
            size = next(len(model) for model in others if name in model)
            reason = f"in another model of {size} images, not joined to the largest"
        else:
            strongest = max(verified[i].items(), key=lambda kv: kv[1])
            reason = (f"verified with {len(verified[i])} image(s) (the most inliers, {strongest[1]}, "
                      f"with {strongest[0]}) but not registered by the mapper")
        out.append((name, reason))
    return out
