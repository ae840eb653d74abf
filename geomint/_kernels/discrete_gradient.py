"""Discrete gradients and the discrete metriplectic field.

A discrete gradient of F satisfies ``dg . (x' - x) = F(x') - F(x)`` and
``dg(x, x) = grad F(x)``.  With discrete gradients of H and S and a discrete
axial vector ``Jbar`` parallel to ``dg S`` the step

    x' = x + h [ dgH x Jbar + eps dgH x (dgH x dgS) ]

keeps H exactly and lowers S by ``h eps |dgH x dgS|^2`` (DESIGN.md section 2).
"""

import numpy as np
from numba import njit, types

from .field import ZERO, dissipative
from .signatures import i64, mat, model_kernel, vec
from .vec3 import as_vector, axpy, cross, dot, load, norm_inf, scale, sub

GONZALEZ = 0

EPS = np.finfo(np.float64).eps


@njit(inline="always")
def gonzalez(grad_mid, f_old, f_new, dx):
    """Gonzalez's discrete gradient (J. Nonlinear Sci. 6 (1996) 449, doi:10.1007/BF02440162).

        dgF = grad F(xbar) + N / |dx|^2 dx,   N = F(x') - F(x) - grad F(xbar) . dx

    Symmetric, second order.  Switching rule: N is computed with round-off up
    to ``4 eps (|F(x)| + |F(x')| + |grad F . dx|)``; where |N| is below that,
    the correction is round-off alone and the midpoint gradient ``grad F(xbar)``
    already satisfies the discrete-gradient identity to round-off, so it is
    used (this covers dx -> 0, where N = O(|dx|^3), and F nearly constant).
    Returns ``(dgF, noise)``: ``noise`` bounds the round-off the correction
    carries, that bound divided by |dx| (0 for the midpoint gradient).
    """
    slope = dot(grad_mid, dx)
    defect = f_new - f_old - slope
    bound = 4.0 * EPS * (abs(f_old) + abs(f_new) + abs(slope))
    if not abs(defect) > bound:
        return grad_mid, 0.0
    dx2 = dot(dx, dx)
    return axpy(defect / dx2, dx, grad_mid), bound / np.sqrt(dx2)


@njit(inline="always")
def discrete_axial(axial, grad_s):
    """``Jbar = (J . n) n`` with ``n = dgS / |dgS|``: parallel to dgS, so S is a Casimir.

    Where ``dgS = 0`` the step cannot change S whatever ``Jbar`` is, and
    ``Jbar = J(xbar)`` is used.  Normalising by the largest component first
    keeps the projection free of overflow and underflow.
    """
    size = norm_inf(grad_s)
    if size == 0.0 or not np.isfinite(size):
        return axial
    n = (grad_s[0] / size, grad_s[1] / size, grad_s[2] / size)  # not 1/size: it overflows for subnormal sizes
    return scale(dot(axial, n) / dot(n, n), n)


@njit(inline="always")
def discrete_field(kind, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_old, S_old, x_new):
    """The discrete field F(x, x') and (H(x'), S(x'), dgH, dgS, Jbar, noise).

    ``J`` is called only with the Hamiltonian part on (else ``Jbar = 0``); S and
    its gradient are always needed, to keep ``Jbar`` parallel to dgS.
    ``noise`` bounds the round-off that the discrete gradients carry into F: the
    floor below which a Newton correction cannot go.
    """
    dx = sub(x_new, x)
    mid = axpy(0.5, dx, x)
    load(buf, x_new)
    H_new = H(buf, params)
    S_new = S(buf, params)
    load(buf, mid)
    # kind selects the discrete gradient; GONZALEZ is the only one so far.
    dg_h, noise_h = gonzalez(as_vector(grad_H(buf, params)), H_old, H_new, dx)
    dg_s, noise_s = gonzalez(as_vector(grad_S(buf, params)), S_old, S_new, dx)
    size_h, size_s = norm_inf(dg_h), norm_inf(dg_s)
    noise = eps * (2.0 * noise_h * size_s + noise_s * size_h) * size_h
    axial_bar = ZERO
    if hamiltonian:
        axial = as_vector(J(buf, params))
        axial_bar = discrete_axial(axial, dg_s)
        noise += noise_h * norm_inf(axial) + (size_h * norm_inf(axial) * noise_s / size_s if size_s > 0.0 else 0.0)
    F = dissipative(dg_h, dg_s, eps, cross(dg_h, axial_bar))
    return F, H_new, S_new, dg_h, dg_s, axial_bar, noise


@model_kernel(types.void, i64, vec, vec, mat)
def evaluate(H, grad_H, S, grad_S, J, params, kind, x_old, x_new, out):
    """Rows of ``out`` (3, 3): dgH, dgS and Jbar at the pair ``(x_old, x_new)``.

    Caller: ``Gonzalez.discrete_gradients`` (tests, diagnostics).
    """
    buf = np.empty(3)
    x = (x_old[0], x_old[1], x_old[2])
    xn = (x_new[0], x_new[1], x_new[2])
    load(buf, x)
    H_old = H(buf, params)
    S_old = S(buf, params)
    F, H_new, S_new, dg_h, dg_s, axial, noise = discrete_field(
        kind, H, grad_H, S, grad_S, J, params, 0.0, True, buf, x, H_old, S_old, xn
    )
    for k in range(3):
        out[0, k] = dg_h[k]
        out[1, k] = dg_s[k]
        out[2, k] = axial[k]
