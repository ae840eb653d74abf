"""Random metriplectic systems in the Fish form, any n: not quadratic, P depending on x.

A reference problem of docs/engine_rn.md.
"""

from __future__ import annotations

import numbers

import numpy as np
from numba import njit

from .._cache import CACHE
from ..model.system_n import MetriplecticSystemN

#: params: the cosine and quartic coefficients, then D (n), A (n^2), B_1 ... B_n (n^3)
_COS, _QUARTIC, _D = 0, 1, 2
#: the largest n: params hold n^3 + n^2 + n + 2 numbers (n = 256: 134 MB)
MAX_N = 256


@njit(cache=CACHE)
def _H(x, p):
    n = x.shape[0]
    value = 0.0
    for i in range(n):
        value += 0.5 * p[_D + i] * x[i] * x[i] + p[_COS] * np.cos(x[i])
    return value


@njit(cache=CACHE)
def _grad_H(x, p):
    n = x.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = p[_D + i] * x[i] - p[_COS] * np.sin(x[i])
    return out


@njit(cache=CACHE)
def _S(x, p):
    value = 0.0
    for i in range(x.shape[0]):
        xi2 = x[i] * x[i]
        value += 0.5 * xi2 + p[_QUARTIC] * xi2 * xi2
    return value


@njit(cache=CACHE)
def _grad_S(x, p):
    n = x.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = x[i] + 4.0 * p[_QUARTIC] * x[i] * x[i] * x[i]
    return out


@njit(cache=CACHE)
def _K(x, p):
    """``K = A + sum_k x_k B_k``: its upper triangle, ``n^3 / 2`` multiply-adds in the order of k, each row's segment
    a contiguous loop; the lower triangle minus it (A and the B_k are skew, so that is K in floating point too)."""
    n = x.shape[0]
    at = _D + n
    K = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            K[i, j] = p[at + i * n + j]
    flat = K.reshape(n * n)
    for k in range(n):
        xk = x[k]
        B = p[at + n * n * (k + 1) : at + n * n * (k + 2)]
        for i in range(n - 1):
            segment, source = flat[i * n + i + 1 : i * n + n], B[i * n + i + 1 : i * n + n]
            for m in range(n - 1 - i):
                segment[m] += xk * source[m]
    for i in range(n):
        for j in range(i + 1, n):
            K[j, i] = -K[i, j]
    return K


@njit(cache=CACHE)
def _P(x, p):
    """``(Q - Q^T) / 2``, ``Q = Pi K Pi``, ``K = A + sum_k x_k B_k``: skew in floating point too."""
    n = x.shape[0]
    K = _K(x, p)
    s = _grad_S(x, p)
    norm = np.sqrt(np.sum(s * s))
    if norm > 0.0:
        s = s / norm
        u = K @ s  # K s
        w = K.T @ s  # K^T s
        c = s @ u  # s^T K s
        for i in range(n):
            for j in range(n):
                K[i, j] += -s[i] * w[j] - u[i] * s[j] + c * s[i] * s[j]
    return 0.5 * (K - K.T)


def random_fish(n: int = 6, seed: int = 0, eps: float = 1.0) -> MetriplecticSystemN:
    """A random metriplectic system in R^n in the Fish form (docs/engine_rn.md, "Reference problems").

        H = x^T D x / 2 + 0.2 sum_i cos x_i,          D diagonal, entries uniform in [0.5, 2],
        S = |x|^2 / 2 + 0.075 sum_i x_i^4,
        P(x) = Pi_S(x) (A + sum_k x_k B_k) Pi_S(x),   Pi_S = I - s s^T,  s = grad S / |grad S|  (Pi_S = I at 0),

    A and B_1 ... B_n random skew matrices with entries of variance 1/n
    (``(G - G^T) / sqrt(2 n)``, G standard normal), drawn from ``seed``.  P is
    skew and ``P grad S = 0`` exactly (the projection), and depends on x; H and S
    are not quadratic.  The paper's metric g.  All random numbers are in ``params``
    (2 coefficients, D, A, then B_1 ... B_n flattened: ``n^3 + n^2 + n + 2`` numbers),
    so one compilation serves every n and seed; ``n <= 256``.  K is formed from the upper
    triangles of A and the B_k (new ``params`` through ``with_`` must keep them skew).

    Reference: the construction of docs/engine_rn.md, "Reference problems"; Fish form as in the paper, section 1.
    """
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 2 <= n <= MAX_N:
        raise ValueError(f"`n` must be an integer in [2, {MAX_N}] (the dimension); got {n!r}.")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"`seed` must be an integer >= 0; got {seed!r}.")
    n = int(n)
    rng = np.random.default_rng([int(seed), n])
    D = rng.uniform(0.5, 2.0, size=n)
    G = rng.normal(size=(n + 1, n, n))
    skew = (G - np.swapaxes(G, 1, 2)) / np.sqrt(2.0 * n)
    params = np.concatenate([[0.2, 0.075], D, skew.reshape(-1)])
    return MetriplecticSystemN(
        H=_H,
        grad_H=_grad_H,
        S=_S,
        grad_S=_grad_S,
        P=_P,
        eps=eps,
        params=params,
        dim=n,
        name=f"random_fish_{n}",
    )
