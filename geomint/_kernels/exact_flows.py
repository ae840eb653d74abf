"""[R3] Exact flows of Hamiltonian sub-systems in R^3, in closed form.

* ``jacobi_sn_cn_dn``: Jacobi elliptic functions by the arithmetic-geometric
  mean and descending Landen transformation (Abramowitz & Stegun 16.4).
* ``elliptic_f``: the incomplete elliptic integral of the first kind by
  Carlson's R_F (B. C. Carlson, Numer. Algorithms 10 (1995) 13-26,
  doi:10.1007/BF02198293), extended to every real amplitude.
* ``rigid_body_flow``: the free rigid body ``m' = grad H x m``,
  ``H = (a x^2 + b y^2 + c z^2) / 2``, exactly (Celledoni, Fasso, Safstrom,
  Zanna, SIAM J. Sci. Comput. 30 (2008) 2084, doi:10.1137/070704393).
* ``rotor_splitting``: the free rigid body split into its three free rotors.
* ``rotation``: the flow of ``x' = x x J`` for constant ``J`` (the oscillator).

Everything here is scalar tuple arithmetic: no allocation, no validation.
"""

import math

import numpy as np
from numba import njit

from .._cache import CACHE
from .jit import inner
from .layout import EPS
from .vec3 import as_vector, load


@njit(cache=CACHE, error_model="numpy")
def jacobi_sn_cn_dn(u, m):
    """``(sn, cn, dn)(u | m)`` for ``0 <= m <= 1`` (parameter ``m = k^2``).

    AGM: ``a_0 = 1, b_0 = sqrt(1 - m), c_0 = sqrt(m)``, ``a_{n+1} = (a_n + b_n)/2``,
    ``b_{n+1} = sqrt(a_n b_n)``, ``c_{n+1} = (a_n - b_n)/2`` until ``c_N <= eps a_N``;
    then ``phi_N = 2^N a_N u`` and ``phi_{n-1} = (phi_n + asin(c_n sin(phi_n) / a_n)) / 2``
    give ``sn = sin phi_0``, ``cn = cos phi_0`` (A&S 16.4.3) and
    ``dn = sqrt((1 - m) + m cn^2)``, free of the cancellation in A&S's
    ``cos phi_0 / cos(phi_1 - phi_0)`` as ``m -> 1``.  ``m = 1`` uses ``(tanh, sech, sech)``.
    """
    if m >= 1.0:
        s = 1.0 / math.cosh(u)
        return math.tanh(u), s, s
    if m <= 0.0:
        return math.sin(u), math.cos(u), 1.0
    levels = 0
    a, c = _agm_level(m, 0)
    while abs(c) > EPS * a and levels < 40:
        levels += 1
        a, c = _agm_level(m, levels)
    phi = 2.0**levels * a * u
    for n in range(levels, 0, -1):
        a, c = _agm_level(m, n)
        phi = 0.5 * (phi + math.asin(c * math.sin(phi) / a))
    cn = math.cos(phi)
    return math.sin(phi), cn, math.sqrt((1.0 - m) + m * cn * cn)


@njit(cache=CACHE, error_model="numpy")
def _agm_level(m, n):
    """``(a_n, c_n)`` of the AGM started at ``(1, sqrt(1 - m))``; recomputed, not stored,
    so that the descending pass allocates nothing (``n`` is at most about 6)."""
    a, b, c = 1.0, math.sqrt(1.0 - m), math.sqrt(m)
    for _ in range(n):
        a, b, c = 0.5 * (a + b), math.sqrt(a * b), 0.5 * (a - b)
    return a, c


@njit(cache=CACHE, error_model="numpy")
def carlson_rf(x, y, z):
    """Carlson's symmetric integral ``R_F(x, y, z)`` (x, y, z >= 0, at most one zero), by duplication."""
    for _ in range(100):
        mean = (x + y + z) / 3.0
        dx, dy, dz = 1.0 - x / mean, 1.0 - y / mean, 1.0 - z / mean
        if max(abs(dx), abs(dy), abs(dz)) <= 1e-3:
            e2 = dx * dy - dz * dz
            e3 = dx * dy * dz
            return (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0) / math.sqrt(mean)
        sx, sy, sz = math.sqrt(x), math.sqrt(y), math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        x, y, z = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam)
    return np.nan


@njit(cache=CACHE, error_model="numpy")
def elliptic_f(phi, m):
    """``F(phi | m) = int_0^phi (1 - m sin^2 t)^(-1/2) dt`` for every real ``phi``, ``0 <= m < 1``.

    ``F(phi) = sin(phi) R_F(cos^2 phi, 1 - m sin^2 phi, 1)`` on ``|phi| <= pi/2`` and
    ``F(phi + j pi) = F(phi) + 2 j K(m)``, ``K(m) = R_F(0, 1 - m, 1)``.
    """
    j = math.floor(phi / math.pi + 0.5)
    reduced = phi - j * math.pi
    s = math.sin(reduced)
    c = math.cos(reduced)
    value = s * carlson_rf(c * c, 1.0 - m * s * s, 1.0)
    if j != 0:
        value += 2.0 * j * carlson_rf(0.0, 1.0 - m, 1.0)
    return value


@njit(cache=CACHE, error_model="numpy")
def _sorted_axes(a, b, c):
    """Indices of the smallest, middle and largest of ``(a, b, c)``."""
    lo, mid, hi = 0, 1, 2
    coef = (a, b, c)
    if coef[lo] > coef[mid]:
        lo, mid = mid, lo
    if coef[mid] > coef[hi]:
        mid, hi = hi, mid
    if coef[lo] > coef[mid]:
        lo, mid = mid, lo
    return lo, mid, hi


@njit(cache=CACHE, error_model="numpy")
def _cyclic_coefficient(coef, i):
    """``a_j - a_k`` for ``(i, j, k)`` cyclic: ``(grad H x m)_i = (a_j - a_k) m_j m_k``."""
    return coef[(i + 1) % 3] - coef[(i + 2) % 3]


@njit(cache=CACHE, error_model="numpy")
def _set(m, i, value):
    return (value if i == 0 else m[0], value if i == 1 else m[1], value if i == 2 else m[2])


@njit(cache=CACHE, error_model="numpy")
def rigid_body_flow(a, b, c, m, t):
    """The exact flow ``m(t)`` of ``m' = grad H x m``, ``H = (a m_1^2 + b m_2^2 + c m_3^2) / 2``.

    With the coefficients sorted ``p <= q <= r``, the component on the middle
    axis is ``s_v V sn(theta)``; the one on the axis the motion circles (largest
    coefficient when ``E > q M``, smallest otherwise, ``E = 2H``, ``M = |m|^2``)
    is ``s_w W dn(theta)``; the third is ``U cn(theta)``, ``theta = omega t + theta_0``.
    With ``alpha_d`` the coefficient of the circled axis and ``alpha_c`` of the cn axis
    (all cancellation-free in the initial components ``u, v, w``):

        U^2 = u^2 + (alpha_d - q) / (alpha_d - alpha_c) v^2,
        V^2 = v^2 + (alpha_d - alpha_c) / (alpha_d - q) u^2,
        W^2 = w^2 + (q - alpha_c) / (alpha_d - alpha_c) v^2,
        k^2 = (q - alpha_c) V^2 / ((alpha_d - alpha_c) W^2),
        omega = sqrt((alpha_d - alpha_c)(alpha_d - q)) W,

    ``s_w = sign w``, ``s_u = 1`` (``sign u`` on the separatrix ``k = 1``, where
    ``cn = sech > 0``), ``s_v = sign((grad H x m)_v coefficient) s_u s_w``, the
    cn component ``s_u U cn`` and ``theta_0 = F(atan2(s_v v / V, u / U) | k^2)``.  Two equal coefficients give a
    uniform rotation about the third axis; equilibria are returned unchanged.
    Our field is ``grad H x m``: the time reverse of the book's ``m x grad H``.
    """
    coef = (a, b, c)
    lo, mid, hi = _sorted_axes(a, b, c)
    p, q, r = coef[lo], coef[mid], coef[hi]
    if p == r:
        return m
    if q == p or q == r:
        axis = hi if q == p else lo
        j, k = (axis + 1) % 3, (axis + 2) % 3
        rate = (q - coef[axis]) * m[axis]
        cs, sn = math.cos(rate * t), math.sin(rate * t)
        out = _set(m, j, cs * m[j] + sn * m[k])
        return _set(out, k, cs * m[k] - sn * m[j])
    # E - q M = (r - q) m_hi^2 - (q - p) m_lo^2: which axis the motion circles
    if (r - q) * m[hi] * m[hi] >= (q - p) * m[lo] * m[lo]:
        d_axis, c_axis = hi, lo
    else:
        d_axis, c_axis = lo, hi
    alpha_d, alpha_c = coef[d_axis], coef[c_axis]
    u, v, w = m[c_axis], m[mid], m[d_axis]
    U2 = u * u + (alpha_d - q) / (alpha_d - alpha_c) * v * v
    V2 = v * v + (alpha_d - alpha_c) / (alpha_d - q) * u * u
    W2 = w * w + (q - alpha_c) / (alpha_d - alpha_c) * v * v
    if U2 == 0.0 or W2 == 0.0 or V2 == 0.0:
        return m  # on an axis: an equilibrium
    k2 = min(1.0, (q - alpha_c) * V2 / ((alpha_d - alpha_c) * W2))
    U, V, W = math.sqrt(U2), math.sqrt(V2), math.sqrt(W2)
    omega = math.sqrt((alpha_d - alpha_c) * (alpha_d - q)) * W
    s_w = 1.0 if w >= 0.0 else -1.0
    # cn changes sign for k < 1, so s_u = +1 will do; on the separatrix cn = sech > 0 and u keeps its sign
    s_u = -1.0 if k2 >= 1.0 and u < 0.0 else 1.0
    s_v = s_u * s_w if _cyclic_coefficient(coef, mid) > 0.0 else -s_u * s_w
    if k2 >= 1.0:
        if u == 0.0:
            return m  # the unstable equilibrium on the middle axis
        theta0 = math.atanh(max(-1.0, min(1.0, s_v * v / V)))
    else:
        theta0 = elliptic_f(math.atan2(s_v * v / V, u / U), k2)
    sn, cn, dn = jacobi_sn_cn_dn(omega * t + theta0, k2)
    out = _set(m, c_axis, s_u * U * cn)
    out = _set(out, mid, s_v * V * sn)
    return _set(out, d_axis, s_w * W * dn)


@njit(cache=CACHE, error_model="numpy")
def rigid_body_flow_at(a, b, c, m, times, out):
    """Rows ``out[i] = rigid_body_flow(a, b, c, m, times[i])``.  Caller: ``geomint.reference``."""
    for i in range(times.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = rigid_body_flow(a, b, c, m, times[i])


@inner
def rotate(x, axis, angle):
    """``x`` rotated by ``angle`` about the coordinate axis ``axis`` (right-handed)."""
    j, k = (axis + 1) % 3, (axis + 2) % 3
    cs, sn = math.cos(angle), math.sin(angle)
    out = _set(x, j, cs * x[j] - sn * x[k])
    return _set(out, k, sn * x[j] + cs * x[k])


@inner
def rotor_splitting(grad_H, params, buf, x, h):
    """One step of the symmetric free-rotor splitting of ``m' = grad H x m``, order 2.

    For a separable ``H = sum_i H_i(m_i)`` (both catalogue rigid bodies) the flow
    of ``H_i`` is a rotation about axis ``i`` by the angle ``t dH_i/dm_i`` (``m_i``
    is constant along it).  The step is ``R_1(h/2) R_2(h/2) R_3(h) R_2(h/2) R_1(h/2)``
    (McLachlan, Phys. Rev. Lett. 71 (1993) 3043, doi:10.1103/PhysRevLett.71.3043):
    explicit, symmetric, Poisson, and exact in ``|m|``.
    """
    for axis, fraction in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        rate = as_vector(grad_H(load(buf, x), params))[axis]
        x = rotate(x, axis, rate * fraction * h)
    return x


@inner
def rotation(J, params, buf, x, h):
    """The exact flow of ``x' = x x J`` with ``J`` constant: a rotation about ``J`` by ``-|J| h``.

    The Hamiltonian part of the dissipative oscillator (``H = |x|^2/2``,
    ``J = (0, 0, 1)``): ``(x, y)`` turn clockwise at unit rate.  Rodrigues' formula.
    """
    axial = as_vector(J(load(buf, x), params))
    size = math.sqrt(axial[0] ** 2 + axial[1] ** 2 + axial[2] ** 2)
    if size == 0.0:
        return x
    n = (axial[0] / size, axial[1] / size, axial[2] / size)
    angle = -size * h
    cs, sn = math.cos(angle), math.sin(angle)
    along = n[0] * x[0] + n[1] * x[1] + n[2] * x[2]
    cr = (n[1] * x[2] - n[2] * x[1], n[2] * x[0] - n[0] * x[2], n[0] * x[1] - n[1] * x[0])
    return (
        cs * x[0] + sn * cr[0] + (1.0 - cs) * along * n[0],
        cs * x[1] + sn * cr[1] + (1.0 - cs) * along * n[1],
        cs * x[2] + sn * cr[2] + (1.0 - cs) * along * n[2],
    )
