"""A user's module: a rigid body written out as five numba functions, H scaled by a global read from the
environment (numba freezes it into the compiled code).  Tests copy it into a folder of their own as ``user.py``
(tests/test_identity.py, tests/test_handles.py)."""

import os

import numba

SCALE = float(os.environ.get("USER_SCALE", "0.5"))


@numba.njit
def H(x, p):
    return SCALE * (x[0] ** 2 + 2.0 * x[1] ** 2 + 3.0 * x[2] ** 2)


@numba.njit
def grad_H(x, p):
    return (2.0 * SCALE * x[0], 4.0 * SCALE * x[1], 6.0 * SCALE * x[2])


@numba.njit
def S(x, p):
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


@numba.njit
def grad_S(x, p):
    return (x[0], x[1], x[2])


@numba.njit
def J(x, p):
    return (x[0], x[1], x[2])
