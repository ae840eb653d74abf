"""The metriplectic field in R^n and its Jacobian, evaluated from the user functions (``layout.ModelN``).

    xi = P(x) grad H + eps D(x) grad S,   D = g = grad H grad H^T - |grad H|^2 I   (the paper's metric)
                                          or D = M(x)                              (the user's metric)

With the Hamiltonian part off ``P`` is never called; with ``eps = 0`` neither
``grad S`` nor ``M``.  Each value is written into a buffer the caller gives
(no allocation but the user functions' own results).
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .jit import inner
from .layout import FN_GRAD_H, FN_GRAD_S, FN_H, FN_POISSON, FN_S, PAPER_METRIC, SQRT_EPS, UNKNOWN
from .vecn import all_finite, dot, norm_inf


@inner
def field_into(out, model, eps, hamiltonian, x):
    """``out = xi(x)``; returns ``out``."""
    p = model.params
    gh = model.grad_H(x, p)
    n = x.shape[0]
    if hamiltonian:
        m = model.P(x, p)
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += m[i, j] * gh[j]
            out[i] = s
    else:
        out[:] = 0.0
    if eps != 0.0:
        gs = model.grad_S(x, p)
        if model.metric == PAPER_METRIC:
            a, b = dot(gh, gs), dot(gh, gh)
            for i in range(n):
                out[i] += eps * (a * gh[i] - b * gs[i])
        else:
            d = model.M(x, p)
            for i in range(n):
                s = 0.0
                for j in range(n):
                    s += d[i, j] * gs[j]
                out[i] += eps * s
    return out


@inner
def jacobian_into(jac, model, eps, hamiltonian, x, f0, shifted, column):
    """``jac[i, j] = d xi_i / d x_j`` at ``x`` by forward differences (n field calls), ``f0 = xi(x)``;
    ``shifted`` and ``column`` are scratch vectors."""
    n = x.shape[0]
    size = norm_inf(x)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    for j in range(n):
        for i in range(n):
            shifted[i] = x[i]
        shifted[j] = x[j] + delta
        field_into(column, model, eps, hamiltonian, shifted)
        for i in range(n):
            jac[i, j] = (column[i] - f0[i]) / delta
    return jac


@inner
def non_finite_culprit_n(model, x, hamiltonian):
    """The first user function (``layout.FN_*``) that is not finite at ``x``, 0 if none is."""
    p = model.params
    if not np.isfinite(model.H(x, p)):
        return FN_H
    if not all_finite(model.grad_H(x, p)):
        return FN_GRAD_H
    if not np.isfinite(model.S(x, p)):
        return FN_S
    if not all_finite(model.grad_S(x, p)):
        return FN_GRAD_S
    if hamiltonian and not all_finite(model.P(x, p).ravel()):
        return FN_POISSON
    return UNKNOWN


@njit(cache=CACHE, error_model="numpy")
def xi_rows(model, eps, hamiltonian, X, out):
    """``out[k] = xi(X[k])`` for every row of ``X`` (m, n).  Caller: ``MetriplecticSystemN``."""
    for k in range(X.shape[0]):
        field_into(out[k], model, eps, hamiltonian, np.ascontiguousarray(X[k]))
