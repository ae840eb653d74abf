"""N damped pendula sharing one entropy: a GENERIC system of any size, block-sparse.

A reference problem of docs/engine_rn.md.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
from numba import njit

from .._cache import CACHE
from .._validate import real
from ..model.system_n import GenericSystem


@njit(cache=CACHE)
def _E(x, p):
    N = (x.shape[0] - 1) // 2
    value = x[2 * N]
    for i in range(N):
        value += 0.5 * x[N + i] * x[N + i] + np.cos(x[i])
    return value


@njit(cache=CACHE)
def _grad_E(x, p):
    N = (x.shape[0] - 1) // 2
    out = np.empty(x.shape[0])
    for i in range(N):
        out[i] = -np.sin(x[i])
        out[N + i] = x[N + i]
    out[2 * N] = 1.0
    return out


@njit(cache=CACHE)
def _S(x, p):
    return x[x.shape[0] - 1]


@njit(cache=CACHE)
def _grad_S(x, p):
    out = np.zeros(x.shape[0])
    out[x.shape[0] - 1] = 1.0
    return out


@njit(cache=CACHE)
def _L(x, p):
    """Canonical on (q, p); zero row and column for s."""
    n = x.shape[0]
    N = (n - 1) // 2
    out = np.zeros((n, n))
    for i in range(N):
        out[i, N + i] = 1.0
        out[N + i, i] = -1.0
    return out


@njit(cache=CACHE)
def _M(x, p):
    """``gamma [[I, -p], [-p^T, |p|^2]]`` on (p, s): ``gamma sum_i w_i w_i^T``, ``w_i = e_{p_i} - p_i e_s``."""
    n = x.shape[0]
    N = (n - 1) // 2
    gamma = p[0]
    out = np.zeros((n, n))
    squares = 0.0
    for i in range(N):
        pi = x[N + i]
        out[N + i, N + i] = gamma
        out[N + i, n - 1] = -gamma * pi
        out[n - 1, N + i] = -gamma * pi
        squares += pi * pi
    out[n - 1, n - 1] = gamma * squares
    return out


@njit(cache=CACHE)
def _L_apply(x, v, p):
    """``L v``: ``(v_p, -v_q, 0)``, O(n)."""
    n = x.shape[0]
    N = (n - 1) // 2
    out = np.empty(n)
    for i in range(N):
        out[i] = v[N + i]
        out[N + i] = -v[i]
    out[n - 1] = 0.0
    return out


@njit(cache=CACHE)
def _M_apply(x, v, p):
    """``M v = gamma sum_i w_i (w_i . v)``, ``w_i = e_{p_i} - p_i e_s``: ``(0, gamma (v_p - p v_s),
    gamma (|p|^2 v_s - p . v_p))``, O(n)."""
    n = x.shape[0]
    N = (n - 1) // 2
    gamma = p[0]
    vs = v[n - 1]
    out = np.empty(n)
    last = 0.0
    for i in range(N):
        pi = x[N + i]
        c = v[N + i] - pi * vs  # w_i . v
        out[i] = 0.0
        out[N + i] = gamma * c
        last -= gamma * pi * c
    out[n - 1] = last
    return out


#: the forms ``damped_pendula`` gives L and M in
FORMS = ("action", "matrix")


def damped_pendula(N: int = 4, gamma: float = 0.5, form: str = "action") -> GenericSystem:
    """N pendula, each damped, their heat going to one shared entropy s (GENERIC, n = 2N + 1).

        x = (q_1 ... q_N, p_1 ... p_N, s),   E = sum_i p_i^2 / 2 + sum_i cos q_i + s,   S = s,
        L canonical on (q, p) (zero row and column for s),
        M = gamma [[I, -p], [-p^T, |p|^2]] on (p, s),

    so ``dq_i/dt = p_i``, ``dp_i/dt = sin q_i - gamma p_i``, ``ds/dt = gamma |p|^2``.
    ``M grad E = 0`` (``grad E = (-sin q, p, 1)``) and ``L grad S = 0``; M is
    ``gamma sum_i w_i w_i^T`` with ``w_i = e_{p_i} - p_i e_s``, positive semidefinite.
    The coordinates are named ``q1 ... qN, p1 ... pN, s`` (``system.variables``).
    Every pendulum comes to rest at ``cos q = -1`` (the minimum of the potential
    cos q), so ``S_inf = E_0 + N``.  L and M are block-sparse: O(n) entries of n^2.
    ``form="action"`` (the default) gives them as actions ``v -> L v``, ``v -> M v``
    (O(n) each: a step costs O(n), docs/engine_rn_speed.md); ``form="matrix"`` as
    (n, n) matrices (O(n^2) per product, a dense Jacobian O(n^3)): the same system.

    Reference: docs/engine_rn.md, "Reference problems"; GENERIC: Grmela and Oettinger, Phys. Rev. E 56 (1997) 6620.
    """
    if isinstance(N, bool) or not isinstance(N, numbers.Integral) or N < 1:
        raise ValueError(f"`N` must be an integer >= 1 (the number of pendula); got {N!r}.")
    gamma = real("gamma", gamma)
    if not 0.0 <= gamma < float("inf"):
        raise ValueError(f"`gamma` must be finite and >= 0; got {gamma!r}.")
    if form not in FORMS:
        raise ValueError(f"`form` must be one of {FORMS}; got {form!r}.")
    operators: dict[str, Any] = dict(L_apply=_L_apply, M_apply=_M_apply) if form == "action" else dict(L=_L, M=_M)
    return GenericSystem(
        E=_E,
        grad_E=_grad_E,
        S=_S,
        grad_S=_grad_S,
        **operators,
        params=[gamma],
        dim=2 * int(N) + 1,
        name=f"damped_pendula_{int(N)}",
        variables=[f"q{i}" for i in range(1, int(N) + 1)] + [f"p{i}" for i in range(1, int(N) + 1)] + ["s"],
    )
