"""The metriplectic vector field and its pieces, evaluated from the user functions.

    xi_P = grad H x J                      (Hamiltonian part, keeps H and S)
    xi_g = grad H x (grad H x grad S)      (gradient part, keeps H, lowers S)
    xi   = xi_P + eps * xi_g

Kernels take ``hamiltonian`` (include xi_P) and ``eps`` (include xi_g when
nonzero) and evaluate only what is switched on: with the Hamiltonian part off
``J`` is never called, with ``eps = 0`` the field never calls ``grad S``.
"""

import numpy as np
from numba import njit, types

from .signatures import mat, model_kernel, vec
from .vec3 import as_vector, axpy, cross, load, norm_inf


@njit(inline="always")
def gradients(grad_H, grad_S, J, params, buf, x):
    """(grad H, grad S, J) at the tuple ``x``; ``buf`` is a length-3 work array."""
    load(buf, x)
    return (
        as_vector(grad_H(buf, params)),
        as_vector(grad_S(buf, params)),
        as_vector(J(buf, params)),
    )


ZERO = (0.0, 0.0, 0.0)


@njit(inline="always")
def dissipative(grad_h, grad_s, eps, base):
    """``base + eps * grad_h x (grad_h x grad_s)``.

    Evaluated as ``((eps a) (a b)) u x (u x v)`` with ``a, b`` the largest
    components of grad_h, grad_s and ``u, v`` the scaled vectors, so the
    triple product neither underflows nor overflows where the result does not
    (states of size 1e-150 or 1e100).
    """
    a = norm_inf(grad_h)
    b = norm_inf(grad_s)
    if a == 0.0 or b == 0.0 or not (np.isfinite(a) and np.isfinite(b)):
        return axpy(eps, cross(grad_h, cross(grad_h, grad_s)), base)
    u = (grad_h[0] / a, grad_h[1] / a, grad_h[2] / a)
    v = (grad_s[0] / b, grad_s[1] / b, grad_s[2] / b)
    return axpy((eps * a) * (a * b), cross(u, cross(u, v)), base)


@njit(inline="always")
def field(grad_H, grad_S, J, params, eps, hamiltonian, buf, x):
    """The metriplectic field xi(x), with only the switched-on parts evaluated."""
    load(buf, x)
    grad_h = as_vector(grad_H(buf, params))
    value = cross(grad_h, as_vector(J(buf, params))) if hamiltonian else ZERO
    if eps != 0.0:
        value = dissipative(grad_h, as_vector(grad_S(buf, params)), eps, value)
    return value


@model_kernel(types.void, mat, vec, vec, mat, mat, mat)
def evaluate(H, grad_H, S, grad_S, J, params, X, out_H, out_S, out_grad_H, out_grad_S, out_J):
    """Fill H, S, grad H, grad S and J at every row of ``X`` (n, 3).

    Caller: ``MetriplecticSystem._evaluate``, which allocates the outputs.
    """
    buf = np.empty(3)
    for i in range(X.shape[0]):
        x = (X[i, 0], X[i, 1], X[i, 2])
        gh, gs, axial = gradients(grad_H, grad_S, J, params, buf, x)
        out_H[i] = H(buf, params)
        out_S[i] = S(buf, params)
        for k in range(3):
            out_grad_H[i, k] = gh[k]
            out_grad_S[i, k] = gs[k]
            out_J[i, k] = axial[k]
