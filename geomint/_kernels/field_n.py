"""The metriplectic field in R^n and its Jacobian, evaluated from the user functions (``layout.ModelN``).

    xi = P(x) grad H + eps D(x) grad S,   D = g = grad H grad H^T - |grad H|^2 I   (the paper's metric)
                                          or D = M(x)                              (the user's metric)

With the Hamiltonian part off ``P`` is never called; with ``eps = 0`` neither
``grad S`` nor ``M``.  P and M are applied in the form the user gave them
(``ModelN.actions``): a matrix times the vector (O(n^2)), or the user's action
``(x, v, params) -> A(x) v`` (whatever it costs, O(n) for a sparse operator):
no function here forms a matrix the user did not give.  Each value is written
into a buffer the caller gives (no allocation but the user functions' own
results).
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .jit import hot, inner
from .layout import FN_GRAD_H, FN_GRAD_S, FN_H, FN_POISSON, FN_S, M_ACTION, P_ACTION, PAPER_METRIC, SQRT_EPS, UNKNOWN
from .vecn import all_finite, copy_into, dot, matvec_into, norm_inf, norm_rows


@hot
def apply_P(model, x, v, out, with_size):
    """``out = P(x) v`` in P's native form; returns a size of ``P(x)`` where ``with_size`` (0 otherwise): its
    infinity norm (row sums) for a matrix, the gain ``|P v|_inf / |v|_inf`` on ``v`` for an action."""
    p = model.params
    if model.actions & P_ACTION:
        copy_into(out, model.P_apply(x, v, p))
        if not with_size:
            return 0.0
        size = norm_inf(v)
        return norm_inf(out) / size if size > 0.0 else 0.0
    m = model.P(x, p)
    matvec_into(out, m, v)
    return norm_rows(m) if with_size else 0.0


@hot
def apply_M(model, x, v, out, with_size):
    """``out = M(x) v`` (the user's metric) in its native form; the size as ``apply_P``."""
    p = model.params
    if model.actions & M_ACTION:
        copy_into(out, model.M_apply(x, v, p))
        if not with_size:
            return 0.0
        size = norm_inf(v)
        return norm_inf(out) / size if size > 0.0 else 0.0
    m = model.M(x, p)
    matvec_into(out, m, v)
    return norm_rows(m) if with_size else 0.0


@hot
def _add_dissipative(out, model, eps, x, gh):
    """``out += eps D(x) grad S(x)``, ``gh = grad H(x)``."""
    p = model.params
    gs = model.grad_S(x, p)
    n = x.shape[0]
    if model.metric == PAPER_METRIC:
        a, b = dot(gh, gs), dot(gh, gh)
        for i in range(n):
            out[i] += eps * (a * gh[i] - b * gs[i])
    elif model.actions & M_ACTION:
        d = model.M_apply(x, gs, p)
        for i in range(n):
            out[i] += eps * d[i]
    else:
        d = model.M(x, p)
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += d[i, j] * gs[j]
            out[i] += eps * s


@hot
def field_into(out, model, eps, hamiltonian, x):
    """``out = xi(x)``; returns ``out``."""
    p = model.params
    gh = model.grad_H(x, p)
    if hamiltonian:
        apply_P(model, x, gh, out, False)
    else:
        out[:] = 0.0
    if eps != 0.0:
        _add_dissipative(out, model, eps, x, gh)
    return out


@hot
def dissipative_into(out, model, eps, x):
    """``out = eps D(x) grad S(x)``, the dissipative part of the field with its eps; returns ``out``."""
    out[:] = 0.0
    if eps != 0.0:
        _add_dissipative(out, model, eps, x, model.grad_H(x, model.params))
    return out


@inner
def difference_step(x):
    """The forward-difference step of the Jacobians: ``sqrt(eps) |x|_inf`` (``sqrt(eps)`` at 0)."""
    size = norm_inf(x)
    return SQRT_EPS * (size if size > 0.0 else 1.0)


@hot
def jacobian_into(jac, model, eps, hamiltonian, x, f0, shifted, column):
    """``jac[i, j] = d xi_i / d x_j`` at ``x`` by forward differences (n field calls), ``f0 = xi(x)``;
    ``shifted`` and ``column`` are scratch vectors."""
    n = x.shape[0]
    delta = difference_step(x)
    for j in range(n):
        for i in range(n):
            shifted[i] = x[i]
        shifted[j] = x[j] + delta
        field_into(column, model, eps, hamiltonian, shifted)
        for i in range(n):
            jac[i, j] = (column[i] - f0[i]) / delta
    return jac


@inner
def jacobian_parts_into(jac, dis, model, eps, hamiltonian, x, f0, g0, shifted, column, dcolumn):
    """The Jacobians of the Hamiltonian part (into ``jac``) and of the dissipative part ``eps D grad S`` (into
    ``dis``) at ``x`` by forward differences, each column from one evaluation of each part (about n field
    calls); ``f0`` is the Hamiltonian part at x, ``g0`` the dissipative part.  Returns ``|dis|_inf``."""
    n = x.shape[0]
    delta = difference_step(x)
    for j in range(n):
        for i in range(n):
            shifted[i] = x[i]
        shifted[j] = x[j] + delta
        field_into(column, model, 0.0, hamiltonian, shifted)
        dissipative_into(dcolumn, model, eps, shifted)
        for i in range(n):
            jac[i, j] = (column[i] - f0[i]) / delta
            dis[i, j] = (dcolumn[i] - g0[i]) / delta
    return norm_rows(dis)


@inner
def dissipative_norm(model, eps, x, g0, shifted, dcolumn, rows):
    """``|D(eps D grad S)(x)|_inf`` by forward differences (n evaluations of the dissipative part) without
    storing the Jacobian: its row sums accumulate in ``rows``.  ``g0`` is the dissipative part at x."""
    n = x.shape[0]
    delta = difference_step(x)
    rows[:] = 0.0
    for j in range(n):
        for i in range(n):
            shifted[i] = x[i]
        shifted[j] = x[j] + delta
        dissipative_into(dcolumn, model, eps, shifted)
        for i in range(n):
            rows[i] += abs((dcolumn[i] - g0[i]) / delta)
    return norm_inf(rows)


@inner
def non_finite_culprit_n(model, x, hamiltonian):
    """The first user function (``layout.FN_*``) that is not finite at ``x``, 0 if none is."""
    p = model.params
    if not np.isfinite(model.H(x, p)):
        return FN_H
    gh = model.grad_H(x, p)
    if not all_finite(gh):
        return FN_GRAD_H
    if not np.isfinite(model.S(x, p)):
        return FN_S
    if not all_finite(model.grad_S(x, p)):
        return FN_GRAD_S
    if hamiltonian:
        if model.actions & P_ACTION:
            if not all_finite(model.P_apply(x, gh, p)):
                return FN_POISSON
        elif not all_finite(model.P(x, p).ravel()):
            return FN_POISSON
    return UNKNOWN


@njit(cache=CACHE, error_model="numpy")
def xi_rows(model, eps, hamiltonian, X, out):
    """``out[k] = xi(X[k])`` for every row of ``X`` (m, n).  Caller: ``MetriplecticSystemN``."""
    for k in range(X.shape[0]):
        field_into(out[k], model, eps, hamiltonian, np.ascontiguousarray(X[k]))
