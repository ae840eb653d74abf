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

``lower_S`` moves a state along ``grad S`` down to its limit plus round-off:
near such an equilibrium H and S are locked, and a step that restores a few
ulps of H raises S with it (the discrete-gradient step's anchor, the pull back
of a composed step); it gives back the part beyond an ulp of the terms of S.
"""

import numpy as np

from .jit import hot, inner
from .layout import EPS, SQRT_EPS
from .roundoff import kept, origin_terms, term_scale
from .vec3 import as_vector, axpy, dot, load, norm_inf


@inner
def rise_tolerance(S_old, S_new, grad_s, x, base):
    """Round-off in ``S(x') - S(x)``: ``2 eps max(|S|, |S'|, |grad S|_inf |x|_inf, base)``, ``base`` the
    constant and linear terms of S (``discrete_gradient.origin_terms``)."""
    return 2.0 * EPS * max(abs(S_old), abs(S_new), norm_inf(grad_s) * norm_inf(x), base)


@hot
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


@inner
def project_both(model, buf, x, H_target, S_target, max_iter, reach):
    """``(y, H(y), S(y), converged, iterations)``: ``y = x + lambda grad H(x) + mu grad S(x)``
    with ``H(y) = H_target`` and ``S(y) = S_target``, by Newton's method on ``(lambda, mu)``.

    Not converged as soon as an update moves y farther than ``reach`` (inf: no limit): near an equilibrium of
    the gradient part the Gram matrix is nearly singular and the nearest such point, if any, is far away.
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
        update = abs(d_lam) * norm_inf(dh) + abs(d_mu) * norm_inf(ds)
        if update > reach:
            return y, H_y, S_y, False, iteration
        lam -= d_lam
        mu -= d_mu
        y = axpy(mu, ds, axpy(lam, dh, x))
        load(buf, y)
        H_y, S_y = H(buf, params), S(buf, params)
        if update <= 4.0 * EPS * size or (update >= 0.5 * previous and update <= SQRT_EPS * size):
            return y, H_y, S_y, True, iteration  # converged, or stopped shrinking at the round-off floor
        previous = update
    return y, H_y, S_y, False, max_iter


#: S above its limit by more than this many ulps of its terms is lowered back (``lower_S``): about the rounding of
#: S at a state (``projection.rise_tolerance`` allows 2 ulps of ``|grad S|_inf |x|_inf``: 4 ulps of S on the rigid body)
S_CAP_ULPS = 1.0


@inner
def lower_S(model, buf, y, H_y, S_y, S_limit, H_target, H_allowed):
    """``(y', H(y'), S(y'), evaluations)``: where S exceeds ``S_limit`` by more than ``S_CAP_ULPS`` ulps of its terms
    (the allowance), ``y`` moved along ``grad S(y)`` down to half the allowance above ``S_limit`` (first order: a
    move of a few ulps), provided S fell and ``|H(y') - H_target|`` stays within ``H_allowed``; else ``y``.

    Where grad S || grad H (an equilibrium of the gradient part: a state at rest at the stable pole), H and S are
    locked together, and a step that restores a few ulps of H towards H(x0) raises S by as many: this gives back
    the part of that move which raised S beyond round-off, so H rejoins H(x0) over a few steps (S rising by at most
    the allowance each) instead of in one step that raises S by 4-6 ulps.  Elsewhere it costs H nothing to first
    order (moving along grad S changes H by ``grad H . grad S / |grad S|^2`` per unit of S).
    """
    p = model.params
    load(buf, y)
    grad_s = as_vector(model.grad_S(buf, p))
    allowance = S_CAP_ULPS * EPS * term_scale(S_limit, S_y, grad_s, y, origin_terms(model.origin, 4, y))
    norm2 = dot(grad_s, grad_s)
    if S_y - S_limit <= allowance or not (norm2 > 0.0 and np.isfinite(norm2)):
        return y, H_y, S_y, 1
    z = axpy((S_limit + 0.5 * allowance - S_y) / norm2, grad_s, y)
    load(buf, z)
    H_z, S_z = model.H(buf, p), model.S(buf, p)
    if S_z < S_y and abs(H_z - H_target) <= H_allowed:
        return z, H_z, S_z, 2
    return y, H_y, S_y, 2


@inner
def on_level(model, buf, y, H_y, S_y, anchor, S_x):
    """``y`` is on ``H = anchor`` as a projection must leave it (64 ulp of the terms of H) and S has
    not risen beyond round-off (False where H or S is not known, as after an RK4 step)."""
    if not (np.isfinite(H_y) and np.isfinite(S_y)):
        return False
    load(buf, y)
    grad_h = as_vector(model.grad_H(buf, model.params))
    grad_s = as_vector(model.grad_S(buf, model.params))
    return kept(
        anchor, H_y, term_scale(anchor, H_y, grad_h, y, origin_terms(model.origin, 0, y)), 64.0, 0.0
    ) and S_y - S_x <= rise_tolerance(S_x, S_y, grad_s, y, origin_terms(model.origin, 4, y))


@hot
def project_step(model, buf, y, H_y, S_y, anchor, S_x, max_iter):
    """A step's result ``y`` (with ``H(y)``, ``S(y)`` or NaN) moved onto ``{H = anchor, S <= S_x}``.

    ``project_energy`` first; where that leaves S above ``S_x`` beyond round-off,
    ``project_both``.  Near an equilibrium of the gradient part (grad S || grad H)
    the 2x2 system is nearly singular; there the step's own state is kept if it
    already meets both conditions (an energy-exact base).  Returns
    ``(y, H(y), S(y), projected, evaluations)``; ``projected`` is False when no
    such point was found.
    """
    y_step, H_step, S_step = y, H_y, S_y
    y, H_y, it = project_energy(model, buf, y, anchor, max_iter)
    evaluations = it + 2
    grad_h = as_vector(model.grad_H(load(buf, y), model.params))
    if not kept(anchor, H_y, term_scale(anchor, H_y, grad_h, y, origin_terms(model.origin, 0, y)), 64.0, 0.0):
        return y, H_y, S_y, False, evaluations
    S_y = model.S(load(buf, y), model.params)
    grad_s = as_vector(model.grad_S(buf, model.params))
    if S_y - S_x > rise_tolerance(S_x, S_y, grad_s, y, origin_terms(model.origin, 4, y)):
        y, H_y, S_y, converged, it = project_both(model, buf, y, anchor, S_x, max_iter, np.inf)
        evaluations += it + 1
        if not converged and on_level(model, buf, y_step, H_step, S_step, anchor, S_x):
            y, H_y, S_y, converged = y_step, H_step, S_step, True
        if not converged:
            return y, H_y, S_y, False, evaluations
    return y, H_y, S_y, True, evaluations
