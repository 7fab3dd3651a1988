"""Levenberg-Marquardt for the two-capture bundle adjustment of :mod:`liff.pose`, with the
points eliminated by the Schur complement.

The problem (:class:`liff.pose.refine._Problem`) has 6 pose parameters and 3 per match, and
each match's 6 residuals depend only on the pose and its own point, so the normal
equations are an arrow matrix: a 6 x 6 pose block U, a 3 x 3 block V_i per point and
6 x 3 couplings W_i. Eliminating the points (the Schur complement, as in every bundle
adjuster: Triggs et al., "Bundle Adjustment - A Modern Synthesis", 2000, Sec. 6.1;
Hartley and Zisserman, Multiple View Geometry, 2nd ed., A6.3) leaves a 6 x 6 system,
and every per-point quantity is a batch of 3 x 3 arrays: an iteration is a few array
operations over the matches, whatever their number. SciPy's ``least_squares`` (used
before) solved the same problem with a sparse iterative solver (LSMR) at 20-50x the
time; a library bundle adjuster (Ceres, COLMAP's) has no residual in the slope.

Robust losses are applied per residual as SciPy's ``least_squares`` does (``rho(r^2 /
C^2) C^2`` summed, halved): the gradient weighs each residual by ``rho'`` (the robust
cost's exact gradient) and the Gauss-Newton Hessian by ``rho' + 2 r^2 rho''`` (Triggs et
al., Sec. 4.3, as SciPy); steps are accepted only where they lower that cost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._rigid import inverse_spd3

#: Levenberg-Marquardt damping: start, factor on a rejected/accepted step, bounds
_DAMPING = (1e-3, 10.0, 1e-12, 1e12)


@dataclass
class Result:
    """What :func:`solve` returns, as SciPy's ``OptimizeResult`` names it: the parameters
    ``x`` and ``cost`` (half the summed loss of the residuals)."""

    x: np.ndarray
    cost: float
    iterations: int


def _loss(z: np.ndarray, loss: str, f_scale: float):
    """For z = r^2 and SciPy's losses 'linear' and 'cauchy' (``rho(z) = C^2 log(1 + z /
    C^2)``): rho(z) summed and halved; the gradient's weights rho'(z); and the
    Gauss-Newton Hessian's weights ``rho'(z) + 2 z rho''(z)``, at least 1e-10 (Triggs et
    al., Sec. 4.3; SciPy's ``least_squares`` scales residuals and Jacobian by the same)."""
    if loss == "linear":
        ones = np.ones_like(z)
        return 0.5 * float(z.sum()), ones, ones
    if loss == "cauchy":
        c2 = f_scale * f_scale
        u = 1.0 / (1.0 + z / c2)
        return 0.5 * c2 * float(np.log1p(z / c2).sum()), u, np.maximum(u - 2.0 * z / c2 * u * u, 1e-10)
    raise ValueError(f"loss = {loss!r}; expected 'linear' or 'cauchy'")


def solve(problem, params0: np.ndarray, loss: str = "linear", f_scale: float = 3.0,
          max_evaluations: int = 100, xtol: float = 1e-8, ftol: float = 1e-8) -> Result:
    """Minimises ``0.5 sum rho(r^2)`` over the pose and every point of ``problem``.

    Parameters
    ----------
    problem : liff.pose.refine._Problem
        ``residuals(params)`` (n, 6) and ``blocks(params)``: Jacobians (n, 6, 6) on the
        pose and (n, 6, 3) on each match's point.
    params0 : ndarray, shape (6 + 3n,)
        Rotation vector (radians), translation (metres), then (x, y, w) per match.
    loss : 'linear' or 'cauchy'
    f_scale : float
        The robust loss's scale C (in units of the normalised residuals).
    max_evaluations, xtol, ftol : stopping rules as SciPy's ``max_nfev``, ``xtol`` and
        ``ftol``: at most that many residual evaluations; stop when a step changes the
        parameters by less than ``xtol (xtol + |x|)`` or the cost by less than ``ftol``
        times itself.

    Returns
    -------
    Result
    """
    x = np.array(params0, np.float64)
    r = problem.residuals(x)
    cost, gradient_weight, weight = _loss(r * r, loss, f_scale)
    damping, factor, low, high = _DAMPING
    evaluations, iterations = 1, 0
    while evaluations < max_evaluations:
        iterations += 1
        A, B = problem.blocks(x)
        Aw, Bw = A * weight[:, :, None], B * weight[:, :, None]
        U = Aw.reshape(-1, 6).T @ A.reshape(-1, 6)
        V = np.swapaxes(Bw, 1, 2) @ B  # (n, 3, 3)
        W = np.swapaxes(Aw, 1, 2) @ B  # (n, 6, 3)
        rg = r * gradient_weight
        gp = A.reshape(-1, 6).T @ rg.ravel()
        gi = np.einsum("nri,nr->ni", B, rg)
        # Marquardt's scaling from the unweighted Jacobian: a point whose residuals all lie
        # in the loss's flat tail has almost no weighted curvature, and damping scaled by
        # that would let it jump arbitrarily far
        dU, dV = np.einsum("nri,nri->i", A, A), np.einsum("nri,nri->ni", B, B)
        done = False
        while evaluations < max_evaluations:
            # (a point's normal matrix is at least its capture-1 observation's information,
            # so it is never near singular)
            Vi = inverse_spd3(V + (damping * np.maximum(dV, 1e-300))[:, :, None] * np.eye(3))
            WV = W @ Vi  # (n, 6, 3)
            S = (U + np.diag(damping * np.maximum(dU, 1e-300))
                 - WV.transpose(1, 0, 2).reshape(6, -1) @ W.transpose(1, 0, 2).reshape(6, -1).T)
            rhs = -gp + np.einsum("nij,nj->i", WV, gi)
            try:
                dpose = np.linalg.solve(S, rhs)
            except np.linalg.LinAlgError:
                dpose = np.linalg.lstsq(S, rhs, rcond=None)[0]
            dpts = -np.einsum("nij,nj->ni", Vi, gi + np.einsum("nki,k->ni", W, dpose))
            step = np.concatenate([dpose, dpts.ravel()])
            x_new = x + step
            r_new = problem.residuals(x_new)
            evaluations += 1
            cost_new, gradient_new, weight_new = _loss(r_new * r_new, loss, f_scale)
            small_step = np.linalg.norm(step) <= xtol * (xtol + np.linalg.norm(x))
            if np.isfinite(cost_new) and cost_new < cost:
                done = small_step or cost - cost_new <= ftol * cost
                x, r, cost, gradient_weight, weight = x_new, r_new, cost_new, gradient_new, weight_new
                damping = max(damping / factor, low)
                break
            damping *= factor
            if small_step or damping > high:
                done = True
                break
        if done:
            break
    return Result(x, cost, iterations)


def solve_points(problem, params: np.ndarray, max_evaluations: int = 50, xtol: float = 1e-8,
                 ftol: float = 1e-8) -> np.ndarray:
    """``params`` with every point fitted to its own residuals (plain least squares), the
    pose held: n independent 3-parameter problems, solved side by side by
    Levenberg-Marquardt, each with its own damping and stopping."""
    x = np.array(params, np.float64)
    n = (len(x) - 6) // 3
    pts = x[6:].reshape(n, 3)
    r = problem.residuals(x)
    cost = 0.5 * np.einsum("nr,nr->n", r, r)
    damping = np.full(n, _DAMPING[0])
    factor, low, high = _DAMPING[1:]
    active = np.ones(n, bool)
    for _ in range(max_evaluations - 1):
        if not active.any():
            break
        _, B = problem.blocks(x)
        V = np.swapaxes(B, 1, 2) @ B
        g = np.einsum("nri,nr->ni", B, r)
        dV = np.einsum("nii->ni", V)
        step = -np.linalg.solve(V + (damping[:, None] * np.maximum(dV, 1e-300))[:, :, None] * np.eye(3),
                                g[:, :, None])[:, :, 0]
        step[~active] = 0.0
        trial = x.copy()
        trial[6:] += step.ravel()
        r_new = problem.residuals(trial)
        cost_new = 0.5 * np.einsum("nr,nr->n", r_new, r_new)
        better = active & np.isfinite(cost_new) & (cost_new < cost)
        small = np.linalg.norm(step, axis=1) <= xtol * (xtol + np.linalg.norm(pts, axis=1))
        converged = better & ((cost - cost_new <= ftol * cost) | small)
        pts[better] += step[better]
        r[better], cost[better] = r_new[better], cost_new[better]
        damping = np.where(better, np.maximum(damping / factor, low), damping * factor)
        active &= ~(converged | (~better & (small | (damping > high))))
    return x
