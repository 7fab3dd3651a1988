"""Absolute poses of light field captures from their metric relative poses (a pose graph).

Each calibrated pair (i, j) gives a metric relative pose, ``X_j = R_ij X_i + t_ij``
(:func:`liff.estimate_relative_pose`), with the absolute scale that 2-D features lack. The
absolute poses, world to camera ``X_i = R_i X + t_i``, are the ones that agree best with
all of them: for every pair

    rotation residual     r_R = rotvec(R_ij^T R_j R_i^T) / sigma_R,ij
    translation residual  r_t = (t_j - R_j R_i^T t_i - t_ij) / sigma_t,ij

(``R_j R_i^T`` and ``t_j - R_j R_i^T t_i`` are the relative pose the absolute ones predict),
minimised with SciPy's ``least_squares`` under Cauchy's loss, whose pull fades with the
residual, starting from a spanning tree of the most precise pairs (smallest sigma of
the translation, then most inliers); pairs that still disagree far more than the rest
are dropped and the others fitted again (a capture whose every pair is dropped is left
out). A wrong pair is outvoted where other pairs cover the same captures, unless it is more
precise than the right ones it contradicts (it is then in the starting tree). The
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
#: Cauchy loss scale, in standard deviations
LOSS_SCALE = 3.0
#: A pair whose RMS normalised residual exceeds this many times the pairs' median (or 1)
#: is dropped and the rest fitted again, at most OUTLIER_ROUNDS fits in all
OUTLIER_FACTOR = 10.0
OUTLIER_ROUNDS = 3


@dataclass
class PairMeasurement:
    """One relative pose: ``X_second = rotation @ X_first + translation`` (metres), with
    standard deviations of the rotation (radians) and translation (metres), and a
    count of inliers (the spanning tree's tie-break)."""

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
    if not isinstance(pairs, dict) or not pairs:
        raise ValueError(f"pairs is {'empty' if isinstance(pairs, dict) else type(pairs).__name__}; "
                         "expected a dict of (first, second) to PairMeasurement with at least one pair")
    pairs = {_check_key(key): _checked(pair, key) for key, pair in pairs.items()}
    strength: Dict[Hashable, int] = {}
    for (first, second), pair in pairs.items():
        for name in (first, second):
            strength[name] = strength.get(name, 0) + pair.inliers
    if reference is None:
        reference = max(strength, key=lambda name: (strength[name], str(name)))
    elif reference not in strength:
        raise ValueError(f"reference {reference!r} is in no pair; expected one of {sorted(map(str, strength))}")
    # Rounds: fit from the spanning tree, drop the pairs that disagree far more
    # than the rest (a wrong pair still bends a long loop under any loss), fit again.
    active = dict(pairs)
    for _ in range(OUTLIER_ROUNDS):
        initial = _spanning_tree(active, reference)
        if len(initial) == 1:
            return initial
        poses, chi = _fit(active, reference, initial)
        bad = [pair for pair, value in chi.items()
               if value > OUTLIER_FACTOR * max(1.0, float(np.median(list(chi.values()))))]
        if not bad:
            break
        for pair in bad:
            del active[pair]
    return poses


def _fit(pairs, reference, initial):
    """Least squares from ``initial`` over the pairs among its captures: (poses, per-pair
    RMS normalised residual)."""
    order = [reference] + [name for name in initial if name != reference]
    position = {name: k for k, name in enumerate(order)}
    used = [(pair, position[pair[0]], position[pair[1]], p) for pair, p in pairs.items()
            if pair[0] in position and pair[1] in position]
    first = np.array([i for _, i, _, _ in used])
    second = np.array([j for _, _, j, _ in used])
    measured_R = Rotation.from_matrix(np.array([p.rotation for *_, p in used]))
    measured_t = np.array([p.translation for *_, p in used])
    sigma_R = np.array([max(p.sigma_rotation, MIN_SIGMA_ROTATION) for *_, p in used])[:, None]
    sigma_t = np.array([max(p.sigma_translation, MIN_SIGMA_TRANSLATION) for *_, p in used])[:, None]

    def poses(x):  # the reference's pose is fixed at the identity
        x = np.vstack([np.zeros(6), x.reshape(-1, 6)])
        return Rotation.from_rotvec(x[:, :3]), x[:, 3:]

    def residuals(x):
        R, t = poses(x)
        predicted = R[second] * R[first].inv()  # R_j R_i^T
        r_R = (measured_R.inv() * predicted).as_rotvec() / sigma_R
        r_t = (t[second] - predicted.apply(t[first]) - measured_t) / sigma_t
        return np.hstack([r_R, r_t])

    x0 = np.concatenate([np.r_[Rotation.from_matrix(initial[name][0]).as_rotvec(), initial[name][1]]
                         for name in order[1:]])
    # Cauchy's loss: a wrong pair's pull fades with its residual (soft-L1's does not). A
    # dense exact trust region: 6 (N - 1) unknowns, and on a long chain the iterative
    # solver of the sparse one needed 100x the time.
    x = least_squares(lambda x: residuals(x).ravel(), x0, loss="cauchy", tr_solver="exact",
                      f_scale=LOSS_SCALE, x_scale="jac").x
    chi = np.sqrt(np.mean(residuals(x) ** 2, axis=1))
    R, t = poses(x)
    return ({name: (R[k].as_matrix(), t[k].copy()) for name, k in position.items()},
            {pair: float(value) for (pair, *_), value in zip(used, chi)})


def _check_key(key) -> Tuple[Hashable, Hashable]:
    if not (isinstance(key, tuple) and len(key) == 2):
        raise ValueError(f"pair key {key!r}; expected a tuple (first, second) of two capture names")
    if key[0] == key[1]:
        raise ValueError(f"pair {key!r} relates a capture to itself; expected two captures")
    return key


def _checked(pair, name) -> PairMeasurement:
    """The measurement with float64 arrays, checked."""
    if not isinstance(pair, PairMeasurement):
        raise ValueError(f"pair {name!r} is a {type(pair).__name__}; expected a PairMeasurement")
    try:
        R, t = np.asarray(pair.rotation, np.float64), np.asarray(pair.translation, np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"pair {name!r}: rotation and translation must be numeric arrays") from None
    if R.shape != (3, 3) or not np.isfinite(R).all() or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
            or np.linalg.det(R) <= 0:
        raise ValueError(f"pair {name!r}: rotation of shape {R.shape} is not a rotation matrix; "
                         "expected a (3, 3) orthonormal matrix with determinant +1")
    if t.shape != (3,) or not np.isfinite(t).all():
        raise ValueError(f"pair {name!r}: translation {t!r}; expected 3 finite values (metres)")
    sigmas = []
    for label, sigma in (("sigma_rotation", pair.sigma_rotation), ("sigma_translation", pair.sigma_translation)):
        if isinstance(sigma, (bool, np.bool_)) or not isinstance(sigma, (int, float, np.integer, np.floating)) \
                or not (np.isfinite(sigma) and sigma > 0):
            raise ValueError(f"pair {name!r}: {label} = {sigma!r}; expected a positive finite number")
        sigmas.append(float(sigma))
    inliers = pair.inliers
    if isinstance(inliers, (bool, np.bool_)) or not isinstance(inliers, (int, np.integer)) or inliers < 0:
        raise ValueError(f"pair {name!r}: inliers = {inliers!r}; expected a count >= 0")
    return PairMeasurement(R, t, sigmas[0], sigmas[1], int(inliers))


def _precedes(p: PairMeasurement, q: PairMeasurement) -> bool:
    """Whether the tree takes pair p before q: the more precise translation (errors add
    along a chain in metres), then the more inliers."""
    return (p.sigma_translation, -p.inliers) < (q.sigma_translation, -q.inliers)


def _spanning_tree(pairs, reference) -> Dict[Hashable, Tuple[np.ndarray, np.ndarray]]:
    """Poses chained from the reference along the most precise pairs (Prim's algorithm,
    :func:`_precedes`): the least squares' starting point."""
    poses = {reference: (np.eye(3), np.zeros(3))}
    while True:
        best = None
        for (a, b), p in pairs.items():
            if (a in poses) != (b in poses) and (best is None or _precedes(p, best[2])):
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
