"""Calibrated light fields: metric depth, metric pose between captures, metric SfM, and
scale-sensitive matching (docs/METRIC.md).

1. Depth on a real scene (HCI, default ../shared/data/hci/cotton): each LiFF feature's
   depth (liff.LightFieldCamera.from_hci) against the ground-truth depth map
   gt_depth_lowres.pfm at its rounded pixel; relative error |Z - Z_gt| / Z_gt.
2. Relative pose of two captures (liff.captures: textured boxes, panels, floor and wall,
   poses along a 40-degree arc), 5x5 and 9x9 views, conditions clean, occluders (a
   fence in front), low contrast (x 0.25) with noise 1e-4 and 1e-3 as benchmarks/sfm.py;
   consecutive poses. liff.estimate_relative_pose is given only the camera (no scale)
   and compared with the true pose: translation error |t - t_true| / |t_true| and
   rotation error (angle of R R_true^T). Beside it: a plain Umeyama fit
   (pycolmap.estimate_rigid3d) on the 3-D points of the same inlier matches; the
   refinement's own first-order standard deviation of |t| (the accuracy that its
   estimated slope and position noise imply); and the slope noise itself, measured
   against depths triangulated from the two captures with the true pose.
3. Metric SfM: COLMAP (liff.colmap; every pair matched by its metric pose,
   liff.colmap.match_by_pose, as liff sfm --camera does, or with --colmap-matching by
   COLMAP's own matching and verification; its default mapper, the permissive one where
   the default makes no model; intrinsics fixed to the calibration) on all poses of each
   capture, scaled to metres with liff.colmap.metric_scale (by the pair poses' baselines
   with pose matching, else by the slopes); the scale error is |s - 1|, s the summed
   distances between the scaled model's camera centres over the true ones. Beside it:
   the same error had the slopes' fit alone set the scale, and the scaled points' depth
   error (median over observations of the least |z / z_true - 1|, z_true the ground-truth
   depths within 5x5 pixels of the keypoint), which shows whether the points are metric too.
4. Scale-sensitive matching: putative matches (ratio 0.8) of consecutive poses with and
   without liff.matching's metric-size test (factors 1.5 and 1.25); a match is correct
   if, triangulated with the true pose, it reprojects within 2 px in both captures and
   both slopes agree with its depth within 0.3 px per view step.

Usage:  python benchmarks/metric.py [--quick] [--scenes N] [--scene DIR] [--automatic]
        [--colmap-matching] [--conditions NAME ...] [--skip-hci]
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
from liff.io import read_hci, read_pfm
from liff.pose import observations

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from lightfields import COTTON  # noqa: E402
from sfm import CONTRAST, CONTRAST_THRESHOLD, NOISE, scene_captures  # noqa: E402  (sfm.py's conditions)

DEFAULT_SCENE = str(COTTON)
SIZE_FACTORS = (1.5, 1.25)
RATIO = 0.8
CORRECT_PX = 2.0
CORRECT_SLOPE = 0.3
#: point_depth_error: ground truth is searched in this window (pixels) around a keypoint
DEPTH_WINDOW = 5
FULL = dict(scenes=3, poses=4, views=((5, 5), (9, 9)), size=(240, 320))
QUICK = dict(scenes=1, poses=3, views=((5, 5),), size=(180, 240))


# --- The one place that chooses the detector's slope range: HCI from parameters.cfg's
# frustum range, captures from their known depths; with --automatic, the detector's own
# automatic range (docs/SLOPES.md).
AUTOMATIC = False
# Metric SfM's matching: "pose" (liff.colmap.match_by_pose, as liff sfm --camera does) or
# "colmap" (COLMAP's exhaustive matching and verification, --colmap-matching).
MATCHING = "pose"


def hci_slopes(scene) -> dict:
    """cotton's frustum is [-2, 2]: 17 slopes across it."""
    if AUTOMATIC:
        return {}
    lo = float(scene.parameters["meta"].get("frustum_disp_min", -2))
    hi = float(scene.parameters["meta"].get("frustum_disp_max", 2))
    return dict(firstSlope=lo, lastSlope=hi, numSlopes=17)


def capture_slopes(capture: captures.Capture) -> dict:
    """The captures' true slopes (Capture.slope_range, from their depth maps: about
    [-1.26, 1.22] from the back wall to the nearest box, up to 2.2 on the fence seen
    obliquely from the arc's ends) with a quarter slope of margin on each side, 8
    slopes per unit slope."""
    if AUTOMATIC:
        return {}
    lo, hi = capture.slope_range()
    lo, hi = lo - 0.25, hi + 0.25
    return dict(firstSlope=lo, lastSlope=hi, numSlopes=int(np.ceil(8 * (hi - lo))) + 1)
# ---------------------------------------------------------------------------------------


def camera_of(capture: captures.Capture) -> liff.LightFieldCamera:
    k = capture.intrinsics
    return liff.LightFieldCamera(k.focal, capture.baseline, (k.cx, k.cy), capture.focus_depth)


def true_relative(capture, i: int, j: int):
    """(R, t) with X_j = R X_i + t, from the capture's world-to-camera poses."""
    a, b = capture.poses[i], capture.poses[j]
    R = b.rotation @ a.rotation.T
    return R, b.translation - R @ a.translation


def rotation_error(R, R_true) -> float:
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(R @ R_true.T)[0])))


def percentiles(values) -> str:
    values = np.asarray(values, float)
    return (f"median {np.median(values):.3g}, p90 {np.percentile(values, 90):.3g}, "
            f"max {values.max():.3g}")


# --- 1. depth on HCI -------------------------------------------------------------------

def hci_depth(folder: str) -> dict:
    scene = read_hci(folder)
    camera = liff.LightFieldCamera.from_hci(folder)
    gt = read_pfm(os.path.join(folder, "gt_depth_lowres.pfm"))
    detector = liff.LiFF.create(**hci_slopes(scene))
    keypoints = detector.detect(scene.light_field)
    z = camera.depth(liff.keypoint_slopes(keypoints))
    xy = np.array([k.pt for k in keypoints]).reshape(-1, 2)
    V, U = gt.shape
    truth = gt[np.clip(np.round(xy[:, 1]).astype(int), 0, V - 1),
               np.clip(np.round(xy[:, 0]).astype(int), 0, U - 1)]
    ok = np.isfinite(z)
    rel = np.abs(z[ok] - truth[ok]) / truth[ok]
    # The toolkit's relation itself, on the whole map: depth of the true disparity.
    relation = np.abs(camera.depth(scene.gt_disparity.ravel()) - gt.ravel()) / gt.ravel()
    return dict(name=os.path.basename(os.path.normpath(folder)), camera=camera, n=len(keypoints),
                with_depth=int(ok.sum()), median=float(np.median(rel)),
                p90=float(np.percentile(rel, 90)), within_1=float(np.mean(rel <= 0.01)),
                relation_max=float(relation.max()), slopes=hci_slopes(scene))


# --- 2-4. captures ---------------------------------------------------------------------

def conditions(seed: int, setup: dict, views):
    """sfm.py's conditions (clean, low contrast + noise, occluders) with these views."""
    return scene_captures(seed, dict(setup, views=views))


def features(capture):
    """LiFF keypoints and descriptors of every pose, on the paper's 8-bit preprocessing
    (liff.colmap.prepare_light_field, as benchmarks/sfm.py) with sfm.py's threshold."""
    detector = liff.LiFF.create(contrastThreshold=CONTRAST_THRESHOLD, **capture_slopes(capture))
    return [detector.detectAndCompute(colmap.prepare_light_field(lf)) for lf in capture.light_fields]


def correct(kp1, kp2, matches, camera, R, t) -> np.ndarray:
    """Whether each match is right: triangulated from the two captures with the true
    pose, it reprojects within CORRECT_PX in both and its slopes agree with its depth
    within CORRECT_SLOPE pixels per view step."""
    if not matches:
        return np.zeros(0, bool)
    o1 = observations([kp1[m.queryIdx] for m in matches])
    o2 = observations([kp2[m.trainIdx] for m in matches])
    X1 = triangulate(o1, o2, camera, R, t)
    X2 = X1 @ R.T + t
    ok = (X1[:, 2] > 0) & (X2[:, 2] > 0)
    for X, o in ((X1, o1), (X2, o2)):
        with np.errstate(invalid="ignore", divide="ignore"):
            uv = X[:, :2] / X[:, 2:] * camera.focal_length + np.asarray(camera.principal_point)
            ok &= np.linalg.norm(uv - o[:, :2], axis=1) < CORRECT_PX
            ok &= np.abs(o[:, 2] - camera.slopes(X[:, 2])) < CORRECT_SLOPE
    return ok


def triangulate(o1, o2, camera, R, t) -> np.ndarray:
    """3-D points (capture 1's frame) of matched observations, from their pixels and
    the true pose (cv2.triangulatePoints): a baseline of metres, not millimetres."""
    K = camera.matrix()
    P1 = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = K @ np.hstack([R, t.reshape(3, 1)])
    X = cv2.triangulatePoints(P1, P2, o1[:, :2].T.astype(np.float64), o2[:, :2].T.astype(np.float64))
    return (X[:3] / X[3]).T


def slope_noise(o1, o2, camera, R, t) -> np.ndarray:
    """Slope errors of capture 1's features against their triangulated depths."""
    return o1[:, 2] - camera.slopes(triangulate(o1, o2, camera, R, t)[:, 2])


def pose_rows(capture, feats, camera):
    rows = []
    for i in range(len(capture.poses) - 1):
        j = i + 1
        R_true, t_true = true_relative(capture, i, j)
        (k1, d1), (k2, d2) = feats[i], feats[j]
        row = dict(pair=(i, j), t_norm=float(np.linalg.norm(t_true)))
        try:
            start = time.time()
            R, t, matches, detail = liff.estimate_relative_pose(k1, d1, k2, d2, camera,
                                                                return_details=True)
            row["seconds"] = time.time() - start
        except liff.PoseEstimationError as error:
            row["error"] = str(error)
            rows.append(row)
            continue
        row.update(t_err=float(np.linalg.norm(t - t_true) / row["t_norm"]),
                   r_err=rotation_error(R, R_true), inliers=len(matches))
        o1 = observations([k1[m.queryIdx] for m in matches])
        o2 = observations([k2[m.trainIdx] for m in matches])
        # The estimator's own uncertainty, from its refinement's Jacobian.
        row["t_sigma"] = detail.translation_sigma / row["t_norm"]
        row["sigma_slope_est"] = detail.sigma_slope
        row["sigma_xy_est"] = detail.sigma_xy
        e = slope_noise(o1, o2, camera, R_true, t_true)
        row["slope_noise"] = float(1.4826 * np.median(np.abs(e - np.median(e))))
        X1, X2 = camera.points_3d([k1[m.queryIdx] for m in matches]), camera.points_3d(
            [k2[m.trainIdx] for m in matches])
        ok = np.isfinite(X1).all(axis=1) & np.isfinite(X2).all(axis=1)
        import pycolmap

        M = np.asarray(pycolmap.estimate_rigid3d(X1[ok], X2[ok]).matrix())
        row.update(umeyama_t=float(np.linalg.norm(M[:, 3] - t_true) / row["t_norm"]),
                   umeyama_r=rotation_error(M[:, :3], R_true))
        rows.append(row)
    return rows


def matching_rows(capture, feats, camera):
    rows = []
    for i in range(len(capture.poses) - 1):
        R, t = true_relative(capture, i, i + 1)
        (k1, d1), (k2, d2) = feats[i], feats[i + 1]
        sizes = (camera.metric_size(k1), camera.metric_size(k2))
        row = {}
        for factor in (None,) + SIZE_FACTORS:
            options = {} if factor is None else dict(metric_sizes=sizes, max_size_factor=factor)
            matches = liff.matching.ratio_matches(d1, d2, RATIO, **options)
            ok = correct(k1, k2, matches, camera, R, t)
            row[factor] = (len(matches), int(ok.sum()))
        rows.append(row)
    return rows


def metric_sfm(capture, feats, camera, workdir: str) -> dict:
    """{"mapper": COLMAP's incremental model scaled by metric_scale, "graph": the model
    from the pair poses (pose matching only)}, each a dict of its errors."""
    images, slopes = [], {}
    for i, ((keypoints, descriptors), lf) in enumerate(zip(feats, capture.light_fields)):
        name = f"pose{i:02d}.png"
        T, S = lf.shape[:2]
        images.append(colmap.FeatureImage(name, lf[T // 2, S // 2], keypoints, colmap.root_sift(descriptors)))
        slopes[name] = liff.keypoint_slopes(keypoints)
    database, image_dir = os.path.join(workdir, "database.db"), os.path.join(workdir, "images")
    colmap.write_database(database, image_dir, images, focal=camera.focal_length,
                          principal_point=camera.principal_point)
    out, pair_poses = {}, None
    if MATCHING == "pose":
        pair_poses = colmap.match_by_pose(database, images, camera)
        # as liff sfm --camera does by default: no scaling, the model is metric
        rec = colmap.reconstruct_from_poses(database, image_dir, os.path.join(workdir, "sparse-graph"),
                                            pair_poses).best
        if rec is None or rec.num_reg_images() < 2:
            out["graph"] = dict(error="no pair pose")
        else:
            fit = colmap.metric_scale(rec, slopes, camera, pair_poses)
            out["graph"] = dict(model_errors(rec, capture), slopes_check=fit.scale_from_slopes - 1.0,
                                baselines_check=fit.scale_from_baselines - 1.0)
    else:
        colmap.match(database)
    for mapper in ("default", "permissive"):  # permissive when the default makes no model
        # the calibrated camera's intrinsics are known and kept (as liff sfm --camera does)
        result = colmap.reconstruct(database, image_dir, os.path.join(workdir, f"sparse-{mapper}"),
                                    mapper, fixed_intrinsics=True)
        rec = result.best
        if rec is not None and rec.num_reg_images() >= 2:
            break
    else:
        out["mapper"] = dict(error=f"COLMAP registered {0 if rec is None else rec.num_reg_images()} images")
        return out
    fit = colmap.metric_scale(rec, slopes, camera, pair_poses)
    colmap.scale_reconstruction(rec, fit.scale)
    errors = model_errors(rec, capture)
    out["mapper"] = dict(errors, mapper=mapper, source=fit.source,
                         slopes_err=abs((1 + errors["scale_signed"]) * fit.scale_from_slopes / fit.scale - 1.0))
    return out


def model_errors(rec, capture) -> dict:
    """scale_err |s - 1|, s the summed distances between the model's camera centres over
    the true ones; registered images; depth_err (point_depth_error)."""
    names = {rec.image(i).name: i for i in rec.reg_image_ids()}
    est, true = [], []
    for i, pose in enumerate(capture.poses):
        name = f"pose{i:02d}.png"
        if name in names:
            est.append(rec.image(names[name]).projection_center())
            true.append(pose.centre)
    est, true = np.array(est), np.array(true)
    pairs = [(a, b) for a in range(len(est)) for b in range(a + 1, len(est))]
    ratio = (sum(np.linalg.norm(est[a] - est[b]) for a, b in pairs)
             / sum(np.linalg.norm(true[a] - true[b]) for a, b in pairs))
    return dict(scale_err=abs(ratio - 1.0), scale_signed=ratio - 1.0, registered=len(est),
                depth_err=point_depth_error(rec, capture))


def point_depth_error(rec, capture, window: int = DEPTH_WINDOW) -> float:
    """Median over the scaled model's observations of min |z / z_true - 1|: z a 3-D
    point's depth in the observing image's frame, z_true the ground-truth depths in the
    window x window pixels around the keypoint (a feature on a depth edge may belong to
    either side)."""
    errors, r = [], window // 2
    for image_id in rec.reg_image_ids():
        image = rec.image(image_id)
        truth = capture.depth_map(int(image.name[4:6]))
        pose = image.cam_from_world()
        R, t = np.asarray(pose.rotation.matrix()), np.asarray(pose.translation)
        for point2D in image.points2D:
            if point2D.has_point3D():
                x, y = np.round(point2D.xy - 0.5).astype(int)  # COLMAP's pixel corners
                patch = truth[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1]
                patch = patch[np.isfinite(patch)]
                if patch.size:
                    z = (R @ rec.point3D(point2D.point3D_id).xyz + t)[2]
                    errors.append(np.min(np.abs(z / patch - 1.0)))
    return float(np.median(errors)) if errors else float("nan")


def run_captures(setup: dict, progress=True):
    out = []
    for views in setup["views"]:
        for seed in range(setup["scenes"]):
            for name, capture in conditions(seed, setup, views):
                if setup.get("conditions") and name not in setup["conditions"]:
                    continue
                camera = camera_of(capture)
                feats = features(capture)
                entry = dict(views=views, seed=seed, condition=name,
                             poses=pose_rows(capture, feats, camera),
                             matching=matching_rows(capture, feats, camera))
                workdir = tempfile.mkdtemp(prefix="liff-metric-")
                try:
                    entry["sfm"] = metric_sfm(capture, feats, camera, workdir)
                finally:
                    shutil.rmtree(workdir, ignore_errors=True)
                out.append(entry)
                if progress:
                    p = entry["poses"]
                    print(f"  {views[0]}x{views[1]} scene {seed} {name}: t err "
                          + ", ".join(f"{100 * r['t_err']:.2f}%" if "t_err" in r else "FAIL" for r in p)
                          + "".join(f"; sfm {kind} " + (f"{100 * r['scale_err']:.2f}%" if "scale_err" in r
                                                         else r["error"]) for kind, r in entry["sfm"].items()),
                          file=sys.stderr, flush=True)
    return out


def sfm_tables(keyed) -> list:
    """Section 3: the model from the pair poses (liff sfm --camera's default) and COLMAP's
    incremental model scaled by metric_scale."""
    lines = []
    graph = any("graph" in e["sfm"] for entries in keyed.values() for e in entries)
    if graph:
        lines += ["", "## 3. Metric SfM from the pair poses (liff.colmap.reconstruct_from_poses, "
                  "not scaled; liff sfm --camera's default)", "",
                  "| views | condition | scenes | scale err median | scale err max | point depth err "
                  "(median) | images registered (min) | check by slopes: max abs | check by baselines: "
                  "max abs | failed |", "|---|---|---|---|---|---|---|---|---|---|"]
        lines += sfm_rows(keyed, "graph", lambda done: (
            f"{100 * max(abs(d['slopes_check']) for d in done):.2f}% | "
            f"{100 * max(abs(d['baselines_check']) for d in done):.2f}%"), 2)
    lines += ["", f"## 3{'b' if graph else ''}. Metric SfM (COLMAP's incremental mapper, scaled by "
              "liff.colmap.metric_scale)", "",
              "| views | condition | scenes | scale err median | scale err max | point depth err "
              "(median) | images registered (min) | scale by | slopes alone: err median | err max | "
              "permissive mapper | failed |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += sfm_rows(keyed, "mapper", lambda done: (
        ", ".join(f"{k} {sum(d['source'] == k for d in done)}" for k in ("baselines", "slopes")
                  if any(d["source"] == k for d in done))
        + f" | {100 * np.nanmedian([d['slopes_err'] for d in done]):.2f}% | "
        f"{100 * np.nanmax([d['slopes_err'] for d in done]):.2f}% | "
        f"{sum(d['mapper'] == 'permissive' for d in done)}"), 4)
    return lines


def sfm_rows(keyed, kind: str, extra, extra_cells: int) -> list:
    lines, errs_all = [], []
    for (views, condition), entries in keyed.items():
        runs = [e["sfm"][kind] for e in entries if kind in e["sfm"]]
        done = [r for r in runs if "scale_err" in r]
        fails = [r["error"] for r in runs if "error" in r]
        errs = [d["scale_err"] for d in done]
        errs_all += errs
        cells = (f"{100 * np.median(errs):.2f}% | {100 * max(errs):.2f}% | "
                 f"{100 * np.nanmedian([d['depth_err'] for d in done]):.2f}% | "
                 f"{min(d['registered'] for d in done)} of {len(entries[0]['poses']) + 1} | {extra(done)}"
                 if done else " | ".join(["-"] * (4 + extra_cells)))
        lines.append(f"| {views[0]}x{views[1]} | {condition} | {len(runs)} | {cells} | "
                     f"{len(fails)}{' (' + '; '.join(fails) + ')' if fails else ''} |")
    if errs_all:
        lines += ["", f"scale error max {100 * max(errs_all):.2f}% over {len(errs_all)} reconstructions "
                  "(target <= 2%)"]
    return lines


def report(hci, results) -> str:
    lines = []
    if hci is not None:
        lines += [f"## 1. Depth on HCI {hci['name']}", "",
                  f"camera from parameters.cfg: {hci['camera']}",
                  f"HCI toolkit relation vs gt_depth_lowres.pfm over the whole map: max relative "
                  f"difference {hci['relation_max']:.2g}",
                  f"LiFF {hci['slopes']}: {hci['n']} features, {hci['with_depth']} with a depth",
                  f"relative depth error: median {100 * hci['median']:.3f}%, p90 "
                  f"{100 * hci['p90']:.2f}%, within 1%: {100 * hci['within_1']:.0f}%  "
                  f"(targets: median <= 0.5%, p90 <= 3%)", ""]
    lines += ["## 2. Relative pose of consecutive captures (no scale given)", "",
              "| views | condition | pairs | failed | inliers (median) | t err median | t err max | "
              "R err max (deg) | Umeyama t err median | Umeyama t err max | predicted sd(|t|) median | "
              "slope noise (px/view) | est. slope sd | est. xy sd (px) |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    keyed = {}
    for e in results:
        keyed.setdefault((e["views"], e["condition"]), []).append(e)
    all_ok = []
    for (views, condition), entries in keyed.items():
        rows = [r for e in entries for r in e["poses"]]
        ok = [r for r in rows if "t_err" in r]
        all_ok += ok
        if not ok:
            lines.append(f"| {views[0]}x{views[1]} | {condition} | {len(rows)} | {len(rows)} |" + " - |" * 10)
            continue
        med = lambda key: float(np.median([r[key] for r in ok]))  # noqa: E731
        mx = lambda key: float(np.max([r[key] for r in ok]))  # noqa: E731
        lines.append(
            f"| {views[0]}x{views[1]} | {condition} | {len(rows)} | {len(rows) - len(ok)} | "
            f"{med('inliers'):.0f} | {100 * med('t_err'):.2f}% | {100 * mx('t_err'):.2f}% | "
            f"{mx('r_err'):.3f} | {100 * med('umeyama_t'):.2f}% | {100 * mx('umeyama_t'):.2f}% | "
            f"{100 * med('t_sigma'):.2f}% | {med('slope_noise'):.4f} | {med('sigma_slope_est'):.4f} | "
            f"{med('sigma_xy_est'):.3f} |")
    failed = sum(1 for e in results for r in e["poses"] if "t_err" not in r)
    if all_ok:
        lines += ["", f"all pairs: {len(all_ok)} estimated, {failed} failed; translation error max "
                  f"{100 * max(r['t_err'] for r in all_ok):.2f}% (target <= 2%), rotation error max "
                  f"{max(r['r_err'] for r in all_ok):.3f} deg (target <= 0.5); Umeyama translation "
                  f"error median {100 * np.median([r['umeyama_t'] for r in all_ok]):.2f}%, max "
                  f"{100 * max(r['umeyama_t'] for r in all_ok):.2f}%; |t| "
                  f"{min(r['t_norm'] for r in all_ok):.2f}-{max(r['t_norm'] for r in all_ok):.2f} m; "
                  f"median time per pose {np.median([r['seconds'] for r in all_ok]):.1f} s"]
    lines += sfm_tables(keyed)
    lines += ["", f"## 4. Scale-sensitive matching (ratio {RATIO}; correct: within {CORRECT_PX:g} px "
              f"and {CORRECT_SLOPE:g} px/view of the true geometry)", "",
              "| views | condition | " + " | ".join(
                  f"{'plain' if f is None else f'size factor {f}'}: putative, correct, precision"
                  for f in (None,) + SIZE_FACTORS) + " |", "|---|---|" + "---|" * (1 + len(SIZE_FACTORS))]
    for (views, condition), entries in keyed.items():
        rows = [r for e in entries for r in e["matching"]]
        cells = []
        for f in (None,) + SIZE_FACTORS:
            put = sum(r[f][0] for r in rows)
            cor = sum(r[f][1] for r in rows)
            cells.append(f"{put}, {cor}, {cor / put if put else float('nan'):.3f}")
        lines.append(f"| {views[0]}x{views[1]} | {condition} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="one small 5x5 scene (a few minutes)")
    parser.add_argument("--scenes", type=int, default=None, help="capture scenes (seeds 0..N-1)")
    parser.add_argument("--scene", default=DEFAULT_SCENE, help="HCI scene folder")
    parser.add_argument("--skip-hci", action="store_true")
    parser.add_argument("--automatic", action="store_true",
                        help="the detector's automatic slope range instead of the known ones")
    parser.add_argument("--conditions", nargs="+", default=None, metavar="NAME",
                        help="only these capture conditions (clean, occluders, "
                             "'low contrast + noise 1e-4', 'low contrast + noise 1e-3')")
    parser.add_argument("--colmap-matching", action="store_true",
                        help="metric SfM on COLMAP's own matching instead of liff.colmap.match_by_pose")
    args = parser.parse_args(argv)
    global AUTOMATIC, MATCHING
    AUTOMATIC = args.automatic
    MATCHING = "colmap" if args.colmap_matching else "pose"
    import pycolmap

    pycolmap.logging.minloglevel = 2
    setup = dict(QUICK if args.quick else FULL)
    if args.scenes:
        setup["scenes"] = args.scenes
    if args.conditions:
        setup["conditions"] = args.conditions
    start = time.time()
    hci = None
    if not args.skip_hci:
        if os.path.isdir(args.scene):
            hci = hci_depth(args.scene)
        else:
            print(f"HCI scene not found at {args.scene}: skipped (pass --scene DIR)", file=sys.stderr)
    results = run_captures(setup)
    conditions_run = (f"conditions {', '.join(setup['conditions'])}" if setup.get("conditions")
                      else f"{len(NOISE) + 2} conditions")
    header = (f"{setup['scenes']} scenes x {conditions_run} x views "
              f"{', '.join(f'{v[0]}x{v[1]}' for v in setup['views'])}; {setup['poses']} poses of "
              f"{setup['size'][1]}x{setup['size'][0]} px on a 40-degree arc; contrastThreshold "
              f"{CONTRAST_THRESHOLD}, low contrast {CONTRAST}; slope ranges "
              f"{'automatic' if AUTOMATIC else 'known (hci_slopes, capture_slopes)'}; "
              f"SfM matching {'by pose (liff.colmap.match_by_pose)' if MATCHING == 'pose' else 'COLMAP'}; "
              f"{time.time() - start:.0f} s")
    print(header + "\n\n" + report(hci, results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
