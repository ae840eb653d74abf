"""The embedded Runge-Kutta pairs in R^n, alone or projected (``Projected``).

As ``runge_kutta.pair_step`` in R^3: stages ``K_i = xi(x + h sum_{j<i} a_ij K_j)``,
``x' = x + h K^T b``, the error estimate ``e = h [K; xi(x')]^T e_w`` (and
Dormand-Prince 8(5,3)'s ``e_low``), then, with ``method.projection``, the state
settled onto ``{H = H(x0)}`` with S not against its direction
(``projection_n.settle``).  The stages, the new state and the estimates live in
the trajectory's workspace: rows ``0 .. s`` the stages, then the new state,
``e`` and ``e_low`` (``pair_rows``).
"""

import numpy as np
from numba import njit

from .field_n import field_into, non_finite_culprit_n
from .jit import inner
from .layout import NO_PROJECTION, NON_FINITE, OK, PROJECTION_FAILED, UNKNOWN, StepResult
from .projection_n import settle
from .step_n import WN_HEADER
from .vecn import all_finite


@njit(inline="always")  # called from Python (the run's workspace) and from the kernels
def pair_rows(stages):
    """Vectors of length n a pair of ``stages`` stages keeps in its workspace."""
    return stages + 6


@inner
def _rows(work, n, count):
    return work[WN_HEADER : WN_HEADER + count * n].reshape((count, n))


@inner
def pair_step_n(method, model, eps, hamiltonian, x, comp, H_anchor, S_x, h, work, estimate):
    """One step; returns ``(StepResult, e, e_low)``, the estimates views of the workspace (zero when
    ``estimate`` is False; ``e_low`` zero unless the pair has one)."""
    b, e, e_low = method.b, method.e, method.e_low
    starts, cols, values = method.a_starts, method.a_cols, method.a_values
    s = b.shape[0]
    n = x.shape[0]
    rows = _rows(work, n, pair_rows(s))
    k, y, error, error_low, d, before = rows[: s + 1], rows[s + 1], rows[s + 2], rows[s + 3], rows[s + 4], rows[s + 5]
    error[:] = 0.0
    error_low[:] = 0.0
    for i in range(s):
        for m in range(n):
            y[m] = x[m]
        for nz in range(starts[i], starts[i + 1]):  # the nonzero a_ij, j increasing
            j = cols[nz]
            for m in range(n):
                y[m] += h * values[nz] * k[j, m]
        field_into(k[i], model, eps, hamiltonian, y)
        if not all_finite(k[i]):
            culprit = non_finite_culprit_n(model, y, hamiltonian) if all_finite(y) else UNKNOWN
            return StepResult(y, comp, np.nan, np.nan, NON_FINITE, 0, i + 1, 0.0, culprit), error, error_low
    for m in range(n):
        total = 0.0
        for j in range(s):
            total += b[j] * k[j, m]
        y[m] = x[m] + h * total
    evaluations = s
    if not all_finite(y):
        return StepResult(y, comp, np.nan, np.nan, NON_FINITE, 0, evaluations, 0.0, UNKNOWN), error, error_low
    if estimate:
        count = s
        if e[s] != 0.0:
            field_into(k[s], model, eps, hamiltonian, y)
            evaluations += 1
            count = s + 1
        for m in range(n):
            for j in range(count):
                error[m] += h * e[j] * k[j, m]
                if e_low.shape[0] > 0:
                    error_low[m] += h * e_low[j] * k[j, m]
    H_y, S_y = np.nan, np.nan
    if method.projection != NO_PROJECTION:
        against = -model.direction * np.sign(h)
        conserve_s = eps == 0.0 and hamiltonian
        H_y, S_y, settled, more = settle(model, y, np.nan, H_anchor, S_x, against, conserve_s, d, before)
        evaluations += more
        if not settled:
            return StepResult(y, comp, H_y, S_y, PROJECTION_FAILED, 0, evaluations, 0.0, UNKNOWN), error, error_low
    return StepResult(y, comp, H_y, S_y, OK, 0, evaluations, 0.0, UNKNOWN), error, error_low
