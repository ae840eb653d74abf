"""Discrete gradients and the discrete metriplectic field.

A discrete gradient of F satisfies ``dg . (x' - x) = F(x') - F(x)`` and
``dg(x, x) = grad F(x)``.  With discrete gradients of H and S and a discrete
axial vector ``Jbar`` parallel to ``dg S`` the step

    x' = x + h [ dgH x Jbar + eps dgH x (dgH x dgS) ]

keeps H exactly and lowers S by ``h eps |dgH x dgS|^2`` (DESIGN.md section 2).

Four discrete gradients share this field (``kind``): Gonzalez's, Itoh-Abe's
(coordinate increments), Itoh-Abe's averaged over the six coordinate orderings,
and the average vector field (AVF, Gauss-Legendre nodes and weights in
``coeffs``).

Switching rules.  A difference quotient ``[F(b) - F(a)] / d`` carries
round-off ~ eps |F| / |d| (it is 0/0 when ``d = 0``).  Gonzalez and AVF use
their correction term only where it exceeds its own round-off bound (see
``gonzalez``): elsewhere the uncorrected gradient already satisfies the
identity to round-off.  Itoh-Abe's per-coordinate quotients are replaced by the
partial derivative at the edge's midpoint below ``|d| <= SWITCH * |x|_inf``,
``SWITCH = eps^(1/3)``, where the quotient's round-off and the derivative's
defect ~ |d|^2 |F'''| are both below one ulp of F (this covers a coordinate
that does not move, 0/0).  Every discrete gradient returns, with its value, a
bound on the round-off it carries: the Newton iteration's floor.
"""

import numpy as np
from numba import njit, types

from .field import ZERO, dissipative
from .signatures import i64, mat, model_kernel, vec
from .vec3 import as_vector, axpy, cross, dot, load, norm_inf, scale, sub

GONZALEZ = 0
ITOH_ABE = 1
SYMMETRIZED_ITOH_ABE = 2
AVF = 3

EPS = np.finfo(np.float64).eps

#: Itoh-Abe quotients over coordinate increments ``|d| <= SWITCH * |x|_inf``
#: are replaced by midpoint partial derivatives (module docstring).
SWITCH = EPS ** (1.0 / 3.0)


@njit(inline="always")
def gonzalez(grad_mid, f_old, f_new, dx):
    """Gonzalez's discrete gradient (J. Nonlinear Sci. 6 (1996) 449, doi:10.1007/BF02440162).

        dgF = g + N / |dx|^2 dx,   N = F(x') - F(x) - g . dx,   g = grad F(xbar)

    Symmetric, second order.  With ``g`` any consistent approximation of the
    gradient (AVF's quadrature) it is the projection of ``g`` onto the
    discrete-gradient condition.  Switching rule: N is computed with round-off
    up to ``4 eps (|F(x)| + |F(x')| + |g . dx|)``; where |N| is below that, the
    correction is round-off alone and ``g`` already satisfies the identity to
    round-off, so it is used (this covers dx -> 0, where N = O(|dx|^3) for the
    midpoint gradient, and F nearly constant, where the quotient would be noise
    only).  ``dx`` is divided by its largest component first so that ``|dx|^2``
    neither underflows nor overflows.  Returns ``(dgF, noise)``: ``noise``
    bounds the round-off the correction carries (0 where ``g`` is used).
    """
    slope = dot(grad_mid, dx)
    defect = f_new - f_old - slope
    bound = 4.0 * EPS * (abs(f_old) + abs(f_new) + abs(slope))
    if not abs(defect) > bound:
        return grad_mid, 0.0
    largest = norm_inf(dx)
    unit = (dx[0] / largest, dx[1] / largest, dx[2] / largest)
    length2 = dot(unit, unit)
    return axpy(defect / largest / length2, unit, grad_mid), bound / (largest * np.sqrt(length2))


@njit(inline="always")
def _vertex(x, x_new, mask):
    """The corner of the box spanned by ``x, x'`` with coordinate i from x' where bit i of ``mask`` is set."""
    return (x_new[0] if mask & 1 else x[0], x_new[1] if mask & 2 else x[1], x_new[2] if mask & 4 else x[2])


@njit(inline="always")
def _value(F, params, buf, x, x_new, mask):
    load(buf, _vertex(x, x_new, mask))
    return F(buf, params)


@njit(inline="always")
def _edge_quotient(grad_F, params, buf, x, x_new, i, mask, f_lo, f_hi, size):
    """``[F(hi) - F(lo)] / (x'_i - x_i)`` along the box edge from corner ``mask`` in direction i.

    Below the switch (``|x'_i - x_i| <= SWITCH * size``, including 0/0) the
    partial derivative at the edge's midpoint.  Returns ``(quotient, noise)``,
    ``noise`` the quotient's round-off bound ``4 eps (|F(lo)| + |F(hi)|) / |d|``.
    """
    d = x_new[i] - x[i]
    if abs(d) <= SWITCH * size:
        lo = _vertex(x, x_new, mask)
        load(buf, axpy(0.5, sub(_vertex(x, x_new, mask | (1 << i)), lo), lo))
        return as_vector(grad_F(buf, params))[i], 0.0
    return (f_hi - f_lo) / d, 4.0 * EPS * (abs(f_lo) + abs(f_hi)) / abs(d)


@njit(inline="always")
def itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size):
    """Itoh-Abe's discrete gradient (J. Comput. Phys. 76 (1988) 85, doi:10.1016/0021-9991(88)90132-5).

        dgF_i = [F(x'_1..x'_i, x_{i+1}..x_n) - F(x'_1..x'_{i-1}, x_i..x_n)] / (x'_i - x_i)

    Coordinates change one at a time, in the order 1, 2, 3.  First order, not
    symmetric; needs F only (two extra values), no gradient away from the switch.
    """
    f1 = _value(F, params, buf, x, x_new, 1)
    f3 = _value(F, params, buf, x, x_new, 3)
    q0, n0 = _edge_quotient(grad_F, params, buf, x, x_new, 0, 0, f_old, f1, size)
    q1, n1 = _edge_quotient(grad_F, params, buf, x, x_new, 1, 1, f1, f3, size)
    q2, n2 = _edge_quotient(grad_F, params, buf, x, x_new, 2, 3, f3, f_new, size)
    return (q0, q1, q2), max(n0, n1, n2)


@njit(inline="always")
def _symmetrized_component(grad_F, params, buf, x, x_new, f, i, size):
    """Component i of Itoh-Abe's gradient averaged over the 6 orderings.

    Coordinate i moves first (2 orderings), second (1 each after j or k) or last
    (2 orderings): weights 2, 1, 1, 2 over the four edges in direction i.
    """
    bit = 1 << i
    j = 1 << ((i + 1) % 3)
    k = 1 << ((i + 2) % 3)
    q0, n0 = _edge_quotient(grad_F, params, buf, x, x_new, i, 0, f[0], f[bit], size)
    q1, n1 = _edge_quotient(grad_F, params, buf, x, x_new, i, j, f[j], f[j | bit], size)
    q2, n2 = _edge_quotient(grad_F, params, buf, x, x_new, i, k, f[k], f[k | bit], size)
    q3, n3 = _edge_quotient(grad_F, params, buf, x, x_new, i, j | k, f[j | k], f[7], size)
    return (2.0 * q0 + q1 + q2 + 2.0 * q3) / 6.0, max(n0, n1, n2, n3)


@njit(inline="always")
def symmetrized_itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size):
    """Itoh-Abe's discrete gradient averaged over all 6 orderings of the coordinates.

    A mean of discrete gradients is one; the set of orderings is closed under
    reversal, which exchanges x and x', so ``dg(x, x') = dg(x', x)``: symmetric,
    second order (McLachlan, Quispel, Robidoux, Phil. Trans. R. Soc. A 357 (1999)
    1021, doi:10.1098/rsta.1999.0363).  Needs F at the 6 other corners of the box.
    """
    f = (
        f_old,
        _value(F, params, buf, x, x_new, 1),
        _value(F, params, buf, x, x_new, 2),
        _value(F, params, buf, x, x_new, 3),
        _value(F, params, buf, x, x_new, 4),
        _value(F, params, buf, x, x_new, 5),
        _value(F, params, buf, x, x_new, 6),
        f_new,
    )
    q0, n0 = _symmetrized_component(grad_F, params, buf, x, x_new, f, 0, size)
    q1, n1 = _symmetrized_component(grad_F, params, buf, x, x_new, f, 1, size)
    q2, n2 = _symmetrized_component(grad_F, params, buf, x, x_new, f, 2, size)
    return (q0, q1, q2), max(n0, n1, n2)


@njit(inline="always")
def average_gradient(grad_F, params, buf, x, dx, coeffs):
    """``sum_k w_k grad F(x + s_k dx)``, nodes ``s = coeffs[:n]``, weights ``w = coeffs[n:]`` on [0, 1]."""
    n = coeffs.shape[0] // 2
    total = ZERO
    for k in range(n):
        load(buf, axpy(coeffs[k], dx, x))
        total = axpy(coeffs[n + k], as_vector(grad_F(buf, params)), total)
    return total


@njit
def discrete_gradient(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size):
    """The discrete gradient of F at ``(x, x')`` selected by ``kind``, and its round-off bound.

    AVF: the Gauss-Legendre average of grad F on the segment (Quispel, McLaren,
    J. Phys. A 41 (2008) 045206, doi:10.1088/1751-8113/41/4/045206), made an exact
    discrete gradient for any F by Gonzalez's projection; the projection's
    correction vanishes (to round-off) when the rule integrates grad F exactly.
    """
    if kind == ITOH_ABE:
        return itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size)
    if kind == SYMMETRIZED_ITOH_ABE:
        return symmetrized_itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size)
    dx = sub(x_new, x)
    if kind == AVF:
        return gonzalez(average_gradient(grad_F, params, buf, x, dx, coeffs), f_old, f_new, dx)
    load(buf, axpy(0.5, dx, x))
    return gonzalez(as_vector(grad_F(buf, params)), f_old, f_new, dx)


@njit(inline="always")
def discrete_axial(axial, grad_s):
    """``Jbar = (J . n) n`` with ``n = dgS / |dgS|``: parallel to dgS, so S is a Casimir.

    Where ``dgS = 0`` the step cannot change S whatever ``Jbar`` is, and
    ``Jbar = J(xbar)`` is used.  Normalising by the largest component first
    keeps the projection free of overflow and underflow, so ``Jbar`` is well
    defined however small ``dgS`` is (oscillator at z = 0, degenerate example
    on y = 0).
    """
    size = norm_inf(grad_s)
    if size == 0.0 or not np.isfinite(size):
        return axial
    n = (grad_s[0] / size, grad_s[1] / size, grad_s[2] / size)  # not 1/size: it overflows for subnormal sizes
    return scale(dot(axial, n) / dot(n, n), n)


@njit
def discrete_field(kind, coeffs, H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, H_old, S_old, x_new):
    """The discrete field F(x, x') and (H(x'), S(x'), dgH, dgS, Jbar, noise).

    Compiled as a function, not inlined (it is called from several places and
    inlining its four discrete gradients multiplies compile time).

    ``J`` is called only with the Hamiltonian part on (else ``Jbar = 0``); S and
    its gradient are always needed, to keep ``Jbar`` parallel to dgS.
    ``noise`` bounds the round-off that the discrete gradients carry into F: the
    floor below which a Newton correction cannot go.
    """
    size = max(norm_inf(x), norm_inf(x_new))
    load(buf, x_new)
    H_new = H(buf, params)
    S_new = S(buf, params)
    dg_h, noise_h = discrete_gradient(kind, coeffs, H, grad_H, params, buf, x, x_new, H_old, H_new, size)
    dg_s, noise_s = discrete_gradient(kind, coeffs, S, grad_S, params, buf, x, x_new, S_old, S_new, size)
    size_h, size_s = norm_inf(dg_h), norm_inf(dg_s)
    noise = eps * (2.0 * noise_h * size_s + noise_s * size_h) * size_h
    axial_bar = ZERO
    if hamiltonian:
        load(buf, axpy(0.5, sub(x_new, x), x))
        axial = as_vector(J(buf, params))
        axial_bar = discrete_axial(axial, dg_s)
        noise += noise_h * norm_inf(axial) + (size_h * norm_inf(axial) * noise_s / size_s if size_s > 0.0 else 0.0)
    F = dissipative(dg_h, dg_s, eps, cross(dg_h, axial_bar))
    return F, H_new, S_new, dg_h, dg_s, axial_bar, noise


@model_kernel(types.void, i64, vec, vec, vec, mat)
def evaluate(H, grad_H, S, grad_S, J, params, kind, coeffs, x_old, x_new, out):
    """Rows of ``out`` (3, 3): dgH, dgS and Jbar at the pair ``(x_old, x_new)``.

    Caller: ``DiscreteGradient.discrete_gradients`` (tests, diagnostics).
    """
    buf = np.empty(3)
    x = (x_old[0], x_old[1], x_old[2])
    xn = (x_new[0], x_new[1], x_new[2])
    load(buf, x)
    H_old = H(buf, params)
    S_old = S(buf, params)
    F, H_new, S_new, dg_h, dg_s, axial, noise = discrete_field(
        kind, coeffs, H, grad_H, S, grad_S, J, params, 0.0, True, buf, x, H_old, S_old, xn
    )
    for k in range(3):
        out[0, k] = dg_h[k]
        out[1, k] = dg_s[k]
        out[2, k] = axial[k]
