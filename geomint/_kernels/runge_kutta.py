"""Explicit Runge-Kutta steps: the classical RK4 and the embedded pairs, alone or projected.

``rk4_step`` is the classical Runge-Kutta method; ``H`` and ``S`` in its
``layout.StepResult`` are NaN (the loop evaluates them where it needs them).

``pair_step`` takes one step of a ``layout.EmbeddedPairStep`` (tableaux in
``geomint.integrators.tableaux``) and returns the error estimate beside the
step: ``e = h [K; xi(x')]^T e_w`` and, for Dormand-Prince 8(5,3), the
lower-order ``e_low``; ``control.error_norm`` turns them into the controller's
norm.  The error is that of the explicit step; the projection that follows
moves by the size of that error (Hairer, Lubich, Wanner, *Geometric Numerical
Integration*, section IV.4), so the estimate also bounds the projected step's
error to leading order.  The stage values are kept in the trajectory's
workspace (``work``), so threads of an ensemble share nothing.

Every step lands with ``vec3.advance`` (compensated summation).
"""

import numpy as np
from numba import njit

from .field import field, field_inlined, non_finite_culprit
from .jit import hot, inner
from .layout import NO_PROJECTION, NON_FINITE, OK, PROJECTION_FAILED, UNKNOWN, StepResult
from .projection import project_step
from .vec3 import ZERO, add, advance, axpy, is_finite, scale


def _rk4_increment_of(xi):
    def increment(model, eps, hamiltonian, buf, x, h):
        """The classical Runge-Kutta increment ``h (k1 + 2 k2 + 2 k3 + k4) / 6``, order 4 (Hairer,
        Norsett, Wanner, *Solving ODEs I*, section II.1).  Four field evaluations, from one call site of
        ``xi`` (a loop over the stages: an inlined field is compiled once, not four times)."""
        k1 = k2 = k3 = k4 = y = x
        for stage in range(4):
            k = xi(model, eps, hamiltonian, buf, y)
            if stage == 0:
                k1 = k
            elif stage == 1:
                k2 = k
            elif stage == 2:
                k3 = k
            else:
                k4 = k
            y = axpy(h if stage == 2 else 0.5 * h, k, x)
        return scale(h / 6.0, add(add(k1, k4), scale(2.0, add(k2, k3))))

    return increment


#: the RK4 increment as a call (starts and error estimates of implicit steps)
rk4_increment = inner(_rk4_increment_of(field))


#: inlined, stages and all, into ``rk4_step``: the explicit baseline runs at the cost of its field evaluations
_rk4_increment_inlined = njit(inline="always")(_rk4_increment_of(field_inlined))


@hot
def rk4_step(model, eps, hamiltonian, buf, x, comp, h):
    """Classical Runge-Kutta, order 4: the generic, structure-blind baseline.  Four field evaluations,
    no H or S."""
    x_new, comp_new = advance(x, comp, _rk4_increment_inlined(model, eps, hamiltonian, buf, x, h))
    if is_finite(x_new):
        return StepResult(x_new, comp_new, np.nan, np.nan, OK, 0, 4, 0.0, UNKNOWN)
    return StepResult(
        x_new, comp_new, np.nan, np.nan, NON_FINITE, 0, 4, 0.0, _stage_culprit(model, eps, hamiltonian, buf, x, h)
    )


@inner
def _stage_culprit(model, eps, hamiltonian, buf, x, h):
    """The user function that is not finite at the first RK4 stage point where one is not (0 if none):
    a stage point can lie where the user's functions are undefined though x and x' do not."""
    y = x
    for c in (0.5, 0.5, 1.0, 0.0):
        culprit = non_finite_culprit(model, buf, y, hamiltonian) if is_finite(y) else UNKNOWN
        if culprit != UNKNOWN or c == 0.0:
            return culprit
        y = axpy(c * h, field(model, eps, hamiltonian, buf, y), x)
    return UNKNOWN


@hot
def _combine(k, weights, h, count):
    """``h sum_j weights_j K_j`` over the first ``count`` stages ``K_j = k[3j:3j+3]`` (skipping zero weights)."""
    total = ZERO
    for j in range(count):
        if weights[j] != 0.0:
            total = axpy(h * weights[j], _stage(k, j), total)
    return total


@njit(inline="always")
def _stage(k, j):
    """The stage ``K_j``, kept at ``k[3j:3j+3]``."""
    return k[3 * j], k[3 * j + 1], k[3 * j + 2]


@hot
def pair_step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work, estimate):
    """One step; returns ``(StepResult, e, e_low)`` (``e``, ``e_low`` zero when ``estimate`` is False).

    Stages ``K_i = xi(x + h sum_{j<i} a_ij K_j)``; ``x' = x + h K^T b`` by
    compensated summation.  With ``estimate`` and a nonzero last error weight
    the field at ``x'`` is evaluated for the estimate (one evaluation more).
    With ``method.projection`` the state is then projected (``projection.project_step``).
    """
    b, e, e_low = method.b, method.e, method.e_low
    starts, cols, values = method.a_starts, method.a_cols, method.a_values
    s = b.shape[0]
    k = work  # the stages K_j at k[3j:3j+3], j <= s
    for i in range(s):
        y = x
        for m in range(starts[i], starts[i + 1]):  # the nonzero a_ij, j increasing
            y = axpy(h * values[m], _stage(k, cols[m]), y)
        f = field_inlined(model, eps, hamiltonian, buf, y)  # one call site: inlined once, as RK4's stages
        if not is_finite(f):  # name the user function that is not finite at this stage point
            culprit = non_finite_culprit(model, buf, y, hamiltonian) if is_finite(y) else UNKNOWN
            return (StepResult(y, comp, np.nan, np.nan, NON_FINITE, 0, i + 1, 0.0, culprit), ZERO, ZERO)
        k[3 * i], k[3 * i + 1], k[3 * i + 2] = f
    x_new, comp_new = advance(x, comp, _combine(k, b, h, s))
    evaluations = s
    error, error_low = ZERO, ZERO
    if not is_finite(x_new):
        return StepResult(x_new, comp_new, np.nan, np.nan, NON_FINITE, 0, evaluations, 0.0, UNKNOWN), error, error_low
    if estimate:
        rows = s
        if e[s] != 0.0:
            k[3 * s], k[3 * s + 1], k[3 * s + 2] = field(model, eps, hamiltonian, buf, x_new)
            evaluations += 1
            rows = s + 1
        error = _combine(k, e, h, rows)
        if e_low.shape[0] > 0:
            error_low = _combine(k, e_low, h, rows)
    H_new, S_new = np.nan, np.nan
    if method.projection != NO_PROJECTION:
        x_new, H_new, S_new, projected, more = project_step(
            model, buf, x_new, np.nan, np.nan, H_anchor, S_x, method.max_iter
        )
        comp_new = ZERO
        evaluations += more
        if not projected:
            return (
                StepResult(x_new, comp_new, H_new, S_new, PROJECTION_FAILED, 0, evaluations, 0.0, UNKNOWN),
                error,
                error_low,
            )
    return StepResult(x_new, comp_new, H_new, S_new, OK, 0, evaluations, 0.0, UNKNOWN), error, error_low
