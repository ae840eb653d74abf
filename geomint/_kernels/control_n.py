"""The adaptive controller's error estimates and first step in R^n (``control`` for R^3, whose rules they follow).

Estimators (``layout``): ``EMBEDDED``, the pair's own (``runge_kutta_n.pair_step_n``);
``RK4_REFERENCE``, a discrete-gradient step against the explicit RK4 step from
the same state (whose increment also seeds the Newton iteration); ``DOUBLING``,
one step of ``h`` against two of ``h/2``, ``e = (x_2 - x_1) / (2^p - 1)``
(Richardson), the two half steps kept.  The intermediate states live in the
controller's vectors at the end of the run's workspace (``CONTROL_VECTORS``
vectors of length n after the method's slots: ``control_vector``), so an
estimate allocates nothing.
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .field_n import field_into
from .jit import inner
from .layout import EPS, OK, RK4_REFERENCE, StepResult
from .runge_kutta_n import pair_step_n
from .step import step
from .step_n import V_DX1, WN_FACTORED, WN_H, WN_HISTORY, factor, rk4_step_n, vector
from .vecn import all_finite, copy_into

#: vectors of length n the controller keeps after the method's slots: the full step, the first half step,
#: the estimate, the RK4 reference
CONTROL_VECTORS = 4
C_FULL, C_HALF, C_ERROR, C_REFERENCE = 0, 1, 2, 3


@inner
def control_vector(work, k, n):
    end = work.shape[0] - (CONTROL_VECTORS - 1 - k) * n
    return work[end - n : end]


@inner
def error_norm_n(e, x, x_new, rtol, atol):
    """``control.error_norm`` (unblended) in R^n: the RMS norm of ``e`` in the weights ``atol + rtol |x|``, each
    component first reduced by the round-off of the two states (``4 eps max(|x_i|, |x'_i|)``)."""
    m = 0.0
    n = x.shape[0]
    for i in range(n):
        size = max(abs(x[i]), abs(x_new[i]))
        m += (max(abs(e[i]) - 4.0 * EPS * size, 0.0) / (atol + rtol * size)) ** 2
    return np.sqrt(m / n)


@inner
def _blended(e, e_low, x, x_new, rtol, atol):
    """Dormand-Prince 8(5,3)'s blend of its two estimates (Hairer's DOP853), as ``control.error_norm``."""
    m, m_low = 0.0, 0.0
    n = x.shape[0]
    for i in range(n):
        size = max(abs(x[i]), abs(x_new[i]))
        weight = atol + rtol * size
        floor = 4.0 * EPS * size
        m += (max(abs(e[i]) - floor, 0.0) / weight) ** 2
        m_low += (max(abs(e_low[i]) - floor, 0.0) / weight) ** 2
    m /= n
    m_low /= n
    if m == 0.0 and m_low == 0.0:
        return 0.0
    return m / np.sqrt((m + 0.01 * m_low) * n)


@inner
def estimated_pair_n(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    r, e, e_low = pair_step_n(method, model, eps, hamiltonian, x, comp, anchor, S_x, h, work, control.adaptive)
    if not control.adaptive:
        return r, 0.0
    if method.e_low.shape[0] > 0:
        return r, _blended(e, e_low, x, r.x, control.rtol, control.atol)
    return r, error_norm_n(e, x, r.x, control.rtol, control.atol)


@inner
def estimated_discrete_gradient_n(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    n = x.shape[0]
    if not control.adaptive:
        return step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work), 0.0
    if control.estimator != RK4_REFERENCE:
        return estimated_by_doubling_n(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work)
    reference = control_vector(work, C_REFERENCE, n)
    rk = rk4_step_n(model, eps, hamiltonian, x, comp, h, work)
    for i in range(n):
        reference[i] = rk.x[i] - x[i]
    if work[WN_FACTORED] > 0.0 and all_finite(reference):  # the RK4 increment starts the Newton iteration
        if work[WN_H] != h:  # the kept Jacobian factored anew for this step (no field evaluations)
            factor(work, n, h)
        copy_into(vector(work, V_DX1, n), reference)
        work[WN_HISTORY] = 1.0
        work[WN_H] = h
    r = step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work)
    e = control_vector(work, C_ERROR, n)
    for i in range(n):
        e[i] = (r.x[i] - x[i]) - reference[i]
    r = StepResult(r.x, r.comp, r.H, r.S, r.status, r.iterations, r.evaluations + 4, r.residual, r.culprit)
    return r, error_norm_n(e, x, r.x, control.rtol, control.atol)


@inner
def estimated_by_doubling_n(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    """One step of ``h`` and, where adaptive, two of ``h/2`` (kept): ``(StepResult, err)``."""
    n = x.shape[0]
    r = step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work)
    if not control.adaptive or r.status != OK:
        return r, 0.0
    full = copy_into(control_vector(work, C_FULL, n), r.x)
    iterations, evaluations = r.iterations, r.evaluations
    r = step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, 0.5 * h, work)
    iterations += r.iterations
    evaluations += r.evaluations
    if r.status == OK:
        half = copy_into(control_vector(work, C_HALF, n), r.x)
        S_half = r.S if not np.isnan(r.S) else model.S(half, model.params)
        r = step(method, model, eps, hamiltonian, buf, half, comp, anchor, S_half, 0.5 * h, work)
        iterations += r.iterations
        evaluations += r.evaluations
    r = StepResult(r.x, r.comp, r.H, r.S, r.status, iterations, evaluations, r.residual, r.culprit)
    if r.status != OK:
        return r, 0.0
    e = control_vector(work, C_ERROR, n)
    factor = 1.0 / (2.0**control.order - 1.0)
    for i in range(n):
        e[i] = factor * (r.x[i] - full[i])
    return r, error_norm_n(e, x, r.x, control.rtol, control.atol)


@njit(cache=CACHE, error_model="numpy")
def first_step_n(model, eps, hamiltonian, x0, t0, t_end, control):
    """``control.first_step`` in R^n: scipy's rule (Hairer, Norsett & Wanner, *Solving ODEs I*, section II.4)."""
    n = x0.shape[0]
    span = abs(t_end - t0)
    direction = 1.0 if t_end >= t0 else -1.0
    f0 = field_into(np.empty(n), model, eps, hamiltonian, x0)
    d0, d1 = 0.0, 0.0
    for i in range(n):
        weight = control.atol + control.rtol * abs(x0[i])
        d0 += (x0[i] / weight) ** 2
        d1 += (f0[i] / weight) ** 2
    d0, d1 = np.sqrt(d0 / n), np.sqrt(d1 / n)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    moved = np.empty(n)
    for i in range(n):
        moved[i] = x0[i] + direction * h0 * f0[i]
    f1 = field_into(np.empty(n), model, eps, hamiltonian, moved)
    d2 = np.inf
    if all_finite(f1):
        d2 = 0.0
        for i in range(n):
            d2 += ((f1[i] - f0[i]) / (control.atol + control.rtol * abs(x0[i]))) ** 2
        d2 = np.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (control.error_order + 1.0))
    h = min(100.0 * h0, h1, span, control.h_max)
    if not np.isfinite(h):
        h = min(span, control.h_max)
    return direction * max(h, 16.0 * EPS * max(abs(t0), abs(t_end)))
