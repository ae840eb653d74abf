"""Projection onto the energy level set ``H = H0`` without raising S.

``project_energy``: the standard projection ``y = x~ + lambda grad H(x~)`` with the
scalar ``lambda`` from Newton's method on ``H(y) = H0`` (Hairer, Lubich,
Wanner, *Geometric Numerical Integration*, section IV.4).  Moving along
``grad H`` changes S by ``lambda grad S . grad H`` to first order, which may be
positive; when the result has ``S(y) > S_n`` beyond round-off the constraint
``S <= S_n`` is active and ``project_both`` solves the 2x2 Newton system

    y = x~ + lambda grad H(x~) + mu grad S(x~),   H(y) = H0,   S(y) = S_n,

i.e. the closest point (to first order) of ``{H = H0, S <= S_n}``, a set that
holds ``x_n``.  Its Jacobian is the Gram matrix of ``grad H`` and ``grad S``,
singular only where they are parallel (``sigma = 0``: equilibria of the
gradient part, where the feasible set shrinks to the point ``x_n``).
"""

import numpy as np
from numba import njit

from .vec3 import as_vector, axpy, dot, load, norm_inf

EPS = np.finfo(np.float64).eps
SQRT_EPS = np.sqrt(EPS)


@njit(error_model="numpy")
def rise_tolerance(S_old, S_new, grad_s, x, base):
    """Round-off in ``S(x') - S(x)``: ``2 eps max(|S|, |S'|, |grad S|_inf |x|_inf, base)``, ``base`` the
    constant and linear terms of S (``discrete_gradient.origin_terms``)."""
    return 2.0 * EPS * max(abs(S_old), abs(S_new), norm_inf(grad_s) * norm_inf(x), base)


@njit(error_model="numpy")
def project_energy(model, buf, x, target, max_iter):
    """``(y, H(y), iterations)``: ``y = x + lambda grad H(x)`` with ``H(y) = target`` to round-off.

    Newton on the scalar ``lambda``; keeps the iterate with the smallest
    ``|H(y) - target|`` and stops when the residual vanishes or stops shrinking.
    """
    H, grad_H, params = model.H, model.grad_H, model.params
    d = as_vector(grad_H(load(buf, x), params))
    lam = 0.0
    best, best_H = x, H(load(buf, x), params)
    best_res = abs(best_H - target)
    y, H_y = best, best_H
    stalls = 0
    for iteration in range(1, max_iter + 1):
        slope = dot(as_vector(grad_H(load(buf, y), params)), d)
        if best_res == 0.0 or slope == 0.0 or not np.isfinite(slope):
            return best, best_H, iteration - 1
        lam -= (H_y - target) / slope
        y = axpy(lam, d, x)
        H_y = H(load(buf, y), params)
        residual = abs(H_y - target)
        if residual < best_res:
            best, best_H, best_res = y, H_y, residual
            stalls = 0
        else:
            stalls += 1
            if stalls == 2:
                return best, best_H, iteration
    return best, best_H, max_iter


@njit(error_model="numpy")
def project_both(model, buf, x, H_target, S_target, max_iter):
    """``(y, H(y), S(y), converged, iterations)``: ``y = x + lambda grad H(x) + mu grad S(x)``
    with ``H(y) = H_target`` and ``S(y) = S_target``, by Newton's method on ``(lambda, mu)``.
    """
    H, grad_H, S, grad_S, params = model.H, model.grad_H, model.S, model.grad_S, model.params
    load(buf, x)
    dh = as_vector(grad_H(buf, params))
    ds = as_vector(grad_S(buf, params))
    lam, mu = 0.0, 0.0
    y = x
    H_y, S_y = H(buf, params), S(buf, params)
    size = norm_inf(x)
    previous = np.inf
    for iteration in range(1, max_iter + 1):
        load(buf, y)
        gh = as_vector(grad_H(buf, params))
        gs = as_vector(grad_S(buf, params))
        a, b = dot(gh, dh), dot(gh, ds)
        c, d = dot(gs, dh), dot(gs, ds)
        det = a * d - b * c
        if det == 0.0 or not np.isfinite(det):
            return y, H_y, S_y, False, iteration
        r_h, r_s = H_y - H_target, S_y - S_target
        d_lam = (d * r_h - b * r_s) / det
        d_mu = (a * r_s - c * r_h) / det
        lam -= d_lam
        mu -= d_mu
        y = axpy(mu, ds, axpy(lam, dh, x))
        load(buf, y)
        H_y, S_y = H(buf, params), S(buf, params)
        update = abs(d_lam) * norm_inf(dh) + abs(d_mu) * norm_inf(ds)
        if update <= 4.0 * EPS * size or (update >= 0.5 * previous and update <= SQRT_EPS * size):
            return y, H_y, S_y, True, iteration  # converged, or stopped shrinking at the round-off floor
        previous = update
    return y, H_y, S_y, False, max_iter
