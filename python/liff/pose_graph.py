"""Absolute poses of light field captures from their metric relative poses (a pose graph).

Each calibrated pair (i, j) gives a metric relative pose, ``X_j = R_ij X_i + t_ij``
(:func:`liff.estimate_relative_pose`), with the absolute scale that 2-D features lack. The
absolute poses, world to camera ``X_i = R_i X + t_i``, are the ones that agree best with
all of them: for every pair

    rotation residual     r_R = rotvec(R_ij^T R_j R_i^T) / sigma_R,ij
    translation residual  r_t = (t_j - R_j R_i^T t_i - t_ij) / sigma_t,ij

(``R_j R_i^T`` and ``t_j - R_j R_i^T t_i`` are the relative pose the absolute ones predict),
minimised with SciPy's ``least_squares`` under a soft-L1 loss (one wrong pair does not
bend the rest), starting from a spanning tree of the pairs with the most inliers. The
world frame is the reference capture's camera frame (``R = I``, ``t = 0``). Because the
translations are metric, no scale is left free, unlike the averaging of unit directions
that structure from motion from 2-D features must do.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Hashable, Tuple

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

#: Floor on a pair's standard deviations (radians, metres): a refinement's first-order
#: sigma can be tiny (docs/METRIC.md: a lower bound), and one pair must not pin the rest.
MIN_SIGMA_ROTATION = 1e-4
MIN_SIGMA_TRANSLATION = 1e-4
#: Soft-L1 loss scale, in standard deviations
LOSS_SCALE = 3.0


@dataclass
class PairMeasurement:
    """One relative pose: ``X_second = rotation @ X_first + translation`` (metres), with
    standard deviations of the rotation (radians) and translation (metres), and a
    weight for the spanning tree (inlier count)."""

    rotation: np.ndarray
    translation: np.ndarray
    sigma_rotation: float
    sigma_translation: float
    inliers: int


def absolute_poses(pairs: Dict[Tuple[Hashable, Hashable], PairMeasurement],
                   reference: Hashable = None) -> Dict[Hashable, Tuple[np.ndarray, np.ndarray]]:
    """World-to-camera poses ``(R, t)`` of every capture connected to ``reference``.

    Parameters
    ----------
    pairs : dict of (first, second) to PairMeasurement
        Relative poses of capture pairs (any hashable names).
    reference : hashable, optional
        The capture whose camera frame is the world (default: the one with the most
        inliers over its pairs).

    Returns
    -------
    dict of name to (ndarray (3, 3), ndarray (3,))
        ``X_cam = R @ X_world + t`` in metres, for the captures connected to the
        reference through ``pairs``; the others are left out.

    Raises
    ------
    ValueError
        If ``pairs`` is empty, the reference is in no pair, a pair relates a capture to
        itself, or a measurement is malformed (not a rotation matrix, a translation not
        of 3 finite values, a standard deviation not positive and finite).
    """
    if not pairs:
        raise ValueError("no relative poses; expected at least one pair")
    for (first, second), pair in pairs.items():
        if first == second:
            raise ValueError(f"pair ({first!r}, {second!r}) relates a capture to itself; expected "
                             "two captures")
        _check_measurement(pair, (first, second))
    strength: Dict[Hashable, int] = {}
    for (first, second), pair in pairs.items():
        for name in (first, second):
            strength[name] = strength.get(name, 0) + pair.inliers
    if reference is None:
        reference = max(strength, key=lambda name: (strength[name], str(name)))
    elif reference not in strength:
        raise ValueError(f"reference {reference!r} is in no pair; expected one of {sorted(map(str, strength))}")
    initial = _spanning_tree(pairs, reference)
    names = [name for name in initial if name != reference]
    if not names:
        return initial
    index = {name: k for k, name in enumerate(names)}
    used = [(a, b, p) for (a, b), p in pairs.items() if a in initial and b in initial]

    def unpack(x):
        poses = {reference: (np.eye(3), np.zeros(3))}
        for name, k in index.items():
            poses[name] = (Rotation.from_rotvec(x[6 * k:6 * k + 3]).as_matrix(), x[6 * k + 3:6 * k + 6])
        return poses

    def residuals(x):
        poses, out = unpack(x), []
        for a, b, p in used:
            (Ra, ta), (Rb, tb) = poses[a], poses[b]
            R_pred = Rb @ Ra.T
            out.append(Rotation.from_matrix(p.rotation.T @ R_pred).as_rotvec()
                       / max(p.sigma_rotation, MIN_SIGMA_ROTATION))
            out.append((tb - R_pred @ ta - p.translation) / max(p.sigma_translation, MIN_SIGMA_TRANSLATION))
        return np.concatenate(out)

    x0 = np.concatenate([np.r_[Rotation.from_matrix(initial[name][0]).as_rotvec(), initial[name][1]]
                         for name in names])
    fit = least_squares(residuals, x0, loss="soft_l1", f_scale=LOSS_SCALE, x_scale="jac")
    return unpack(fit.x)


def _check_measurement(pair, name) -> None:
    if not isinstance(pair, PairMeasurement):
        raise ValueError(f"pair {name!r} is a {type(pair).__name__}; expected a PairMeasurement")
    R, t = np.asarray(pair.rotation, np.float64), np.asarray(pair.translation, np.float64)
    if R.shape != (3, 3) or not np.isfinite(R).all() or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
            or np.linalg.det(R) <= 0:
        raise ValueError(f"pair {name!r}: rotation of shape {R.shape} is not a rotation matrix; "
                         "expected a (3, 3) orthonormal matrix with determinant +1")
    if t.shape != (3,) or not np.isfinite(t).all():
        raise ValueError(f"pair {name!r}: translation {t!r}; expected 3 finite values (metres)")
    for label, sigma in (("sigma_rotation", pair.sigma_rotation), ("sigma_translation", pair.sigma_translation)):
        if not (np.isfinite(sigma) and sigma > 0):
            raise ValueError(f"pair {name!r}: {label} = {sigma!r}; expected a positive finite value")


def _spanning_tree(pairs, reference) -> Dict[Hashable, Tuple[np.ndarray, np.ndarray]]:
    """Poses chained from the reference along the pairs with the most inliers (Prim's
    maximum spanning tree): the least squares' starting point."""
    poses = {reference: (np.eye(3), np.zeros(3))}
    while True:
        best = None
        for (a, b), p in pairs.items():
            if (a in poses) != (b in poses) and (best is None or p.inliers > best[2].inliers):
                best = (a, b, p)
        if best is None:
            return poses
        a, b, p = best
        if a in poses:  # X_b = R_ab X_a + t_ab
            Ra, ta = poses[a]
            poses[b] = (p.rotation @ Ra, p.rotation @ ta + p.translation)
        else:  # X_a = R_ab^T (X_b - t_ab)
            Rb, tb = poses[b]
            poses[a] = (p.rotation.T @ Rb, p.rotation.T @ (tb - p.translation))
