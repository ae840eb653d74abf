"""The discrete gradients of one scalar F: Gonzalez, Itoh-Abe, symmetrized Itoh-Abe, AVF.

A discrete gradient of F satisfies ``dg . (x' - x) = F(x') - F(x)`` and
``dg(x, x) = grad F(x)``; ``discrete_field`` builds the metriplectic step's
field from those of H and S.  Four discrete gradients (``kind``): Gonzalez's,
Itoh-Abe's (coordinate increments), Itoh-Abe's averaged over the six
coordinate orderings, and the average vector field (AVF, Gauss-Legendre nodes
and weights in ``coeffs``); ``dispatch`` chooses among them.

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
whole steps are anchored to H(x0) (``dg_step.discrete_gradient_step``) and
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

from .jit import inner
from .layout import EPS
from .roundoff import term_scale
from .vec3 import ZERO, as_vector, axpy, dot, load, norm_inf, sub

#: Itoh-Abe quotients over coordinate increments ``|d| <= SWITCH * |x|_inf``
#: are replaced by midpoint partial derivatives (module docstring).
SWITCH = EPS ** (1.0 / 3.0)


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
