"""The metriplectic vector field and its pieces, evaluated from the user functions.

    xi_P = grad H x J                      (Hamiltonian part, keeps H and S)
    xi_g = grad H x (grad H x grad S)      (gradient part, keeps H, lowers S)
    xi   = xi_P + eps * xi_g
"""

import numpy as np
from numba import njit, types

from .signatures import mat, model_kernel, vec
from .vec3 import as_vector, axpy, cross, load


@njit(inline="always")
def gradients(grad_H, grad_S, J, params, buf, x):
    """(grad H, grad S, J) at the tuple ``x``; ``buf`` is a length-3 work array."""
    load(buf, x)
    return (
        as_vector(grad_H(buf, params)),
        as_vector(grad_S(buf, params)),
        as_vector(J(buf, params)),
    )


@njit(inline="always")
def metriplectic(grad_h, grad_s, axial, eps):
    """``grad_h x axial + eps * grad_h x (grad_h x grad_s)``.

    With the exact gradients this is the field xi; with discrete gradients and a
    discrete axial vector parallel to the discrete grad S it is the update
    direction of the energy-exact, entropy-dissipating step (DESIGN.md section 2).
    """
    return axpy(eps, cross(grad_h, cross(grad_h, grad_s)), cross(grad_h, axial))


@njit(inline="always")
def field(grad_H, grad_S, J, params, eps, buf, x):
    """The metriplectic field xi(x)."""
    grad_h, grad_s, axial = gradients(grad_H, grad_S, J, params, buf, x)
    return metriplectic(grad_h, grad_s, axial, eps)


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
