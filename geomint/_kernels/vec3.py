"""[R3] Arithmetic on 3-vectors held as tuples of floats (no allocation in hot loops), and compensated summation.

These are ordinary compiled functions (``jit.inner``), not numba-inlined ones;
LLVM inlines them all the same (docs/design.md section 5).
"""

import numpy as np
from numba import njit, types
from numba.extending import overload

from .jit import OVERLOADED, inner

ZERO = (0.0, 0.0, 0.0)


@inner
def add(u, v):
    return (u[0] + v[0], u[1] + v[1], u[2] + v[2])


@inner
def sub(u, v):
    return (u[0] - v[0], u[1] - v[1], u[2] - v[2])


@inner
def scale(a, u):
    return (a * u[0], a * u[1], a * u[2])


@inner
def axpy(a, u, v):
    """``a*u + v``."""
    return (a * u[0] + v[0], a * u[1] + v[1], a * u[2] + v[2])


@inner
def dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@inner
def cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@inner
def abs_dot(u, v):
    """``sum_i |u_i v_i|``: the size of the terms of ``u . v``."""
    return abs(u[0] * v[0]) + abs(u[1] * v[1]) + abs(u[2] * v[2])


@inner
def norm_inf(u):
    return max(abs(u[0]), abs(u[1]), abs(u[2]))


@inner
def is_finite(u):
    return np.isfinite(u[0]) and np.isfinite(u[1]) and np.isfinite(u[2])


@inner
def load(buf, u):
    """Write the tuple ``u`` into the work array ``buf`` (user functions take arrays)."""
    buf[0] = u[0]
    buf[1] = u[1]
    buf[2] = u[2]
    return buf


@inner
def solve(m, r):
    """Solve the 3x3 system ``m y = r`` (``m`` a tuple of rows) by Cramer's rule.

    Returns ``r`` unchanged when ``m`` is singular or not finite, i.e. the
    Newton step falls back to a fixed-point step.
    """
    c0 = cross(m[1], m[2])
    c1 = cross(m[2], m[0])
    c2 = cross(m[0], m[1])
    det = dot(m[0], c0)
    if det == 0.0 or not np.isfinite(det):
        return r
    return (
        (c0[0] * r[0] + c1[0] * r[1] + c2[0] * r[2]) / det,
        (c0[1] * r[0] + c1[1] * r[1] + c2[1] * r[2]) / det,
        (c0[2] * r[0] + c1[2] * r[1] + c2[2] * r[2]) / det,
    )


def as_vector(v):
    """A user function's vector result as a 3-tuple; a 3x3 matrix ``P`` gives its axial vector.

    ``P v = v x J`` means ``J = (P[1,2], -P[0,2], P[0,1])``.  An array of another
    shape gives NaNs (the step then fails as non-finite, naming the function)
    instead of a read past its end.
    """
    if np.shape(v) not in ((3,), (3, 3)):
        return (np.nan, np.nan, np.nan)
    if np.ndim(v) == 2:  # pure-Python path (NUMBA_DISABLE_JIT=1)
        return (v[1][2], -v[0][2], v[0][1])
    return (v[0], v[1], v[2])


@overload(as_vector, jit_options=OVERLOADED)
def _as_vector(v):
    if isinstance(v, types.Array) and v.ndim == 2:
        return lambda v: (
            (v[1, 2], -v[0, 2], v[0, 1]) if v.shape[0] == 3 and v.shape[1] == 3 else (np.nan, np.nan, np.nan)
        )
    if isinstance(v, types.Array):
        return lambda v: (v[0], v[1], v[2]) if v.shape[0] == 3 else (np.nan, np.nan, np.nan)
    return lambda v: (v[0], v[1], v[2])


@inner
def same(u, v):
    """Bitwise-equal components (``-0.0 == 0.0``)."""
    return u[0] == v[0] and u[1] == v[1] and u[2] == v[2]


#: Components below ``FLUSH * |x|_inf`` are flushed to zero: 2^-200 ~ 6e-61 is
#: far below an ulp of ``|x|``, so H and S change by less than ~1e-44 ulp, and
#: products of a few such components stay above the subnormal range, whose
#: arithmetic is about 10x slower on x86.
FLUSH = 2.0**-200


@inner
def flush_tiny(u, carry):
    """``u`` with components ``|u_i| <= FLUSH * |u|_inf`` set to 0, and ``carry`` zeroed there too."""
    limit = FLUSH * norm_inf(u)
    keep0 = abs(u[0]) > limit
    keep1 = abs(u[1]) > limit
    keep2 = abs(u[2]) > limit
    return (
        (u[0] if keep0 else 0.0, u[1] if keep1 else 0.0, u[2] if keep2 else 0.0),
        (carry[0] if keep0 else 0.0, carry[1] if keep1 else 0.0, carry[2] if keep2 else 0.0),
    )


@njit(inline="always")
def advance(x, comp, dx):
    """``x + dx`` by compensated summation; returns ``(x_new, comp_new)``.

    Kahan, Comm. ACM 8 (1965) 40, doi:10.1145/363707.363723; as in Hairer's
    geometric integrators.  ``x + comp`` is the state carried to extra precision.
    """
    y = sub(dx, comp)
    x_new = add(x, y)
    return x_new, sub(sub(x_new, x), y)
