"""A user's module for a system in R^n: a quadratic energy, S the first coordinate's square, P canonical on the
other pairs (S a Casimir), each function returning an array.  Copied by tests/test_identity.py as ``chain.py``."""

import numba
import numpy as np


@numba.njit
def H(x, p):
    return 0.5 * np.sum(x * x)


@numba.njit
def grad_H(x, p):
    return x.copy()


@numba.njit
def S(x, p):
    return 0.5 * x[0] * x[0]


@numba.njit
def grad_S(x, p):
    g = np.zeros(x.shape[0])
    g[0] = x[0]
    return g


@numba.njit
def P(x, p):
    n = x.shape[0]
    m = np.zeros((n, n))
    for i in range(1, n - 1, 2):
        m[i, i + 1] = 1.0
        m[i + 1, i] = -1.0
    return m
