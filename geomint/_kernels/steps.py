"""One step of each method family, all with the same calling convention.

``step(code, model..., eps, hamiltonian, coeffs, iopts, buf, x, H_x, S_x, h)`` returns
``(x_new, H_new, S_new, status, newton_iterations, field_evaluations, residual)``.
``code`` names the family, ``coeffs``/``iopts`` carry the method's data (see
``geomint.integrators``) and ``buf`` is a length-3 work array.  ``status`` is ``OK`` or one of the failure codes below.
"""

import numpy as np
from numba import njit

from .discrete_gradient import discrete_field
from .field import ZERO, field
from .vec3 import add, axpy, is_finite, load, norm_inf, same, scale, solve, sub

# families
RK4 = 0
DISCRETE_GRADIENT = 1

# step status
OK = 0
NEWTON_FAILED = -1
NON_FINITE = -2

# iopts layout for DISCRETE_GRADIENT
DG_KIND = 0
DG_MAX_ITER = 1
DG_DAMPED = 2
DG_COMPENSATED = 3

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
def _jacobian(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0):
    """Columns of ``D xi(x)`` by forward differences (3 field calls); ``f0 = xi(x)``."""
    size = norm_inf(x)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    c0 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0] + delta, x[1], x[2])), f0))
    c1 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0], x[1] + delta, x[2])), f0))
    c2 = scale(1.0 / delta, sub(field(grad_H, grad_S, J, params, eps, hamiltonian, buf, (x[0], x[1], x[2] + delta)), f0))
    return c0, c1, c2


@njit(inline="always")
def _matrix(a, c0, c1, c2):
    """Rows of ``I + a C`` for the matrix ``C`` with columns ``c0, c1, c2``."""
    return (
        (1.0 + a * c0[0], a * c1[0], a * c2[0]),
        (a * c0[1], 1.0 + a * c1[1], a * c2[1]),
        (a * c0[2], a * c1[2], 1.0 + a * c2[2]),
    )


@njit(inline="always")
def _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0, h):
    """Rows of ``I - h/2 D xi(x)``."""
    c0, c1, c2 = _jacobian(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0)
    return _matrix(-0.5 * h, c0, c1, c2)


@njit(inline="always")
def _discrete_newton_matrix(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, x_new, F, h):
    """Rows of ``I - h D_x' F(x, x')``, the exact Newton matrix, by forward differences (3 discrete fields)."""
    size = norm_inf(x_new)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    c0 = c1 = c2 = ZERO
    for i in range(3):
        shifted = (x_new[0] + (delta if i == 0 else 0.0), x_new[1] + (delta if i == 1 else 0.0), x_new[2] + (delta if i == 2 else 0.0))
        column = scale(1.0 / delta, sub(discrete_field(
            kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, shifted
        )[0], F))
        if i == 0:
            c0 = column
        elif i == 1:
            c1 = column
        else:
            c2 = column
    return _matrix(-h, c0, c1, c2)


@njit(inline="always")
def _at_round_off(f_old, f_new, gradient, size, rising_only):
    """``F(x') - F(x)`` (or ``|F(x') - F(x)|``) within 16 ulp of the terms ``max(|F|, |dgF| |x|)``."""
    change = f_new - f_old if rising_only else abs(f_new - f_old)
    return change <= 16.0 * EPS * max(abs(f_old), abs(f_new), norm_inf(gradient) * size)


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
def kahan_add(x, d, carry):
    """``(x', carry')``: ``x' = fl(x + (d - carry))`` and the part of it rounded away (Kahan's summation).

    Kahan, Further remarks on reducing truncation errors, Comm. ACM 8 (1965) 40,
    doi:10.1145/363707.363723; Higham, Accuracy and Stability of Numerical
    Algorithms, section 4.3.  ``x' - carry'`` equals ``x - carry + d`` to the
    round-off of ``d``, not of ``x``.
    """
    y = sub(d, carry)
    x_new = add(x, y)
    return x_new, sub(sub(x_new, x), y)


@njit
def discrete_gradient_increment(
    kind, max_iter, damped, compensated, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, carry,
    H_x, S_x, h,
):
    """Solve ``d = h F(x, x')``, ``x' = fl(x + (d - carry))`` (see ``discrete_field``), by Newton's method.

    Returns ``(x', carry', H(x'), S(x'), status, iterations, evaluations, residual)``:
    the state ``x - carry`` advanced by the increment ``d`` with compensated
    summation (``kahan_add``), so that the digits of ``d`` that ``x'`` rounds
    away are kept in ``carry'`` for the next step.  The discrete gradients are
    evaluated at the pair of stored states ``(x, x')``, so the evaluation errors
    of H telescope along the run.  With ``compensated`` false, ``carry`` is
    ignored and ``carry' = 0``.

    Newton matrix ``I - h/2 D xi`` (the implicit-midpoint Jacobian, exact for
    quadratic H and S) at ``x``; start from the linearly implicit midpoint
    predictor.  Converged when ``x'`` is a fixed point in floating point
    (``x - carry + h F(x, x')`` rounds to ``x'``) or the Newton correction is
    within 4 ulp.  Either way the step returns the state ``x'`` at which the
    discrete gradients were *evaluated*, with the increment ``d = h F(x, x')``
    of that pair and ``carry' = (x' - x) - (d - carry)``: the value ``H(x')``
    of the identity ``dgH . dx = H(x') - H(x)`` is the one the next step starts
    from, so the evaluation errors of H telescope, and the few ulp between x'
    and ``x - carry + d`` are carried, not lost.  (Returning the state
    *corrected* after its last evaluation lets the energy error random-walk
    by ~1 ulp per step.)

    When the corrections stop shrinking (ratio >= 1/2) the iterate is accepted
    only if it is within sqrt(eps) of converging *and* H and S are already
    exact at it (``|dH|``, ``dS`` rise within 16 ulp of the terms): the noise
    floor of the discrete gradient, whose quotient carries round-off
    ~ eps |H| / |dx|.  Otherwise the Newton matrix is replaced by the exact
    ``I - h D_x' F`` (forward differences of the discrete field) at the iterate.

    Fails after ``max_iter`` iterations or on a non-finite iterate.  With
    ``damped`` the dissipation is scaled by ``damping_factor`` (stiff problems).
    """
    if not compensated:
        carry = ZERO
    if damped:
        eps = eps * damping_factor(grad_H, grad_S, J, params, eps, buf, x, h)
    f0 = field(grad_H, grad_S, J, params, eps, hamiltonian, buf, x)
    m = _newton_matrix(grad_H, grad_S, J, params, eps, hamiltonian, buf, x, f0, h)
    d = solve(m, scale(h, f0))
    evaluations = 4
    previous = np.inf
    for iteration in range(1, max_iter + 1):
        x_new, carry_new = kahan_add(x, d, carry)
        F, H_new, S_new, dg_h, dg_s, axial_bar = discrete_field(
            kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, x_new
        )
        evaluations += 1
        exact = scale(h, F)
        correction = solve(m, sub(d, exact))
        error = norm_inf(correction)
        size = max(norm_inf(x_new), norm_inf(d))
        if same(kahan_add(x, exact, carry)[0], x_new) or error <= 4.0 * EPS * size:
            carry_exact = sub(sub(x_new, x), sub(exact, carry)) if compensated else ZERO
            return x_new, carry_exact, H_new, S_new, OK, iteration, evaluations, error
        if error >= 0.5 * previous:
            if (
                error <= SQRT_EPS * size
                and _at_round_off(H_x, H_new, dg_h, size, False)
                and _at_round_off(S_x, S_new, dg_s, size, True)
            ):
                return x_new, carry_new, H_new, S_new, OK, iteration, evaluations, error
            m = _discrete_newton_matrix(
                kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_x, S_x, x_new, F, h
            )
            evaluations += 3
            correction = solve(m, sub(d, exact))
            error = norm_inf(correction)
        d = sub(d, correction)
        x_new, carry_new = kahan_add(x, d, carry)
        if not (np.isfinite(error) and is_finite(x_new)):
            return x_new, carry_new, H_new, S_new, NON_FINITE, iteration, evaluations, error
        previous = error
    return x_new, carry_new, H_new, S_new, NEWTON_FAILED, max_iter, evaluations, error


@njit
def compensated_step(code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, carry, H_x, S_x, h):
    """``step`` for the driver's compensated sum: ``(x', carry', H(x'), S(x'), status, iterations, evaluations,
    residual)`` with ``x' - carry'`` the state (see ``discrete_gradient_increment``).

    Discrete-gradient methods carry the digits their increments lose; every
    other family goes through ``step`` and returns ``carry' = 0``.
    """
    if code == DISCRETE_GRADIENT:
        return discrete_gradient_increment(
            iopts[DG_KIND], iopts[DG_MAX_ITER], iopts[DG_DAMPED], iopts[DG_COMPENSATED], coeffs,
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, carry, H_x, S_x, h,
        )
    x_new, H_new, S_new, status, iterations, evaluations, residual = step(
        code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, H_x, S_x, h
    )
    return x_new, ZERO, H_new, S_new, status, iterations, evaluations, residual


@njit
def step(code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, H_x, S_x, h):
    """Advance ``x`` by ``h`` with the method ``(code, coeffs, iopts)``."""
    if code == RK4:
        return rk4_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, h)
    x_new, carry, H_new, S_new, status, iterations, evaluations, residual = discrete_gradient_increment(
        iopts[DG_KIND], iopts[DG_MAX_ITER], iopts[DG_DAMPED], iopts[DG_COMPENSATED], coeffs,
        H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, ZERO, H_x, S_x, h,
    )
    return x_new, H_new, S_new, status, iterations, evaluations, residual
