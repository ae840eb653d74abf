"""One step of each method family, all with the same calling convention.

``step(code, model..., eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, h)``
returns ``(x_new, comp_new, H_new, S_new, status, newton_iterations,
field_evaluations, residual)``.  ``code`` names the family, ``coeffs``/``iopts``
carry the method's data (see ``geomint.integrators``) and ``buf`` is a length-3
work array.  ``status`` is ``OK`` or one of the failure codes below.

Every family computes an increment and lands with ``advance``: compensated
(Kahan) summation, in which ``comp`` carries the rounding error of the state
from step to step, so that round-off in the state does not random-walk.
"""

import numpy as np
from numba import njit

from . import composition
from .discrete_gradient import discrete_field
from .field import ZERO, field
from .vec3 import add, axpy, is_finite, load, norm_inf, scale, solve, sub

# families
RK4 = 0
DISCRETE_GRADIENT = 1
COMPOSED = 10  # splittings, compositions, projections: see composition.py

# step status
OK = 0
NEWTON_FAILED = -1
NON_FINITE = -2

# iopts layout for DISCRETE_GRADIENT (coeffs: AVF's nodes and weights)
DG_KIND = 0
DG_MAX_ITER = 1
DG_DAMPED = 2
DG_COMPENSATED = 3

EPS = np.finfo(np.float64).eps
SQRT_EPS = np.sqrt(EPS)
GUARD = 1024.0


@njit(inline="always")
def advance(H, S, params, buf, x, comp, dx):
    """``x + dx`` by compensated summation; returns ``(x_new, comp_new, H(x_new), S(x_new))``.

    Kahan, Comm. ACM 8 (1965) 40, doi:10.1145/363707.363723; as in Hairer's
    geometric integrators.  ``x + comp`` is the state carried to extra precision.
    """
    y = sub(dx, comp)
    x_new = add(x, y)
    comp_new = sub(sub(x_new, x), y)
    load(buf, x_new)
    return x_new, comp_new, H(buf, params), S(buf, params)


@njit
def rk4_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, comp, h):
    """Classical Runge-Kutta, order 4: the generic, structure-blind baseline."""
    k1 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, x)
    k2 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, axpy(0.5 * h, k1, x))
    k3 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, axpy(0.5 * h, k2, x))
    k4 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, axpy(h, k3, x))
    incr = add(add(k1, k4), scale(2.0, add(k2, k3)))
    x_new, comp_new, H_new, S_new = advance(H, S, params, buf, x, comp, scale(h / 6.0, incr))
    return x_new, comp_new, H_new, S_new, OK, 0, 4, 0.0


@njit(inline="always")
def _jacobian(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0):
    """Columns of ``D xi(x)`` by forward differences (3 field calls); ``f0 = xi(x)``."""
    size = norm_inf(x)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    c0 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0] + delta, x[1], x[2])), f0))
    c1 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0], x[1] + delta, x[2])), f0))
    c2 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0], x[1], x[2] + delta)), f0))
    return c0, c1, c2


@njit(inline="always")
def _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0, h):
    """Rows of ``I - h/2 D xi(x)``."""
    c0, c1, c2 = _jacobian(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0)
    a = -0.5 * h
    return (
        (1.0 + a * c0[0], a * c1[0], a * c2[0]),
        (a * c0[1], 1.0 + a * c1[1], a * c2[1]),
        (a * c0[2], a * c1[2], 1.0 + a * c2[2]),
    )


@njit(inline="always")
def damping_factor(grad_H, grad_S, J, params, eps, buf, x, h):
    """``phi = 1 / sqrt(1 + (h kappa / 2)^2)``, ``kappa = |D (eps xi_g)(x)|_inf`` (4 gradient calls).

    ``eps xi_g`` is differentiated as a whole, so that ``eps`` scales the
    product before it can underflow (states of size 1e-150 with eps ~ 1e150).

    Multiplying the dissipation by ``phi`` (still exact in H, monotone in S)
    makes the midpoint-type step damp a dissipative mode of rate ``lambda ~ kappa``
    by ``(1 - w) / (1 + w)``, ``w = (h lambda / 2) phi -> 1`` as ``h kappa -> oo``,
    instead of reflecting it; ``phi = 1 + O(h^2)`` keeps order 2.
    """
    g0 = field(grad_H, grad_S, J, params, eps, False, buf, x)
    c0, c1, c2 = _jacobian(grad_H, grad_S, J, params, eps, False, buf, x, g0)
    row_sum = max(
        abs(c0[0]) + abs(c1[0]) + abs(c2[0]), abs(c0[1]) + abs(c1[1]) + abs(c2[1]), abs(c0[2]) + abs(c1[2]) + abs(c2[2])
    )
    z = 0.5 * h * row_sum
    if not np.isfinite(z):
        return 1.0
    return 1.0 / np.sqrt(1.0 + z * z)


@njit(inline="always")
def _residual(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h, x_new):
    F = discrete_field(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, x_new)[0]
    return sub(sub(x_new, x), scale(h, F))


@njit
def _residual_matrix(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h, x_new):
    """Rows of the Jacobian of ``R(x') = x' - x - h F(x, x')`` at ``x_new`` (4 discrete-field calls)."""
    r0 = _residual(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h, x_new)
    size = norm_inf(x_new)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    columns = []
    for j in range(3):
        shifted = (x_new[0] + (delta if j == 0 else 0.0), x_new[1] + (delta if j == 1 else 0.0),
                   x_new[2] + (delta if j == 2 else 0.0))
        r = _residual(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h, shifted)
        columns.append(scale(1.0 / delta, sub(r, r0)))
    c0, c1, c2 = columns[0], columns[1], columns[2]
    return ((c0[0], c1[0], c2[0]), (c0[1], c1[1], c2[1]), (c0[2], c1[2], c2[2]))


@njit(inline="always")
def _kept(f_old, f_new, gradient, size, ulps, direction):
    """``F(x') - F(x)`` within ``ulps`` of the terms ``max(|F|, |dgF| |x|)``: in absolute value
    (``direction = 0``), or not rising along ``direction`` (the sign of ``h``)."""
    change = direction * (f_new - f_old) if direction != 0.0 else abs(f_new - f_old)
    return change <= ulps * EPS * max(abs(f_old), abs(f_new), norm_inf(gradient) * size)


@njit
def discrete_gradient_step(
    kind, max_iter, damped, compensated, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, comp,
    H_x, S_x, h,
):
    """Solve ``x' = x + h F(x, x')`` (see ``discrete_field``) by Newton's method to round-off.

    Newton matrix ``I - h/2 D xi(x)`` (the implicit-midpoint Jacobian, exact for
    quadratic H and S near the solution); start from the linearly implicit
    midpoint predictor (explicit Euler where that matrix is nearly singular).
    ``H_x`` is the energy the step keeps: the driver passes H(x0), not H(x_n),
    so that the discrete-gradient identity ``dgH . dx = H(x') - H_x`` pulls
    every step back onto the initial level set and the rounding of the states
    does not random-walk the energy.  ``S_x`` is S(x_n).  The increment lands
    by compensated summation (``advance``) unless ``compensated`` is false.
    With ``damped`` the dissipation is scaled by ``damping_factor`` (stiff
    problems: the midpoint-type step then damps the fast mode instead of
    reflecting it).

    The iteration has converged when the correction is within 4 ulp of the state
    and increment; the root must then keep H and not raise S (not lower it for
    ``h < 0``: the backward sub-steps of a composition) to within ``GUARD``
    ulps of the terms: the scheme guarantees both at the true root, and a
    far-away spurious root, reached from a step far beyond the time scale,
    fails this.  When a correction is not below half the smallest one so far
    (stalled), the Newton matrix becomes the finite-difference Jacobian of the
    discrete residual itself; once that has been done, a stalled correction
    within 16 times the round-off floor (4 ulp of the state plus ``|h|`` times
    the noise the discrete-gradient quotients carry, ~ eps |F| / |dx|), or
    within sqrt(eps) of the state, is the floor of the iteration: the root is
    accepted if H and S are already kept to 16 ulp of their terms there.
    Fails on divergence, on a spurious root, after ``max_iter`` iterations, or
    on a non-finite iterate.
    """
    if not compensated:
        comp = ZERO
    if damped:
        eps = eps * damping_factor(grad_H, grad_S, J, params, eps, buf, x, h)
    f0 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, x)
    m = _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0, h)
    reach = 4.0 * h * norm_inf(f0)
    dx = solve(m, scale(h, f0))
    if not (norm_inf(dx) <= reach):
        dx = scale(h, f0)
    x_new = add(x, dx)
    evaluations = 4
    best = np.inf
    error = 0.0
    refreshed = False
    for iteration in range(1, max_iter + 1):
        F, H_new, S_new, dg_h, dg_s, axial_bar, noise = discrete_field(
            kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, x_new
        )
        evaluations += 1
        correction = solve(m, sub(dx, scale(h, F)))
        dx = sub(dx, correction)
        x_new = add(x, dx)
        error = norm_inf(correction)
        if not (np.isfinite(error) and is_finite(x_new)):
            return x_new, comp, H_new, S_new, NON_FINITE, iteration, evaluations, error
        size = max(norm_inf(x_new), norm_inf(dx))
        floor = 4.0 * EPS * size + 2.0 * abs(h) * noise  # abs: compositions take backward steps
        stalled = error >= 0.5 * best
        converged = error <= 4.0 * EPS * size
        at_floor = stalled and refreshed and (error <= 16.0 * floor or error <= SQRT_EPS * size)
        if converged or at_floor:
            x_new, comp_new, H_new, S_new = advance(H, S, params, buf, x, comp, dx)
            if not compensated:
                comp_new = ZERO
            ulps = GUARD if converged else 16.0
            if _kept(H_x, H_new, dg_h, size, ulps, 0.0) and _kept(S_x, S_new, dg_s, size, ulps, np.sign(h)):
                return x_new, comp_new, H_new, S_new, OK, iteration, evaluations, error
            if converged:
                break  # a spurious root: the invariants the scheme guarantees do not hold
        if error > 1e3 * (norm_inf(x) + reach):
            break  # diverged
        if stalled:
            m = _residual_matrix(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h, x_new)
            evaluations += 4
            refreshed = True
        best = min(best, error)
    return x_new, comp, H_x, S_x, NEWTON_FAILED, iteration, evaluations, error


@njit
def step(code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, h):
    """Advance ``x`` by ``h`` with the method ``(code, coeffs, iopts)``."""
    if code == RK4:
        return rk4_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, comp, h)
    if code == COMPOSED:
        return composition.composed_step(
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, h, 0.0
        )[:8]
    return discrete_gradient_step(
        iopts[DG_KIND], iopts[DG_MAX_ITER], iopts[DG_DAMPED], iopts[DG_COMPENSATED], coeffs,
        H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, comp, H_x, S_x, h,
    )
