"""Vectors of length n in preallocated buffers, and a dense LU solve, for the kernels in R^n.

The R^n kernels hold states and their intermediates in slices of one
workspace array (``step_n.vector``), never allocating per step; these are the
loops they share.  ``lu_factor``/``lu_solve`` are Gaussian elimination with
partial pivoting (Golub & Van Loan, *Matrix Computations*, section 3.4),
written out so that a small system pays no call into LAPACK
(docs/engine_rn.md, "Solving the step"); ``lapack_factor``/``lapack_solve``
factor with LAPACK's ``dgetrf`` (blocked, O(n^3 / 3) at BLAS-3 speed) in place,
reached through numba's own binding (``numba_xxgetrf``, linked by name, so
the kernels stay cacheable), and solve with the factors by hand (O(n^2), as
``dgetrs`` would for one right-hand side).
"""

import numpy as np
from numba import types
from numba.extending import overload
from numba.np.linalg import _LAPACK, F_INT_nptype, ensure_lapack

from .jit import OVERLOADED, hot, inner

#: numba's binding of ``dgetrf`` (the one np.linalg uses; scipy's LAPACK is loaded when a kernel is compiled)
_getrf = _LAPACK.numba_xxgetrf(types.float64)

#: LAPACK's integer (the pivots of ``lapack_factor``)
LAPACK_INT = F_INT_nptype


@hot
def dot(u, v):
    """``u . v`` in four partial sums (``i mod 4``), added pairwise at the end: four independent chains of
    additions the processor overlaps, where one waits on each addition (the rounding differs from a single
    running sum's by a few ulps of the terms)."""
    n = u.shape[0]
    s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0
    i = 0
    while i + 4 <= n:
        s0 += u[i] * v[i]
        s1 += u[i + 1] * v[i + 1]
        s2 += u[i + 2] * v[i + 2]
        s3 += u[i + 3] * v[i + 3]
        i += 4
    while i < n:
        s0 += u[i] * v[i]
        i += 1
    return (s0 + s1) + (s2 + s3)


@hot
def abs_dot(u, v):
    """``sum_i |u_i v_i|``: the size of the terms of ``u . v`` (four partial sums, as ``dot``)."""
    n = u.shape[0]
    s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0
    i = 0
    while i + 4 <= n:
        s0 += abs(u[i] * v[i])
        s1 += abs(u[i + 1] * v[i + 1])
        s2 += abs(u[i + 2] * v[i + 2])
        s3 += abs(u[i + 3] * v[i + 3])
        i += 4
    while i < n:
        s0 += abs(u[i] * v[i])
        i += 1
    return (s0 + s1) + (s2 + s3)


@hot
def scaled_norm2(u, scale):
    """``sum_i (scale u_i)^2`` in four partial sums (as ``dot``): with ``scale = 1 / |u|_inf``, ``|u|^2 /
    |u|_inf^2`` without underflow or overflow."""
    n = u.shape[0]
    s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0
    i = 0
    while i + 4 <= n:
        a0, a1, a2, a3 = scale * u[i], scale * u[i + 1], scale * u[i + 2], scale * u[i + 3]
        s0 += a0 * a0
        s1 += a1 * a1
        s2 += a2 * a2
        s3 += a3 * a3
        i += 4
    while i < n:
        a0 = scale * u[i]
        s0 += a0 * a0
        i += 1
    return (s0 + s1) + (s2 + s3)


@hot
def norm_inf(u):
    """``max_i |u_i|``, NaN where any component is NaN.  Four running maxima (a maximum is exact in any order):
    independent chains the processor overlaps, where one chain waits on each comparison."""
    n = u.shape[0]
    m0, m1, m2, m3 = 0.0, 0.0, 0.0, 0.0
    i = 0
    while i + 4 <= n:
        a0, a1, a2, a3 = abs(u[i]), abs(u[i + 1]), abs(u[i + 2]), abs(u[i + 3])
        m0 = a0 if a0 > m0 or a0 != a0 else m0  # a NaN, once taken, stays
        m1 = a1 if a1 > m1 or a1 != a1 else m1
        m2 = a2 if a2 > m2 or a2 != a2 else m2
        m3 = a3 if a3 > m3 or a3 != a3 else m3
        i += 4
    while i < n:
        a0 = abs(u[i])
        m0 = a0 if a0 > m0 or a0 != a0 else m0
        i += 1
    for m in (m1, m2, m3):
        m0 = m if m > m0 or m != m else m0
    return m0


@inner
def all_finite(u):
    for i in range(u.shape[0]):
        if not np.isfinite(u[i]):
            return False
    return True


@hot
def copy_into(out, u):
    for i in range(u.shape[0]):
        out[i] = u[i]
    return out


@inner
def axpy_into(out, a, u, v):
    """``out = a u + v`` (``out`` may be ``v``)."""
    for i in range(u.shape[0]):
        out[i] = a * u[i] + v[i]
    return out


@hot
def remove_scaled(u, e, dd):
    """``remove_along(u, d)`` with ``e = d / |d|_inf`` and ``dd = e . e`` prepared by the caller, once for several
    vectors (nothing where ``dd`` is 0): the same arithmetic as ``remove_along``'s, bit for bit."""
    if dd == 0.0:
        return u
    c = dot(u, e) / dd
    for i in range(u.shape[0]):
        u[i] -= c * e[i]
    return u


@inner
def remove_along(u, direction):
    """``u - (u . d / d . d) d`` in place: ``u`` without its component along ``d`` (nothing where ``d = 0``).

    ``d`` is divided by its largest component first, so that ``d . d`` neither
    underflows nor overflows however small or large ``d`` is.
    """
    size = norm_inf(direction)
    if size == 0.0 or not np.isfinite(size):
        return u
    dd, ud = 0.0, 0.0
    for i in range(u.shape[0]):
        e = direction[i] / size
        dd += e * e
        ud += u[i] * e
    c = ud / dd
    for i in range(u.shape[0]):
        u[i] -= c * (direction[i] / size)
    return u


@hot
def norm_rows(m):
    """The infinity norm of a matrix: its largest absolute row sum."""
    largest = 0.0
    for i in range(m.shape[0]):
        s = 0.0
        for j in range(m.shape[1]):
            s += abs(m[i, j])
        if not s <= largest:
            largest = s
    return largest


@hot
def matvec_into(out, m, v):
    for i in range(m.shape[0]):
        s = 0.0
        for j in range(m.shape[1]):
            s += m[i, j] * v[j]
        out[i] = s
    return out


@hot
def lu_factor(a, base, n, pivots, first):
    """Factor the (n, n) matrix stored row by row at ``a[base:base + n * n]`` in place as ``P a = L U`` (partial
    pivoting); ``pivots[first:first + n]`` (floats) records the rows.  (Flat storage: one routine serves a dense
    matrix, ``base = 0``, and the packed blocks of ``sparse_n``, without a view per block.)

    Returns False where a pivot is zero or not finite (the matrix is singular to working precision).
    """
    for k in range(n):
        p = k
        big = abs(a[base + k * n + k])
        for i in range(k + 1, n):
            if abs(a[base + i * n + k]) > big:
                big = abs(a[base + i * n + k])
                p = i
        pivots[first + k] = p
        if not (big > 0.0 and np.isfinite(big)):
            return False
        if p != k:
            for j in range(n):
                a[base + k * n + j], a[base + p * n + j] = a[base + p * n + j], a[base + k * n + j]
        inverse = 1.0 / a[base + k * n + k]
        for i in range(k + 1, n):
            a[base + i * n + k] *= inverse
            f = a[base + i * n + k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[base + i * n + j] -= f * a[base + k * n + j]
    return True


@hot
def lu_solve(lu, base, n, pivots, first, b):
    """Solve ``a x = b[:n]`` in place (``b`` becomes x) from ``lu_factor``'s factors at ``base``, ``first``."""
    for k in range(n):
        p = int(pivots[first + k])
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= lu[base + i * n + j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= lu[base + i * n + j] * b[j]
        b[i] = s / lu[base + i * n + i]
    return b


def lapack_factor(a, pivots):
    """Factor ``a`` (n, n, C order) in place with LAPACK's ``dgetrf``, which sees ``a^T`` (Fortran order):
    ``a^T = P L U``; ``pivots`` (n LAPACK integers, ``LAPACK_INT``) records the rows, 1-based.  Returns False
    where ``a`` is singular (a zero pivot) or not finite.  (This body runs under ``NUMBA_DISABLE_JIT=1``; compiled
    code calls ``dgetrf`` directly, ``_lapack_factor_typed``.)"""
    import scipy.linalg.lapack  # noqa: PLC0415 - the pure-Python lane only

    if not np.all(np.isfinite(a)):
        return False
    _, piv, info = scipy.linalg.lapack.dgetrf(a.T, overwrite_a=1)  # pyright: ignore[reportAttributeAccessIssue]
    pivots[:] = piv + 1
    return info == 0


@overload(lapack_factor, jit_options=OVERLOADED)
def _lapack_factor_typed(a, pivots):
    ensure_lapack()

    def impl(a, pivots):
        n = a.shape[0]
        for i in range(n):
            for j in range(n):
                if not np.isfinite(a[i, j]):
                    return False
        return _getrf(ord("d"), n, n, a.ctypes, n, pivots.ctypes) == 0

    return impl


@inner
def lapack_solve(lu, pivots, b):
    """Solve ``a x = b`` in place (``b`` becomes x) from ``lapack_factor``'s factors: ``a = U^T L^T P^T`` (the
    factors of ``a^T``), so ``U^T z = b`` (forward, the diagonal of U), ``L^T w = z`` (backward, unit diagonal),
    ``x = P w`` (the interchanges in reverse order), all along the rows of ``lu``."""
    n = lu.shape[0]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= lu[i, j] * b[j]
        b[i] = s / lu[i, i]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= lu[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        p = pivots[i] - 1
        if p != i:
            b[i], b[p] = b[p], b[i]
    return b
