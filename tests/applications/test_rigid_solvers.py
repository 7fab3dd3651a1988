"""The closed-form and analytic pieces of liff.pose: the minimal rigid solver, sampling,
MSAC scoring against the exact distances, the local fit's and the bundle adjustment's
analytic Jacobians against finite differences, and the Schur-complement solver against
SciPy's least_squares."""

import cv2
import numpy as np
import pytest

import liff
from liff import _bundle, _rigid
from liff.pose import CHI2_INLIER
from liff.pose.ransac import _transfer_distances
from liff.pose.refine import _Problem

CAMERA = liff.LightFieldCamera(400.0, 0.05, (200.0, 150.0), 5.0)


def random_rotations(rng, count):
    return _rigid.rotations(rng.normal(0, 1.0, (count, 3)))


def scene(rng, n=60, n_wrong=0, sigma=(0.2, 0.02)):
    """Matched observations of random points 2-15 m away, seen from two poses, with noise
    (pixels, pixels per view step) and n_wrong of them re-paired; and the true pose."""
    R = _rigid.rotations(np.array([0.02, -0.2, 0.01]))
    t = np.array([-0.9, 0.05, 0.2])
    Z = rng.uniform(2.0, 15.0, n)
    X1 = np.column_stack([rng.uniform(-0.4, 0.4, (n, 2)) * Z[:, None], Z])
    X2 = X1 @ R.T + t

    def observe(X):
        xy = X[:, :2] / X[:, 2:] * CAMERA.focal_length + CAMERA.principal_point
        return np.column_stack([xy + rng.normal(0, sigma[0], (n, 2)),
                                CAMERA.slopes(X[:, 2]) + rng.normal(0, sigma[1], n)])

    obs1, obs2 = observe(X1), observe(X2)
    if n_wrong:
        obs2[-n_wrong:] = obs2[-n_wrong:][rng.permutation(n_wrong)]
    return obs1, obs2, R, t


def test_minimal_solver_recovers_a_rigid_motion_exactly():
    rng = np.random.default_rng(0)
    R_true = random_rotations(rng, 500)
    t_true = rng.normal(0, 3.0, (500, 3))
    X1 = rng.normal(0, 2.0, (500, 3, 3))  # 500 minimal samples of 3 points
    X2 = np.einsum("hij,hkj->hki", R_true, X1) + t_true[:, None, :]
    R, t = _rigid.rigid_fits(X1, X2)
    assert np.abs(R - R_true).max() < 1e-9 and np.abs(t - t_true).max() < 1e-9
    assert np.allclose(np.linalg.det(R), 1.0)
    # a reflection is never returned: a mirrored sample still gives a rotation
    R, _ = _rigid.rigid_fits(X1[:5], X1[:5] * np.array([1, 1, -1]))
    assert np.allclose(np.linalg.det(R), 1.0)


def test_rotations_match_rodrigues():
    rng = np.random.default_rng(1)
    rvecs = np.vstack([rng.normal(0, 1.0, (20, 3)), rng.normal(0, 1e-9, (3, 3)), np.zeros((1, 3))])
    expected = np.array([cv2.Rodrigues(r.reshape(3, 1))[0] for r in rvecs])
    assert np.abs(_rigid.rotations(rvecs) - expected).max() < 1e-12


def test_sample_triples_are_distinct_and_uniform():
    rng = np.random.default_rng(2)
    samples = _rigid.sample_triples(rng, 7, 70000)
    assert samples.shape == (70000, 3) and samples.min() == 0 and samples.max() == 6
    assert (samples[:, 0] != samples[:, 1]).all() and (samples[:, 0] != samples[:, 2]).all() \
        and (samples[:, 1] != samples[:, 2]).all()
    for column in samples.T:  # each position uniform over the 7 indices
        counts = np.bincount(column, minlength=7)
        assert np.abs(counts / 10000 - 1).max() < 0.05
    with pytest.raises(ValueError, match="m = 2; expected at least 3"):
        _rigid.sample_triples(rng, 2, 1)


def test_msac_scores_equal_the_exact_distances():
    # The bound that skips far-off matches must never change a score or an inlier: the
    # costs and inliers of random and near-true poses, right and re-paired matches,
    # features of different noise, equal those of the exact distances of every match.
    rng = np.random.default_rng(3)
    obs1, obs2, R_true, t_true = scene(rng, 80, 30)
    sigma1 = np.column_stack([rng.uniform(0.1, 1.0, 80), rng.uniform(0.01, 0.1, 80)])
    sigma2 = np.column_stack([rng.uniform(0.1, 1.0, 80), rng.uniform(0.01, 0.1, 80)])
    R = np.concatenate([random_rotations(rng, 200), _rigid.rotations(rng.normal(0, 1e-3, (56, 3))) @ R_true])
    t = np.concatenate([rng.normal(0, 5.0, (200, 3)), t_true + rng.normal(0, 5e-3, (56, 3))])
    scorer = _rigid.TransferScorer(obs1, obs2, sigma1, sigma2, CAMERA, CAMERA, CHI2_INLIER)
    cost, inliers = scorer.scores(R, t)
    d = _transfer_distances(obs1, obs2, sigma1, sigma2, CAMERA, CAMERA, R, t)
    assert np.array_equal(inliers, d < CHI2_INLIER)
    exact = np.minimum(d, CHI2_INLIER).sum(axis=1)
    assert np.allclose(cost[200:], exact[200:], rtol=1e-9, atol=0)
    # a random pose can put a point nearly in capture 2's image plane, where the
    # prediction's covariance has a condition number ~1e12: any two float64 inverses of
    # it (LU there, the adjugate here) then differ in the 4th digit
    assert np.allclose(cost, exact, rtol=1e-4, atol=0)
    assert inliers[200:, :50].mean() > 0.5 and inliers[:200].mean() < 0.2  # both kinds seen


def test_local_fit_jacobian_matches_finite_differences():
    rng = np.random.default_rng(4)
    obs1, obs2, R_true, t_true = scene(rng, 30)
    scorer = _rigid.TransferScorer(obs1, obs2, (0.3, 0.03), (0.3, 0.03), CAMERA, CAMERA, CHI2_INLIER)
    R = _rigid.rotations(np.array([[0.01, 0.02, -0.01]])) @ R_true[None]
    t = t_true[None] + 0.03
    h, i = np.zeros(30, int), np.arange(30)
    e, J = scorer.error_and_pose_jacobian(R, t, h, i)
    numeric = np.empty_like(J)
    step = 1e-6
    for k in range(6):
        delta = np.zeros(6)
        delta[k] = step
        up = scorer.error_and_pose_jacobian(_rigid.rotations(delta[:3])[None] @ R, t + delta[3:], h, i)[0]
        delta[k] = -step
        down = scorer.error_and_pose_jacobian(_rigid.rotations(delta[:3])[None] @ R, t + delta[3:], h, i)[0]
        numeric[:, :, k] = (up - down) / (2 * step)
    assert np.abs(J - numeric).max() <= 1e-5 * np.abs(J).max()


def test_local_fit_reaches_the_pose_of_noise_free_matches():
    rng = np.random.default_rng(5)
    obs1, obs2, R_true, t_true = scene(rng, 40, sigma=(0.0, 0.0))
    scorer = _rigid.TransferScorer(obs1, obs2, (0.3, 0.03), (0.3, 0.03), CAMERA, CAMERA, CHI2_INLIER)
    R0 = _rigid.rotations(rng.normal(0, 0.01, (4, 3))) @ R_true
    t0 = t_true + rng.normal(0, 0.02, (4, 3))
    R, t = scorer.fit(R0, t0, np.ones((4, 40), bool), iterations=20)
    assert np.abs(R - R_true).max() < 1e-7 and np.abs(t - t_true).max() < 1e-7


def bundle_problem(rng, n=25, n_wrong=3):
    obs1, obs2, R, t = scene(rng, n, n_wrong)
    problem = _Problem(obs1, obs2, CAMERA, CAMERA, np.tile([0.2, 0.2, 0.02, 0.2, 0.2, 0.02], (n, 1)))
    rvec = cv2.Rodrigues(R)[0].ravel() + 0.01
    points = np.column_stack([obs1[:, :2], CAMERA.inverse_depth(obs1[:, 2])])
    params = np.concatenate([rvec, t + 0.02, points.ravel()])
    return problem, params


def test_bundle_jacobian_matches_finite_differences():
    problem, params = bundle_problem(np.random.default_rng(6))
    pose, point = problem.blocks(params)
    n, step = problem.n, 1e-7
    numeric = np.empty((n, 6, 6 + 3 * n))
    for k in range(6 + 3 * n):
        delta = np.zeros_like(params)
        delta[k] = step * max(1.0, abs(params[k]))
        difference = problem.residuals(params + delta) - problem.residuals(params - delta)
        numeric[:, :, k] = difference / (2 * delta[k])
    assert np.abs(pose - numeric[:, :, :6]).max() <= 1e-5 * np.abs(pose).max()
    own = numeric[:, :, 6:].reshape(n, 6, n, 3)[np.arange(n), :, np.arange(n)]  # (n, 6, 3)
    assert np.abs(point - own).max() <= 1e-5 * np.abs(point).max()
    others = numeric[:, :, 6:].reshape(n, 6, n, 3).copy()
    others[np.arange(n), :, np.arange(n)] = 0
    assert np.abs(others).max() < 1e-6  # a match's residuals see no other match's point


@pytest.mark.parametrize("loss", ["linear", "cauchy"])
def test_schur_solver_reaches_scipys_minimum(loss):
    from scipy.optimize import least_squares

    # plain least squares on right matches; Cauchy's loss with 3 of 25 re-paired
    problem, params = bundle_problem(np.random.default_rng(7), n_wrong=3 if loss == "cauchy" else 0)
    ours = _bundle.solve(problem, params, loss, f_scale=3.0)
    theirs = least_squares(lambda q: problem.residuals(q).ravel(), params, method="trf", loss=loss,
                           f_scale=3.0, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=500)
    assert abs(ours.cost - theirs.cost) <= 1e-7 * theirs.cost
    assert np.abs(ours.x[:6] - theirs.x[:6]).max() < 1e-5
    if loss == "linear":  # the points for that pose, fitted alone, are the same
        points = _bundle.solve_points(problem, np.concatenate([ours.x[:6], params[6:]]))
        assert np.abs(points - ours.x).max() < 1e-6
    with pytest.raises(ValueError, match="loss = 'huber'; expected 'linear' or 'cauchy'"):
        _bundle.solve(problem, params, "huber")


def _points_with_outliers(rng, n, wrong, noise=0.05):
    """(X1, X2, R, t): n points 5-11 m away moved by a random motion, with 3-D noise
    (metres) and the first ``wrong`` of X2 replaced by unrelated points."""
    X1 = rng.uniform(-3, 3, (n, 3)) + (0, 0, 8)
    R, t = _rigid.rotations(rng.normal(0, 0.3, 3)), rng.normal(0, 1, 3)
    X2 = X1 @ R.T + t + rng.normal(0, noise, (n, 3))
    X2[:wrong] = rng.uniform(-3, 3, (wrong, 3)) + (0, 0, 8)
    return X1, X2, R, t


@pytest.mark.parametrize("wrong", [0, 150, 300])
def test_robust_rigid_fit_finds_the_motion_among_wrong_matches(wrong):
    rng = np.random.default_rng(wrong)
    X1, X2, R, t = _points_with_outliers(rng, 360, wrong)
    R_fit, t_fit, inliers = _rigid.robust_rigid_fit(X1, X2, 0.2, np.random.default_rng(0))
    assert inliers[wrong:].mean() > 0.95 and inliers[:wrong].sum() <= 0.02 * max(wrong, 1)
    assert np.linalg.norm(t_fit - t) < 0.06 and np.abs(R_fit - R).max() < 0.01
    # it is the motion its inliers give (the local optimisation ran)
    R_in, t_in = _rigid.rigid_fits(X1[inliers], X2[inliers])
    assert np.allclose(R_fit, R_in) and np.allclose(t_fit, t_in)


def test_robust_rigid_fit_agrees_with_colmaps():
    """The seed :func:`liff.pose.ransac_pose` gives is the one pycolmap's
    estimate_rigid3d_robust gave, which it replaces (without its 0.06 s import)."""
    import pycolmap  # a test dependency (tests/applications/test_colmap.py)
    for seed, wrong in enumerate((100, 250)):
        X1, X2, _, _ = _points_with_outliers(np.random.default_rng(10 + seed), 300, wrong)
        R, t, inliers = liff.pose.ransac_pose(X1, X2, 0.2, seed)
        options = pycolmap.RANSACOptions()
        options.max_error, options.random_seed = 0.2, seed
        theirs = pycolmap.estimate_rigid3d_robust(X1, X2, options)
        matrix = np.asarray(theirs["tgt_from_src"].matrix())
        assert (inliers == np.asarray(theirs["inlier_mask"], bool)).mean() > 0.99
        assert np.abs(matrix[:, :3] - R).max() < 1e-3 and np.abs(matrix[:, 3] - t).max() < 1e-3


@pytest.mark.parametrize("X1, X2, max_error, message", [
    (np.zeros((2, 3)), np.zeros((2, 3)), 0.1, "expected at least 3"),
    (np.zeros((5, 3)), np.zeros((5, 2)), 0.1, "expected two"),
    (np.full((5, 3), np.nan), np.zeros((5, 3)), 0.1, "non-finite"),
    (np.zeros((5, 3)), np.zeros((5, 3)), 0.0, "max_error"),
])
def test_robust_rigid_fit_refuses_bad_input(X1, X2, max_error, message):
    with pytest.raises(ValueError, match=message):
        _rigid.robust_rigid_fit(X1, X2, max_error, np.random.default_rng(0))


def test_the_pose_command_does_not_import_pycolmap(tmp_path):
    """``liff pose`` pays for no pycolmap import (issue 29: 0.06 of its 0.34 s)."""
    import subprocess
    import sys

    rng = np.random.default_rng(5)
    obs1, obs2, _, _ = scene(rng, n=80)
    code = ("import sys, numpy as np, liff, liff.cli.pose\n"
            f"o1, o2 = np.array({obs1.tolist()}), np.array({obs2.tolist()})\n"
            "camera = liff.LightFieldCamera(400.0, 0.05, (200.0, 150.0), 5.0)\n"
            "X1, X2 = liff.pose.model.back_project(camera, o1), liff.pose.model.back_project(camera, o2)\n"
            "liff.pose.ransac_pose(X1, X2, 0.1)\n"
            "liff.pose.observation_ransac(o1, o2, camera, camera)\n"
            "print('pycolmap' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"
