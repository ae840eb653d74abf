"""Discrete gradients and the discrete metriplectic field.

A discrete gradient of F satisfies ``dg . (x' - x) = F(x') - F(x)`` and
``dg(x, x) = grad F(x)``.  With discrete gradients of H and S and a discrete
axial vector ``Jbar`` parallel to ``dg S`` the step

    x' = x + h [ dgH x Jbar + eps dgH x (dgH x dgS) ]

keeps H exactly and lowers S by ``h eps |dgH x dgS|^2`` (docs/design.md section 2).

Four discrete gradients share this field (``kind``): Gonzalez's, Itoh-Abe's
(coordinate increments), Itoh-Abe's averaged over the six coordinate orderings,
and the average vector field (AVF, Gauss-Legendre nodes and weights in
``coeffs``).

Switching rules.  A difference quotient ``[F(b) - F(a)] / d`` carries
round-off ~ eps T / |d|, with T the size of the *terms* of F, not of F: at an
equilibrium of the metriplectic Lorenz system the terms of H are ~1500 while
H ~ -30 (it is 0/0 when ``d = 0``).  T is estimated as
``max(|F(x)|, |F(x')|, sum_i |d_i F x_i|, |F(0)| + sum_i |d_i F(0) x_i|)``:
for homogeneous F of degree k, ``x . grad F = k F``; where terms cancel,
``sum_i |d_i F x_i|`` still measures them; and the last entry measures the
constant and linear terms, which ``x . grad F`` misses where they cancel the
others (``H = |x - c|^2 / 2`` written out, ``-r z`` in the Lorenz system near
``z = r``); ``term_scale``, ``origin_terms``.  Gonzalez and AVF use their correction term only where it exceeds its
own round-off bound (see ``gonzalez``): elsewhere the uncorrected gradient
already satisfies the identity to round-off, and adding the correction would
add noise ~ eps T / |dx| that no Newton iteration can remove.  The small
defect so skipped (< 2 ulp of T) has a consistent sign along a trajectory;
whole steps are anchored to H(x0) (``steps.discrete_gradient_step``) and
composed steps are pulled back onto H(x0) when they stray
(``composition.composed_step``), so it never accumulates.  Itoh-Abe's per-coordinate quotients are replaced by the
partial derivative at the edge's midpoint below ``|d| <= SWITCH * |x|_inf``,
``SWITCH = eps^(1/3)``, where the quotient's round-off and the derivative's
defect ~ |d|^2 |F'''| are both below one ulp of F (this covers a coordinate
that does not move, 0/0); the few ulps by which the switched gradient then
misses ``dg . dx = F(x') - F(x)`` (the rounding of the F values, which a
quotient would absorb) are removed by Gonzalez's projection under its own
switching rule (``_exact``): without it a step near an equilibrium converges to
a root that keeps H to ~5 ulp only.  Every discrete gradient returns, with its value, a
bound on the round-off it carries: the Newton iteration's floor.
"""

import numpy as np
from numba import njit, types
from numba.extending import overload

from .._cache import CACHE
from .field import dissipative
from .jit import inner
from .layout import AVF, ITOH_ABE, SYMMETRIZED_ITOH_ABE, AVFKind, GonzalezKind, ItohAbeKind, SymmetrizedItohAbeKind
from .vec3 import ZERO, abs_dot, as_vector, axpy, cross, dot, is_finite, load, norm_inf, scale, sub

EPS = np.finfo(np.float64).eps

#: Itoh-Abe quotients over coordinate increments ``|d| <= SWITCH * |x|_inf``
#: are replaced by midpoint partial derivatives (module docstring).
SWITCH = EPS ** (1.0 / 3.0)


@inner
def term_scale(f_old, f_new, gradient, x, base):
    """``max(|F(x)|, |F(x')|, sum_i |d_i F x_i|, base)``: the size of the terms of F (module docstring);
    ``base`` is ``origin_terms`` at x."""
    return max(abs(f_old), abs(f_new), abs_dot(gradient, x), base)


@inner
def origin_terms(origin, at, x):
    """``|F(0)| + sum_i |d_i F(0) x_i|``, with ``F(0), grad F(0)`` at ``origin[at:at + 4]``
    (``layout.Model.origin``: H at 0, S at 4): the constant and linear terms of F at x."""
    return abs(origin[at]) + abs(origin[at + 1] * x[0]) + abs(origin[at + 2] * x[1]) + abs(origin[at + 3] * x[2])


@inner
def gonzalez(grad_mid, f_old, f_new, dx, x_new, gain, base):
    """Gonzalez's discrete gradient (J. Nonlinear Sci. 6 (1996) 449, doi:10.1007/BF02440162).

        dgF = g + N / |dx|^2 dx,   N = F(x') - F(x) - g . dx,   g = grad F(xbar)

    Symmetric, second order.  With ``g`` any consistent approximation of the
    gradient (AVF's quadrature) it is the projection of ``g`` onto the
    discrete-gradient condition.  Switching rule: N carries round-off up to
    ``bound = 2 eps T`` (``term_scale``); where |N| is below that the correction
    is round-off alone and ``g`` already satisfies the identity to round-off, so
    it is used (this covers F nearly constant, where the quotient would be noise
    only).  ``g`` is used too where the correction's round-off, ``bound / |dx|``,
    carried into the step by ``gain`` (how far x' moves per unit change of the
    discrete gradient: ``|h| (|J| + eps |dgH| |dgS| ...)``, see ``discrete_field``),
    would exceed 1% of the step, ``bound gain > |dx|^2 / 100``: no iteration
    could converge on such a quotient, and there ``|dx| <= 10 sqrt(bound gain)``
    makes the skipped defect N = O(|dx|^3) far smaller than round-off; and
    where ``dx = 0`` (a state at rest: no direction to correct along).  ``dx`` is
    divided by its largest component first so that ``|dx|^2`` neither
    underflows nor overflows.  Returns ``(dgF, noise)``: ``noise`` bounds the
    round-off the correction carries (0 where ``g`` is used).
    """
    slope = dot(grad_mid, dx)
    defect = f_new - f_old - slope
    bound = 2.0 * EPS * term_scale(f_old, f_new, grad_mid, x_new, base)
    largest = norm_inf(dx)
    if not abs(defect) > bound or not bound * gain <= 0.01 * largest * largest or largest == 0.0:
        return grad_mid, 0.0
    unit = (dx[0] / largest, dx[1] / largest, dx[2] / largest)
    length2 = dot(unit, unit)
    return axpy(defect / largest / length2, unit, grad_mid), bound / (largest * np.sqrt(length2))


@inner
def _vertex(x, x_new, mask):
    """The corner of the box spanned by ``x, x'`` with coordinate i from x' where bit i of ``mask`` is set."""
    return (x_new[0] if mask & 1 else x[0], x_new[1] if mask & 2 else x[1], x_new[2] if mask & 4 else x[2])


@inner
def _value(F, params, buf, x, x_new, mask):
    load(buf, _vertex(x, x_new, mask))
    return F(buf, params)


@inner
def _edge_quotient(grad_F, params, buf, x, x_new, i, mask, f_lo, f_hi, size, base):
    """``[F(hi) - F(lo)] / (x'_i - x_i)`` along the box edge from corner ``mask`` in direction i.

    Below the switch (``|x'_i - x_i| <= SWITCH * size``, including 0/0) the
    partial derivative at the edge's midpoint.  Returns ``(quotient, noise)``,
    ``noise`` the quotient's round-off bound ``4 eps (|F(lo)| + |F(hi)| + base) / |d|`` (``base``: the
    constant and linear terms, ``origin_terms``).
    """
    d = x_new[i] - x[i]
    if abs(d) <= SWITCH * size:
        lo = _vertex(x, x_new, mask)
        load(buf, axpy(0.5, sub(_vertex(x, x_new, mask | (1 << i)), lo), lo))
        return as_vector(grad_F(buf, params))[i], 0.0
    return (f_hi - f_lo) / d, 4.0 * EPS * (abs(f_lo) + abs(f_hi) + base) / abs(d)


@inner
def itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size, base):
    """Itoh-Abe's discrete gradient (J. Comput. Phys. 76 (1988) 85, doi:10.1016/0021-9991(88)90132-5).

        dgF_i = [F(x'_1..x'_i, x_{i+1}..x_n) - F(x'_1..x'_{i-1}, x_i..x_n)] / (x'_i - x_i)

    Coordinates change one at a time, in the order 1, 2, 3.  First order, not
    symmetric; needs F only (two extra values), no gradient away from the switch.
    """
    f1 = _value(F, params, buf, x, x_new, 1)
    f3 = _value(F, params, buf, x, x_new, 3)
    q0, n0 = _edge_quotient(grad_F, params, buf, x, x_new, 0, 0, f_old, f1, size, base)
    q1, n1 = _edge_quotient(grad_F, params, buf, x, x_new, 1, 1, f1, f3, size, base)
    q2, n2 = _edge_quotient(grad_F, params, buf, x, x_new, 2, 3, f3, f_new, size, base)
    return (q0, q1, q2), max(n0, n1, n2)


@inner
def _symmetrized_component(grad_F, params, buf, x, x_new, f, i, size, base):
    """Component i of Itoh-Abe's gradient averaged over the 6 orderings.

    Coordinate i moves first (2 orderings), second (1 each after j or k) or last
    (2 orderings): weights 2, 1, 1, 2 over the four edges in direction i.
    """
    bit = 1 << i
    j = 1 << ((i + 1) % 3)
    k = 1 << ((i + 2) % 3)
    q0, n0 = _edge_quotient(grad_F, params, buf, x, x_new, i, 0, f[0], f[bit], size, base)
    q1, n1 = _edge_quotient(grad_F, params, buf, x, x_new, i, j, f[j], f[j | bit], size, base)
    q2, n2 = _edge_quotient(grad_F, params, buf, x, x_new, i, k, f[k], f[k | bit], size, base)
    q3, n3 = _edge_quotient(grad_F, params, buf, x, x_new, i, j | k, f[j | k], f[7], size, base)
    return (2.0 * q0 + q1 + q2 + 2.0 * q3) / 6.0, max(n0, n1, n2, n3)


@inner
def symmetrized_itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size, base):
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
    q0, n0 = _symmetrized_component(grad_F, params, buf, x, x_new, f, 0, size, base)
    q1, n1 = _symmetrized_component(grad_F, params, buf, x, x_new, f, 1, size, base)
    q2, n2 = _symmetrized_component(grad_F, params, buf, x, x_new, f, 2, size, base)
    return (q0, q1, q2), max(n0, n1, n2)


@inner
def average_gradient(grad_F, params, buf, x, dx, coeffs):
    """``sum_k w_k grad F(x + s_k dx)``, nodes ``s = coeffs[:n]``, weights ``w = coeffs[n:]`` on [0, 1]."""
    n = coeffs.shape[0] // 2
    total = ZERO
    for k in range(n):
        load(buf, axpy(coeffs[k], dx, x))
        total = axpy(coeffs[n + k], as_vector(grad_F(buf, params)), total)
    return total


# -- the four discrete gradients of F, one signature: (kind, coeffs, F, grad_F, params, buf, x, x', F(x), F(x'),
#    size, gain, base) -> (dgF, noise); ``kind`` is read only by ``_by_code`` -----------------------------------
def _gonzalez_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    dx = sub(x_new, x)
    load(buf, axpy(0.5, dx, x))
    return gonzalez(as_vector(grad_F(buf, params)), f_old, f_new, dx, x_new, gain, base)


def _avf_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    """AVF: the Gauss-Legendre average of grad F on the segment (Quispel, McLaren, J. Phys. A 41
    (2008) 045206, doi:10.1088/1751-8113/41/4/045206), made an exact discrete gradient for any F by
    Gonzalez's projection; the projection's correction vanishes (to round-off) when the rule
    integrates grad F exactly."""
    dx = sub(x_new, x)
    return gonzalez(average_gradient(grad_F, params, buf, x, dx, coeffs), f_old, f_new, dx, x_new, gain, base)


@inner
def _exact(dg_noise, f_old, f_new, x, x_new, gain, base):
    """An Itoh-Abe gradient made exact again where edges switched to derivatives (module docstring):
    Gonzalez's projection of it onto ``dg . dx = F(x') - F(x)``, applied only where the defect exceeds
    its round-off bound (``gonzalez``), so an unswitched gradient is returned as it is."""
    dg, noise = dg_noise
    exact, more = gonzalez(dg, f_old, f_new, sub(x_new, x), x_new, gain, base)
    return exact, max(noise, more)


def _itoh_abe_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    return _exact(itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size, base), f_old, f_new, x, x_new, gain,
                  base)


def _symmetrized_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    return _exact(symmetrized_itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size, base), f_old, f_new, x,
                  x_new, gain, base)


_BY_MARKER = {GonzalezKind: _gonzalez_dg, ItohAbeKind: _itoh_abe_dg, SymmetrizedItohAbeKind: _symmetrized_dg,
              AVFKind: _avf_dg}
#: each discrete gradient compiled to be inlined (into its own discrete field, below) ...
_INLINED = {marker: njit(inline="always")(dg) for marker, dg in _BY_MARKER.items()}
_gonzalez_inlined = _INLINED[GonzalezKind]
#: ... and as a call (programs mixing discrete-gradient kinds: ``composition.stage_kind``)
_itoh_abe_called, _symmetrized_called, _avf_called = (
    inner(dg) for dg in (_itoh_abe_dg, _symmetrized_dg, _avf_dg))


@njit(inline="always")
def _by_code(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    """The discrete gradient chosen at run time by the integer code ``kind`` (a program mixing kinds):
    inlined into the discrete field of codes, with Gonzalez's gradient (the usual stage, and a short one) inlined
    too and the others called."""
    if kind == ITOH_ABE:
        return _itoh_abe_called(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
    if kind == SYMMETRIZED_ITOH_ABE:
        return _symmetrized_called(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
    if kind == AVF:
        return _avf_called(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
    return _gonzalez_inlined(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)


def discrete_gradient(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    """The discrete gradient of F at ``(x, x')`` selected by ``kind``, and its round-off bound (Python callers and
    ``NUMBA_DISABLE_JIT=1``; compiled code reaches them through ``discrete_field``).

    ``kind`` is a kind marker (``layout.GonzalezKind`` ...) or an integer code.
    """
    dg = _by_code if isinstance(kind, (int, np.integer)) else _BY_MARKER[type(kind)]
    return dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)


@inner
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


@inner
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
        dg_h, noise_h = discrete_gradient(kind, coeffs, model.H, model.grad_H, p, buf, x, x_new, H_old, H_new, size,
                                          gain_h, origin_terms(model.origin, 0, x_new))
        dg_s, noise_s = discrete_gradient(kind, coeffs, model.S, model.grad_S, p, buf, x, x_new, S_old, S_new, size,
                                          gain_s, origin_terms(model.origin, 4, x_new))
        size_h, size_s = norm_inf(dg_h), norm_inf(dg_s)
        noise = eps * (2.0 * noise_h * size_s + noise_s * size_h) * size_h
        axial_bar = ZERO
        if hamiltonian:
            load(buf, axpy(0.5, sub(x_new, x), x))
            axial = as_vector(model.J(buf, p))
            axial_bar = discrete_axial(axial, dg_s)
            noise += noise_h * norm_inf(axial) + (size_h * norm_inf(axial) * noise_s / size_s if size_s > 0.0 else 0.0)
        F = polish(dissipative(dg_h, dg_s, eps, cross(dg_h, axial_bar)), dg_h, dg_s, eps)
        return F, H_new, S_new, dg_h, dg_s, axial_bar, noise
    return discrete_field


#: the discrete field of each kind of discrete gradient, the gradient inlined (a call carrying the user's functions
#: costs more than the quotient), and of integer codes (programs mixing kinds: chosen at run time)
_FIELDS = {marker: inner(_discrete_field_with(dg)) for marker, dg in _INLINED.items()}
_FIELD_BY_CODE = inner(_discrete_field_with(_by_code))


def discrete_field(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales):
    """The discrete field F(x, x') and ``(H(x'), S(x'), dgH, dgS, Jbar, noise)`` (``_discrete_field_with``); ``kind``
    a kind marker (chosen when the kernel is compiled, so a run compiles only its own discrete gradient) or an
    integer code."""
    field = _FIELD_BY_CODE if isinstance(kind, (int, np.integer)) else _FIELDS[type(kind)]
    return field(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales)


@overload(discrete_field, inline="always")
def _discrete_field_typed(kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales):
    field = _FIELD_BY_CODE if isinstance(kind, types.Integer) else _FIELDS[kind.instance_class]
    return lambda kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales: field(
        kind, coeffs, model, eps, hamiltonian, buf, x, H_old, S_old, x_new, h, scales)


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
    F, H_new, S_new, dg_h, dg_s, axial, noise = discrete_field(kind, coeffs, model, 0.0, True, buf, x, H_old, S_old, xn,
                                                                0.0, (0.0, 0.0, 0.0))
    for k in range(3):
        out[0, k] = dg_h[k]
        out[1, k] = dg_s[k]
        out[2, k] = axial[k]
