"""The discrete metriplectic field F(x, x') of a discrete gradient.

With discrete gradients of H and S and a discrete axial vector ``Jbar``
parallel to ``dg S`` the step

    x' = x + h [ dgH x Jbar + eps dgH x (dgH x dgS) ]

keeps H exactly and lowers S by ``h eps |dgH x dgS|^2`` (docs/design.md
section 2).  ``discrete_field`` is compiled once per kind of discrete gradient
(``dispatch.INLINED``), the gradient inlined, and once for integer codes.
"""

import numpy as np
from numba import njit, types

from .._cache import CACHE
from .dispatch import INLINED, by_code
from .field import dissipative
from .jit import hot, inner, typed_inline
from .layout import EPS
from .roundoff import origin_terms, term_scale
from .vec3 import ZERO, as_vector, axpy, cross, dot, is_finite, load, norm_inf, scale, sub


@hot
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


@hot
def polish(F, dg_h, dg_s, eps):
    """F with ``F . dgH = 0`` and ``F . dgS = -eps |dgH x dgS|^2`` restored to the rounding of |F|.

    Both hold identically in exact arithmetic (triple products with a repeated
    vector), so this changes the scheme by round-off only; but the cross
    products round at the size of their *terms*, which in a stiff step
    (``h eps |dgH|^2 |dgS| >> |x|``) exceed |F| by orders of magnitude, and that
    rounding, along dgH, would move H by more than an ulp.  F loses its
    component along dgH, then is moved along ``w``, the part of dgS orthogonal
    to dgH (which keeps ``F . dgH``), to the exact rate of S; where ``w`` is
    itself round-off (dgS parallel to dgH: an equilibrium of the gradient
    part) that second move is skipped.  Computed with ``u = dgH / a``,
    ``v = dgS / b`` (a, b their largest components), so it works at any scale.
    """
    a, b = norm_inf(dg_h), norm_inf(dg_s)
    if a == 0.0 or not (np.isfinite(a) and is_finite(F)):
        return F
    u = (dg_h[0] / a, dg_h[1] / a, dg_h[2] / a)
    uu = dot(u, u)
    F = axpy(-dot(F, u) / uu, u, F)
    if b == 0.0 or not np.isfinite(b):
        return F
    v = (dg_s[0] / b, dg_s[1] / b, dg_s[2] / b)
    w = axpy(-dot(v, u) / uu, u, v)
    ww = dot(w, w)
    if not ww > (64.0 * EPS) ** 2 * dot(v, v):
        return F
    sigma = cross(u, v)
    rate = -(eps * a) * (a * b) * dot(sigma, sigma)  # -eps |dgH x dgS|^2 / b
    return axpy((rate - dot(F, v)) / ww, w, F)


#: ``polish`` is skipped where the rounding it removes moves H and S by at most an ulp of their terms, a quarter of
#: the acceptance's allowance (``layout.ACCEPT_ULPS``): the worst-case factor of ``polish_moves``
ROUNDING_BOUND = 32.0


@hot
def polish_moves(h, eps, axial_size, size_h, size_s, terms_h, terms_s):
    """Whether ``polish`` can move H or S by an ulp of their terms (``terms_h``, ``terms_s``): whether the rounding
    of F's cross products, carried into the step, can.

    Each component of ``F = dgH x Jbar + eps dgH x (dgH x dgS)`` rounds within ``9 eps T_F``,
    ``T_F = |dgH| (|Jbar| + eps |dgH| |dgS|)`` (infinity norms: 2 eps per cross product of the sizes of its
    factors, twice that through the nested one); the step ``h F`` then changes H by the rounding along dgH, at
    most ``27 eps |h| T_F |dgH|``, and S by at most ``27 eps |h| T_F |dgS|`` (the identity
    ``F(x') - F(x) = dgF . (x' - x)``).  Where both stay within one ulp of the terms (``ROUNDING_BOUND = 32``
    in place of 27), ``polish`` changes the step by less than the acceptance's round-off allowance: a step well
    inside the time scale (``|h| |Jbar| |dgH| << H``).  A stiff step, or a non-finite size, is polished.
    Products are grouped so that they neither overflow nor underflow where the sizes do not (``gain`` is
    scale-free under ``x -> lam x, h -> h / lam, eps -> eps / lam``).
    """
    gain = abs(h) * (axial_size + eps * size_h * size_s)
    return not (
        ROUNDING_BOUND * gain * size_h * size_h <= terms_h and ROUNDING_BOUND * gain * size_h * size_s <= terms_s
    )


def _discrete_field_with(discrete_gradient):
    def discrete_field(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales):
        """The discrete field F(x, x') and ``(H(x'), S(x'), dgH, dgS, Jbar, noise)``.

        ``h`` and ``scales = (|J|, |dgH|, |dgS|)`` (from the caller's previous
        evaluation; zeros for none) give the gains with which round-off in dgH and
        dgS moves the step ``x' = x + h F`` (Gonzalez's switching rule):
        ``|h| (|J| + 2 eps |dgH| |dgS|)`` for dgH and ``|h| (|J| / |dgS| + eps |dgH|^2)``
        for dgS (through the direction of ``Jbar``).

        ``J`` is called only with the Hamiltonian part on (else ``Jbar = 0``); S and
        its gradient are always needed, to keep ``Jbar`` parallel to dgS.
        ``noise`` bounds the round-off that the discrete gradients carry into F: the
        floor below which a Newton correction cannot go.
        """
        p = model.params
        size = max(norm_inf(x), norm_inf(x_new))
        load(buf, x_new)
        H_new = model.H(buf, p)
        S_new = model.S(buf, p)
        axial_size, size_h, size_s = scales
        gain_h = abs(h) * ((axial_size if hamiltonian else 0.0) + 2.0 * eps * size_h * size_s)
        gain_s = abs(h) * ((axial_size / size_s if hamiltonian and size_s > 0.0 else 0.0) + eps * size_h * size_h)
        dg_h, noise_h = discrete_gradient(
            kind,
            coeffs,
            model.H,
            model.grad_H,
            p,
            buf,
            x,
            x_new,
            H_old,
            H_new,
            size,
            gain_h,
            origin_terms(model.origin, 0, x_new),
        )
        dg_s, noise_s = discrete_gradient(
            kind,
            coeffs,
            model.S,
            model.grad_S,
            p,
            buf,
            x,
            x_new,
            S_old,
            S_new,
            size,
            gain_s,
            origin_terms(model.origin, 4, x_new),
        )
        size_h, size_s = norm_inf(dg_h), norm_inf(dg_s)
        noise = eps * (2.0 * noise_h * size_s + noise_s * size_h) * size_h
        axial_bar = ZERO
        if hamiltonian:
            load(buf, axpy(0.5, sub(x_new, x), x))
            axial = as_vector(model.J(buf, p))
            axial_bar = discrete_axial(axial, dg_s)
            noise += noise_h * norm_inf(axial) + (size_h * norm_inf(axial) * noise_s / size_s if size_s > 0.0 else 0.0)
        F = dissipative(dg_h, dg_s, eps, cross(dg_h, axial_bar))
        if polish_moves(
            h,
            eps,
            norm_inf(axial_bar),
            size_h,
            size_s,
            term_scale(H_old, H_new, dg_h, x_new, origin_terms(model.origin, 0, x_new)),
            term_scale(S_old, S_new, dg_s, x_new, origin_terms(model.origin, 4, x_new)),
        ):
            F = polish(F, dg_h, dg_s, eps)
        return F, H_new, S_new, dg_h, dg_s, axial_bar, noise

    return discrete_field


#: the discrete field of each kind of discrete gradient, the gradient inlined (a call carrying the user's functions
#: costs more than the quotient), and of integer codes (programs mixing kinds: chosen at run time)
_FIELDS = {marker: hot(_discrete_field_with(dg)) for marker, dg in INLINED.items()}


_FIELD_BY_CODE = inner(_discrete_field_with(by_code))


def discrete_field(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales):
    """The discrete field F(x, x') and ``(H(x'), S(x'), dgH, dgS, Jbar, noise)`` (``_discrete_field_with``); ``kind``
    a kind marker (chosen when the kernel is compiled, so a run compiles only its own discrete gradient) or an
    integer code."""
    field = _FIELD_BY_CODE if isinstance(kind, (int, np.integer)) else _FIELDS[type(kind)]
    return field(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales)


@typed_inline(discrete_field)
def _discrete_field_typed(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales):
    field = _FIELD_BY_CODE if isinstance(kind, types.Integer) else _FIELDS[kind.instance_class]
    return lambda kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales: field(
        kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales
    )


@njit(cache=CACHE, error_model="numpy")
def evaluate(model, kind, coeffs, x_old, x_new, out):
    """Rows of ``out`` (3, 3): dgH, dgS and Jbar at the pair ``(x_old, x_new)``.

    Caller: ``DiscreteGradient.discrete_gradients`` (tests, diagnostics).
    """
    buf = np.empty(3)
    x = (x_old[0], x_old[1], x_old[2])
    xn = (x_new[0], x_new[1], x_new[2])
    load(buf, x)
    H_old = model.H(buf, model.params)
    S_old = model.S(buf, model.params)
    F, H_new, S_new, dg_h, dg_s, axial, noise = discrete_field(
        kind, coeffs, model, 0.0, True, buf, x, H_old, S_old, xn, 0.0, (0.0, 0.0, 0.0)
    )
    for k in range(3):
        out[0, k] = dg_h[k]
        out[1, k] = dg_s[k]
        out[2, k] = axial[k]
