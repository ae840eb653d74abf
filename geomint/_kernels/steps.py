"""One step of each method family, all with the same calling convention.

``step(code, model..., eps, hamiltonian, coeffs, iopts, buf, x, H_x, S_x, h)`` returns
``(x_new, H_new, S_new, status, newton_iterations, field_evaluations, residual)``.
``code`` names the family, ``coeffs``/``iopts`` carry the method's data (see
``geomint.integrators``) and ``buf`` is a length-3 work array.  ``status`` is ``OK`` or one of the failure codes below.
"""

import numpy as np
from numba import njit

from . import composition
from .discrete_gradient import discrete_field
from .field import field
from .vec3 import add, axpy, is_finite, load, norm_inf, scale, solve, sub

# families
RK4 = 0
DISCRETE_GRADIENT = 1
COMPOSED = 10  # splittings, compositions, projections: see composition.py

# step status
OK = 0
NEWTON_FAILED = -1
NON_FINITE = -2

# iopts layout for DISCRETE_GRADIENT
DG_KIND = 0
DG_MAX_ITER = 1

EPS = np.finfo(np.float64).eps
SQRT_EPS = np.sqrt(EPS)


@njit(inline="always")
def _with_invariants(H, S, params, buf, x_new, status, iterations, evaluations, residual):
    load(buf, x_new)
    return x_new, H(buf, params), S(buf, params), status, iterations, evaluations, residual


@njit
def rk4_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, h):
    """Classical Runge-Kutta, order 4: the generic, structure-blind baseline."""
    k1 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, x)
    k2 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, axpy(0.5 * h, k1, x))
    k3 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, axpy(0.5 * h, k2, x))
    k4 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, axpy(h, k3, x))
    incr = add(add(k1, k4), scale(2.0, add(k2, k3)))
    x_new = axpy(h / 6.0, incr, x)
    return _with_invariants(H, S, params, buf, x_new, OK, 0, 4, 0.0)


@njit(inline="always")
def _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0, h):
    """Rows of ``I - h/2 D xi(x)``, with ``D xi`` by forward differences (3 field calls)."""
    size = norm_inf(x)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    c0 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0] + delta, x[1], x[2])), f0))
    c1 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0], x[1] + delta, x[2])), f0))
    c2 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0], x[1], x[2] + delta)), f0))
    a = -0.5 * h
    return (
        (1.0 + a * c0[0], a * c1[0], a * c2[0]),
        (a * c0[1], 1.0 + a * c1[1], a * c2[1]),
        (a * c0[2], a * c1[2], 1.0 + a * c2[2]),
    )


@njit
def discrete_gradient_step(kind, max_iter, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h):
    """Solve ``x' = x + h F(x, x')`` (see ``discrete_field``) by Newton's method to round-off.

    Newton matrix ``I - h/2 D xi`` (the implicit-midpoint Jacobian, exact for
    quadratic H and S) at ``x``; start from the linearly implicit midpoint
    predictor.  Converged when the correction is within 4 ulp of the state and
    of the increment.  When the corrections stop shrinking (ratio >= 1/2) the
    iteration has reached the noise floor of the discrete gradient (its
    quotient carries round-off ~ eps |H| / |dx|): that is accepted below
    sqrt(eps) relative; above it the Newton matrix is re-evaluated at the
    current midpoint.  Fails after ``max_iter`` iterations or on a non-finite
    iterate.
    """
    f0 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, x)
    m = _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0, h)
    x_new = add(x, solve(m, scale(h, f0)))
    evaluations = 4
    previous = np.inf
    for iteration in range(1, max_iter + 1):
        F, H_new, S_new, dg_h, dg_s, axial_bar = discrete_field(
            kind, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, x_new
        )
        evaluations += 1
        correction = solve(m, sub(sub(x_new, x), scale(h, F)))
        x_new = sub(x_new, correction)
        error = norm_inf(correction)
        if not (np.isfinite(error) and is_finite(x_new)):
            return x_new, H_new, S_new, NON_FINITE, iteration, evaluations, error
        size = max(norm_inf(x_new), norm_inf(sub(x_new, x)))
        if error <= 4.0 * EPS * size:
            return _with_invariants(H, S, params, buf, x_new, OK, iteration, evaluations, error)
        if error >= 0.5 * previous:
            if error <= SQRT_EPS * size:
                return _with_invariants(H, S, params, buf, x_new, OK, iteration, evaluations, error)
            mid = axpy(0.5, sub(x_new, x), x)
            f_mid = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, mid)
            m = _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, mid, f_mid, h)
            evaluations += 4
        previous = error
    return x_new, H_new, S_new, NEWTON_FAILED, max_iter, evaluations, error


@njit
def step(code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, H_x, S_x, h):
    """Advance ``x`` by ``h`` with the method ``(code, coeffs, iopts)``."""
    if code == RK4:
        return rk4_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, h)
    if code == COMPOSED:
        return composition.composed_step(
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, H_x, S_x, h, 0.0
        )[:7]
    return discrete_gradient_step(
        iopts[DG_KIND], iopts[DG_MAX_ITER], H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, h
    )
