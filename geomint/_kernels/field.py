"""The metriplectic vector field and its pieces, evaluated from the user functions.

    xi_P = grad H x J                      (Hamiltonian part, keeps H and S)
    xi_g = grad H x (grad H x grad S)      (gradient part, keeps H, lowers S)
    xi   = xi_P + eps * xi_g

Kernels take ``hamiltonian`` (include xi_P) and ``eps`` (include xi_g when
nonzero) and evaluate only what is switched on: with the Hamiltonian part off
``J`` is never called, with ``eps = 0`` the field never calls ``grad S``.
The model arrives as ``layout.Model`` (first-class functions and params).
"""

import math

import numpy as np
from numba import njit

from .._cache import CACHE
from .jit import inner
from .layout import FN_GRAD_H, FN_GRAD_S, FN_H, FN_POISSON, FN_S, UNKNOWN
from .vec3 import ZERO, as_vector, axpy, cross, is_finite, load, norm_inf, scale

#: gradients with largest components in [SAFE_LOW, SAFE_HIGH] give a triple product
#: (at most 2^600 or at least 2^-600) that neither overflows nor underflows.
SAFE_LOW = 2.0**-200
SAFE_HIGH = 2.0**200


@njit(inline="always")
def dissipative(grad_h, grad_s, eps, base):
    """``base + eps * grad_h x (grad_h x grad_s)``.

    Outside ``[SAFE_LOW, SAFE_HIGH]`` (states of size 1e-150 or 1e100) it is
    evaluated as ``(eps 2^(2i+j)) u x (u x v)`` with ``u = 2^-i grad_h``,
    ``v = 2^-j grad_s`` (``2^i``, ``2^j`` the binary orders of their largest
    components), so the triple product neither underflows nor overflows where
    the result does not.  Scaling by powers of two is exact: both branches give
    the same bits wherever both can be evaluated, so a run and the same run
    scaled by a power of two stay bitwise alike.  Inlined (the hot path of every
    field evaluation); the rare scaled branch is a call.
    """
    a = norm_inf(grad_h)
    b = norm_inf(grad_s)
    if (
        (SAFE_LOW <= a <= SAFE_HIGH and SAFE_LOW <= b <= SAFE_HIGH)
        or a == 0.0
        or b == 0.0
        or not (np.isfinite(a) and np.isfinite(b))
    ):
        return axpy(eps, cross(grad_h, cross(grad_h, grad_s)), base)
    return _dissipative_scaled(grad_h, grad_s, eps, base, a, b)


@inner
def _dissipative_scaled(grad_h, grad_s, eps, base, a, b):
    """``dissipative`` for gradients whose largest components ``a``, ``b`` lie outside the safe range."""
    i = math.frexp(a)[1]
    j = math.frexp(b)[1]
    if i < -1000 or j < -1000:  # subnormal gradients: 2^-i would overflow
        return axpy(eps, cross(grad_h, cross(grad_h, grad_s)), base)
    u = scale(math.ldexp(1.0, -i), grad_h)
    v = scale(math.ldexp(1.0, -j), grad_s)
    return axpy(math.ldexp(eps, 2 * i + j), cross(u, cross(u, v)), base)


def _field(model, eps, hamiltonian, buf, x):
    """The metriplectic field xi(x), with only the switched-on parts evaluated."""
    load(buf, x)
    grad_h = as_vector(model.grad_H(buf, model.params))
    value = cross(grad_h, as_vector(model.J(buf, model.params))) if hamiltonian else ZERO
    if eps != 0.0:
        value = dissipative(grad_h, as_vector(model.grad_S(buf, model.params)), eps, value)
    return value


#: the field as a call (Jacobians, starts, failure reports: compiled once)
field = inner(_field)
#: the field inlined where it is called: the explicit steps' stages, where a call costs more than the arithmetic
field_inlined = njit(inline="always")(_field)


@njit(cache=CACHE, error_model="numpy")
def evaluate(model, X, out_H, out_S, out_grad_H, out_grad_S, out_J):
    """Fill H, S, grad H, grad S and J at every row of ``X`` (n, 3).

    Caller: ``MetriplecticSystem._evaluate``, which allocates the outputs.
    """
    buf = np.empty(3)
    p = model.params
    for i in range(X.shape[0]):
        load(buf, (X[i, 0], X[i, 1], X[i, 2]))
        out_H[i] = model.H(buf, p)
        out_S[i] = model.S(buf, p)
        gh = as_vector(model.grad_H(buf, p))
        gs = as_vector(model.grad_S(buf, p))
        axial = as_vector(model.J(buf, p))
        for k in range(3):
            out_grad_H[i, k] = gh[k]
            out_grad_S[i, k] = gs[k]
            out_J[i, k] = axial[k]


@inner
def non_finite_culprit(model, buf, x, hamiltonian):
    """The first user function (``layout.FN_*``) that is not finite at ``x``, 0 if none is.

    Called only after a step produced a non-finite value, to name the function in the report.
    """
    load(buf, x)
    p = model.params
    if not np.isfinite(model.H(buf, p)):
        return FN_H
    if not is_finite(as_vector(model.grad_H(buf, p))):
        return FN_GRAD_H
    if not np.isfinite(model.S(buf, p)):
        return FN_S
    if not is_finite(as_vector(model.grad_S(buf, p))):
        return FN_GRAD_S
    if hamiltonian and not is_finite(as_vector(model.J(buf, p))):
        return FN_POISSON
    return UNKNOWN
