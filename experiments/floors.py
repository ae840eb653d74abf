"""Hand-written numba loops: the cost floors geomint's engine is measured against (experiments/engine_speed.py).

All on the relaxing rigid body, ``H = (a x^2 + b y^2 + c z^2) / 2``, ``S = |x|^2 / 2``, ``J = x``
(``geomint.systems.relaxing_rigid_body``), with the parameters as arguments, compiled once (``cache=True``).

* ``gonzalez_exact``: the exact step geomint's ``Gonzalez()`` takes (docs/design.md section 2,
  ``geomint/_kernels/dg_step.py``), written out for this system:

      x' - x = h [ dgH x Jbar + eps dgH x (dgH x dgS) ],   Jbar = (J(xbar) . n) n,   n = dgS / |dgS|,

  ``xbar = (x + x') / 2``; ``dgH x (dgH x dgS) = (dgH dgH^T - |dgH|^2 I) dgS`` is the paper's metric ``g dgS``.
  dgH and dgS are Gonzalez's discrete gradients ``grad F(xbar) + N dx / |dx|^2``,
  ``N = F(x') - F(x) - grad F(xbar) . dx``, with the library's switching rule (``_gonzalez``) and H's ``F(x)`` the
  anchor H(x0), S's the S of the step's start (``dg_step.discrete_gradient_step``).  What it writes by hand: the
  field and both discrete gradients inline (no first-class function, no call, no array: every vector a tuple);
  simplified Newton with ``I - h/2 D xi``, D xi by differences of the inlined field, kept across steps as its
  inverse (a correction is a matrix-vector product) and refreshed as the library refreshes it
  (``THETA_REFRESH``), the start extrapolated from the last three increments; the state advanced by compensated
  summation and flushed as the engine's loop does.  Newton is iterated to round-off (``strict``: a correction
  within 4 ulps of the increment, or a measured contraction bounding the rest within one ulp); ``strict=False``
  stops as the library's ``newton.newton`` does, which accepts the first corrected iterate that keeps H and S
  (on the first iteration no rate is measured: its ``theta = error / inf = 0``).  Every step is then held to the
  library's acceptance (``layout.ACCEPT_ULPS``, ``ACCEPT_S_ULPS``): H within 4 ulps of its terms of H(x0), S not
  above S(x_n) by more than 2 ulps of its terms (``geomint/_kernels/roundoff.py``); a step that misses is
  counted in ``FloorRun.failures``, and a floor with failures is no floor.  It is a floor because it does the
  work the step needs and nothing else: the same equation to the same round-off, the same iteration and
  acceptance, without the engine's generality (user functions through first-class handles, retries, the
  Newton-proper fallback, the S cap, counters, the general loop).
* ``gonzalez_exact_ensemble``: ``gonzalez_exact`` from every row of a start array over numba's parallel range:
  the floor for ``geomint.solve_ensemble``.
* ``rk4_inlined``: classical RK4 with the field written out in the loop (no function calls at all): what the
  hardware allows for an explicit step.
* ``rk4_first_class``: the same RK4, reaching H, grad H, S, grad S and J through numba first-class function
  types (``system.model``), as geomint's kernels reach a user's functions, with the subnormal flush geomint
  applies: what the first-class calls cost.
* ``midpoint_batch_inlined``: an ensemble of implicit-midpoint trajectories (fixed-point iteration), field
  inlined (experiments/ensemble.py).

The floors share the engine's constants (the flush threshold, the acceptance ulps, the refresh rate) and one
helper (``geomint._kernels.vec3.flush_tiny``), so that a floor rounds and accepts as the engine does.
"""

from collections import namedtuple

import numpy as np
from numba import njit, prange

from geomint._kernels.layout import ACCEPT_S_ULPS, ACCEPT_ULPS
from geomint._kernels.newton import THETA_REFRESH
from geomint._kernels.vec3 import FLUSH, flush_tiny


@njit(cache=True)
def rk4_inlined(a, b, c, eps, x0, h, n):
    """RK4 on ``m' = grad H x m + eps grad H x (grad H x m)``, ``H = (a x^2 + b y^2 + c z^2)/2``, field inlined."""
    x, y, z = x0[0], x0[1], x0[2]
    for _ in range(n):
        k = np.empty((4, 3))
        px, py, pz = x, y, z
        for s in range(4):
            gx, gy, gz = a * px, b * py, c * pz
            # grad H x m, and grad H x (grad H x m)
            cx, cy, cz = gy * pz - gz * py, gz * px - gx * pz, gx * py - gy * px
            k[s, 0] = cx + eps * (gy * cz - gz * cy)
            k[s, 1] = cy + eps * (gz * cx - gx * cz)
            k[s, 2] = cz + eps * (gx * cy - gy * cx)
            w = 0.5 * h if s < 2 else h
            if s < 3:
                px, py, pz = x + w * k[s, 0], y + w * k[s, 1], z + w * k[s, 2]
        x += h / 6.0 * (k[0, 0] + 2.0 * k[1, 0] + 2.0 * k[2, 0] + k[3, 0])
        y += h / 6.0 * (k[0, 1] + 2.0 * k[1, 1] + 2.0 * k[2, 1] + k[3, 1])
        z += h / 6.0 * (k[0, 2] + 2.0 * k[1, 2] + 2.0 * k[2, 2] + k[3, 2])
    return np.array([x, y, z])


@njit(inline="always")
def _field(model, eps, buf, x):
    buf[0], buf[1], buf[2] = x
    gh = model.grad_H(buf, model.params)
    gs = model.grad_S(buf, model.params)
    j = model.J(buf, model.params)
    c = (gh[1] * j[2] - gh[2] * j[1], gh[2] * j[0] - gh[0] * j[2], gh[0] * j[1] - gh[1] * j[0])
    d = (gh[1] * gs[2] - gh[2] * gs[1], gh[2] * gs[0] - gh[0] * gs[2], gh[0] * gs[1] - gh[1] * gs[0])
    g = (gh[1] * d[2] - gh[2] * d[1], gh[2] * d[0] - gh[0] * d[2], gh[0] * d[1] - gh[1] * d[0])
    return (c[0] + eps * g[0], c[1] + eps * g[1], c[2] + eps * g[2])


@njit(cache=True)
def rk4_first_class(model, eps, x0, h, n):
    """RK4 with the user functions reached as first-class functions through ``model``, and the flush."""
    buf = np.empty(3)
    x = (x0[0], x0[1], x0[2])
    zero = (0.0, 0.0, 0.0)
    for _ in range(n):
        k1 = _field(model, eps, buf, x)
        k2 = _field(model, eps, buf, (x[0] + 0.5 * h * k1[0], x[1] + 0.5 * h * k1[1], x[2] + 0.5 * h * k1[2]))
        k3 = _field(model, eps, buf, (x[0] + 0.5 * h * k2[0], x[1] + 0.5 * h * k2[1], x[2] + 0.5 * h * k2[2]))
        k4 = _field(model, eps, buf, (x[0] + h * k3[0], x[1] + h * k3[1], x[2] + h * k3[2]))
        x = (
            x[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            x[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            x[2] + h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
        )
        x, _ = flush_tiny(x, zero)
    return np.array(x)


@njit(cache=True, parallel=True)
def midpoint_batch_inlined(a, b, c, eps, X0, h, n):
    """Implicit midpoint on the relaxing rigid body for every row of ``X0`` (prange over trajectories), the field
    written out and the midpoint equation solved by fixed-point iteration to round-off: the ensemble floor
    (the implicit midpoint is Gonzalez's step for this quadratic H with the same Newton cost per iteration)."""
    out = np.empty_like(X0)
    for i in prange(X0.shape[0]):
        x, y, z = X0[i, 0], X0[i, 1], X0[i, 2]
        for _ in range(n):
            nx, ny, nz = x, y, z
            for _ in range(50):
                px, py, pz = 0.5 * (x + nx), 0.5 * (y + ny), 0.5 * (z + nz)
                gx, gy, gz = a * px, b * py, c * pz
                cx, cy, cz = gy * pz - gz * py, gz * px - gx * pz, gx * py - gy * px
                fx = x + h * (cx + eps * (gy * cz - gz * cy))
                fy = y + h * (cy + eps * (gz * cx - gx * cz))
                fz = z + h * (cz + eps * (gx * cy - gy * cx))
                change = abs(fx - nx) + abs(fy - ny) + abs(fz - nz)
                nx, ny, nz = fx, fy, fz
                if change <= 4e-16 * (abs(nx) + abs(ny) + abs(nz)):
                    break
            x, y, z = nx, ny, nz
        out[i, 0], out[i, 1], out[i, 2] = x, y, z
    return out


# -- the exact Gonzalez step by hand -----------------------------------------------------------------------------
#: Newton iterations allowed per attempt (the library's ``max_newton_iter`` default)
MAX_ITER = 50
EPS = float(np.finfo(np.float64).eps)
SQRT_EPS = float(np.sqrt(EPS))

inline = njit(inline="always", error_model="numpy")


@inline
def _gonzalez(g, f_old, f_new, d, y, gain):
    """Gonzalez's discrete gradient ``g + N d / |d|^2``, ``N = F(y) - F(x) - g . d``, ``g = grad F(xbar)``
    (Gonzalez, J. Nonlinear Sci. 6 (1996) 449), with the library's switching rule
    (``geomint/_kernels/discrete_gradient.py``, ``gonzalez``): the correction is taken only where ``|N|`` exceeds
    its round-off bound ``2 eps T``, ``T = max(|F(x)|, |F(y)|, sum_i |g_i y_i|)`` (the terms of F; F(0) = 0 and
    grad F(0) = 0 here, so the library's constant-and-linear part is 0), where that bound carried into the step by
    ``gain`` stays below 1 % of ``|d|^2``, and where ``d != 0``.  Returns ``(dgF, noise)``, ``noise`` the
    round-off the correction carries."""
    slope = g[0] * d[0] + g[1] * d[1] + g[2] * d[2]
    defect = f_new - f_old - slope
    bound = 2.0 * EPS * max(abs(f_old), abs(f_new), abs(g[0] * y[0]) + abs(g[1] * y[1]) + abs(g[2] * y[2]))
    largest = max(abs(d[0]), abs(d[1]), abs(d[2]))
    if not abs(defect) > bound or not bound * gain <= 0.01 * largest * largest or largest == 0.0:
        return g, 0.0
    u = (d[0] / largest, d[1] / largest, d[2] / largest)
    length2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
    k = defect / largest / length2
    return (g[0] + k * u[0], g[1] + k * u[1], g[2] + k * u[2]), bound / (largest * np.sqrt(length2))


@inline
def _cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@inline
def _norm(u):
    return max(abs(u[0]), abs(u[1]), abs(u[2]))


@inline
def _energies(a, b, c, y):
    """``H(y) = (a y0^2 + b y1^2 + c y2^2) / 2`` and ``S(y) = |y|^2 / 2``."""
    return 0.5 * (a * y[0] * y[0] + b * y[1] * y[1] + c * y[2] * y[2]), 0.5 * (y[0] * y[0] + y[1] * y[1] + y[2] * y[2])


@inline
def _xi(a, b, c, eps, x):
    """The continuous field ``xi = grad H x m + eps grad H x (grad H x m)`` (J = m, grad S = m)."""
    g = (a * x[0], b * x[1], c * x[2])
    p = _cross(g, x)
    q = _cross(g, p)
    return (p[0] + eps * q[0], p[1] + eps * q[1], p[2] + eps * q[2])


@inline
def _discrete_field(a, b, c, eps, x, y, H0, S_x, h, scales):
    """``F(x, y) = dgH x Jbar + eps dgH x (dgH x dgS)`` (docs/design.md section 2), ``Jbar = (J(xbar) . n) n``,
    ``n = dgS / |dgS|``, ``J(xbar) = xbar``; dgH anchored to ``H0 = H(x0)``, dgS to ``S_x = S(x_n)``.
    ``scales = (|Jbar|, |dgH|, |dgS|)`` of the previous iterate give the gains of the switching rule (zeros on the
    first).  Returns ``(F, H(y), S(y), scales, noise)``."""
    H_y, S_y = _energies(a, b, c, y)
    m = (0.5 * (x[0] + y[0]), 0.5 * (x[1] + y[1]), 0.5 * (x[2] + y[2]))
    d = (y[0] - x[0], y[1] - x[1], y[2] - x[2])
    axial_size, size_h, size_s = scales
    gain_h = abs(h) * (axial_size + 2.0 * eps * size_h * size_s)
    gain_s = abs(h) * ((axial_size / size_s if size_s > 0.0 else 0.0) + eps * size_h * size_h)
    dgh, noise_h = _gonzalez((a * m[0], b * m[1], c * m[2]), H0, H_y, d, y, gain_h)
    dgs, noise_s = _gonzalez(m, S_x, S_y, d, y, gain_s)
    ss = dgs[0] * dgs[0] + dgs[1] * dgs[1] + dgs[2] * dgs[2]
    k = (m[0] * dgs[0] + m[1] * dgs[1] + m[2] * dgs[2]) / ss if ss > 0.0 else 1.0
    axial = (k * dgs[0], k * dgs[1], k * dgs[2]) if ss > 0.0 else m
    p = _cross(dgh, axial)
    q = _cross(dgh, _cross(dgh, dgs))
    F = (p[0] + eps * q[0], p[1] + eps * q[1], p[2] + eps * q[2])
    size_h, size_s, size_j = _norm(dgh), _norm(dgs), _norm(m)
    noise = eps * (2.0 * noise_h * size_s + noise_s * size_h) * size_h + noise_h * size_j
    if size_s > 0.0:
        noise += size_h * size_j * noise_s / size_s
    return F, H_y, S_y, (_norm(axial), size_h, size_s), noise


@inline
def _newton_inverse(a, b, c, eps, x, h):
    """``(I - h/2 D xi(x))^-1`` (rows) and ``xi(x)``: D xi by forward differences of the inlined field, step
    ``sqrt(eps) |x|_inf`` as the library's ``newton.jacobian``, inverted by its adjugate (once per refresh: a
    kept inverse makes every correction a matrix-vector product)."""
    f0 = _xi(a, b, c, eps, x)
    size = _norm(x)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    w = -0.5 * h / delta
    f1 = _xi(a, b, c, eps, (x[0] + delta, x[1], x[2]))
    f2 = _xi(a, b, c, eps, (x[0], x[1] + delta, x[2]))
    f3 = _xi(a, b, c, eps, (x[0], x[1], x[2] + delta))
    r0 = (1.0 + w * (f1[0] - f0[0]), w * (f2[0] - f0[0]), w * (f3[0] - f0[0]))
    r1 = (w * (f1[1] - f0[1]), 1.0 + w * (f2[1] - f0[1]), w * (f3[1] - f0[1]))
    r2 = (w * (f1[2] - f0[2]), w * (f2[2] - f0[2]), 1.0 + w * (f3[2] - f0[2]))
    c0, c1, c2 = _cross(r1, r2), _cross(r2, r0), _cross(r0, r1)
    det = r0[0] * c0[0] + r0[1] * c0[1] + r0[2] * c0[2]
    return (
        (c0[0] / det, c1[0] / det, c2[0] / det),
        (c0[1] / det, c1[1] / det, c2[1] / det),
        (c0[2] / det, c1[2] / det, c2[2] / det),
    ), f0


@inline
def _apply(m, r):
    return (
        m[0][0] * r[0] + m[0][1] * r[1] + m[0][2] * r[2],
        m[1][0] * r[0] + m[1][1] * r[1] + m[1][2] * r[2],
        m[2][0] * r[0] + m[2][1] * r[1] + m[2][2] * r[2],
    )


@inline
def _newton(a, b, c, eps, x, comp, H0, S_x, h, dx, inverse, max_iter, strict):
    """Simplified Newton on ``dx - h F(x, x + dx) = 0`` from ``dx``, stopped as the library's ``newton.newton``
    stops: a correction within 4 ulps of the increment (``resolution``: of ``|dx|`` and of the terms of ``h F``),
    or a contraction rate theta with ``theta / (1 - theta) |correction|`` within one (the correction then applied),
    or a correction that no longer shrinks within 16 times the round-off floor.  Returns ``(converged, dx,
    iterations, first contraction rate)``."""
    reach = _norm(x) + 4.0 * _norm(dx)
    previous, best, first_theta = np.inf, np.inf, 0.0
    scales = (0.0, 0.0, 0.0)
    for iteration in range(1, max_iter + 1):
        y = _advance(x, comp, dx)[0]
        F, H_y, S_y, scales, noise = _discrete_field(a, b, c, eps, x, y, H0, S_x, h, scales)
        corr = _apply(inverse, (dx[0] - h * F[0], dx[1] - h * F[1], dx[2] - h * F[2]))
        error = _norm(corr)
        resolution = EPS * (_norm(dx) + abs(h) * scales[1] * (scales[0] + eps * scales[1] * scales[2]))
        theta = error / previous  # 0 on the first iteration: no rate measured yet
        if iteration == 2:
            first_theta = theta
        measured = iteration > 1 or not strict
        if error <= 4.0 * resolution or (measured and theta < 0.5 and theta / (1.0 - theta) * error <= resolution):
            corrected = (dx[0] - corr[0], dx[1] - corr[1], dx[2] - corr[2])
            off_h, off_s, _ = _off(a, b, c, H0, S_x, _advance(x, comp, corrected)[0])
            if off_h <= ACCEPT_ULPS and off_s <= ACCEPT_S_ULPS:
                return True, corrected, iteration, max(theta, first_theta)
        stalled = error >= 0.5 * best
        if stalled and error <= 16.0 * (4.0 * resolution + 2.0 * abs(h) * noise):
            return True, dx, iteration, first_theta
        if not error <= 1e3 * reach or error == 0.0:
            return False, dx, iteration, first_theta
        best, previous = min(best, error), error
        dx = (dx[0] - corr[0], dx[1] - corr[1], dx[2] - corr[2])
    return False, dx, max_iter, first_theta


@inline
def _off(a, b, c, H0, S_x, y):
    """How far y is from exact, in ulps of the terms: ``|H(y) - H0| / (eps T_H)`` and ``(S(y) - S_x) / (eps T_S)``,
    ``T_F = max(|F_old|, |F(y)|, sum_i |y_i d_i F(y)|)`` (``geomint/_kernels/roundoff.py``, ``term_scale``),
    and ``(H(y), S(y))``."""
    H_y, S_y = _energies(a, b, c, y)
    terms_h = max(abs(H0), abs(H_y), a * y[0] * y[0] + b * y[1] * y[1] + c * y[2] * y[2])
    terms_s = max(abs(S_x), abs(S_y), y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    return abs(H_y - H0) / (EPS * terms_h), (S_y - S_x) / (EPS * terms_s), S_y


@inline
def _extrapolated(d1, d2, d3, past):
    """The increment extrapolated from the last (up to) three: ``d1``, ``2 d1 - d2``, ``3 (d1 - d2) + d3``
    (error O(h^2), O(h^3), O(h^4): the library's ``newton.predictor``)."""
    if past == 1:
        return d1
    if past == 2:
        return (2.0 * d1[0] - d2[0], 2.0 * d1[1] - d2[1], 2.0 * d1[2] - d2[2])
    return (3.0 * (d1[0] - d2[0]) + d3[0], 3.0 * (d1[1] - d2[1]) + d3[1], 3.0 * (d1[2] - d2[2]) + d3[2])


@inline
def _advance(x, comp, dx):
    """``x + dx`` by compensated summation (Kahan, Comm. ACM 8 (1965) 40), as the library's ``vec3.advance``:
    ``(y, comp')``, ``y + comp'`` the state to extra precision.  Without it the rounding of the state random-walks H
    on the tail at rest, where every increment is below an ulp of the state."""
    u = (dx[0] - comp[0], dx[1] - comp[1], dx[2] - comp[2])
    y = (x[0] + u[0], x[1] + u[1], x[2] + u[2])
    return y, ((y[0] - x[0]) - u[0], (y[1] - x[1]) - u[1], (y[2] - x[2]) - u[2])


@inline
def _flushed(y, comp):
    """``y`` with components below ``FLUSH |y|_inf`` set to 0, and its compensation there too, as the engine's loop
    does (``vec3.flush_tiny``): no subnormal arithmetic on the tail at rest."""
    limit = FLUSH * _norm(y)
    k0, k1, k2 = abs(y[0]) > limit, abs(y[1]) > limit, abs(y[2]) > limit
    return (
        (y[0] if k0 else 0.0, y[1] if k1 else 0.0, y[2] if k2 else 0.0),
        (comp[0] if k0 else 0.0, comp[1] if k1 else 0.0, comp[2] if k2 else 0.0),
    )


@njit(cache=True, error_model="numpy")
def _gonzalez_run(a, b, c, eps, x0, h, n, max_iter, strict):
    """``n`` exact Gonzalez steps from ``x0`` (``gonzalez_exact``): ``(x, failures, iterations, worst H, worst S)``."""
    x = (x0[0], x0[1], x0[2])
    H0, S_x = _energies(a, b, c, x)
    zero = (0.0, 0.0, 0.0)
    comp = zero
    d1, d2, d3, past = zero, zero, zero, 0
    inverse, kept = (zero, zero, zero), False
    failures, iterations, worst_h, worst_s = 0, 0, 0.0, -np.inf
    for _ in range(n):
        ok, fresh, rate, dx = False, False, 0.0, zero
        if kept and past > 0:  # the usual step: the extrapolated increment with the kept inverse
            ok, dx, its, rate = _newton(
                a, b, c, eps, x, comp, H0, S_x, h, _extrapolated(d1, d2, d3, past), inverse, max_iter, strict
            )
            iterations += its
        if not ok:  # a fresh inverse and the linearly implicit start (I - h/2 D xi)^-1 h xi(x)
            inverse, f0 = _newton_inverse(a, b, c, eps, x, h)
            kept, fresh = True, True
            dx = _apply(inverse, (h * f0[0], h * f0[1], h * f0[2]))
            ok, dx, its, rate = _newton(a, b, c, eps, x, comp, H0, S_x, h, dx, inverse, max_iter, strict)
            iterations += its
        if rate > THETA_REFRESH and not fresh:  # the inverse has gone stale
            kept = False
        y, comp = _advance(x, comp, dx)
        y, comp = _flushed(y, comp)
        off_h, off_s, S_y = _off(a, b, c, H0, S_x, y)
        worst_h, worst_s = max(worst_h, off_h), max(worst_s, off_s)
        if not (ok and off_h <= ACCEPT_ULPS and off_s <= ACCEPT_S_ULPS):
            failures += 1
        d3, d2, d1 = d2, d1, (y[0] - x[0], y[1] - x[1], y[2] - x[2])
        past = min(3, past + 1)
        x, S_x = y, S_y
    return np.array([x[0], x[1], x[2]]), failures, iterations, worst_h, worst_s


#: a floor's run: the final state (one per start for the ensemble), the steps that missed the library's acceptance
#: (must be 0), the Newton iterations, and the largest |H - H(x0)| and rise of S over the run in ulps of their terms
FloorRun = namedtuple("FloorRun", "x failures iterations worst_H worst_S")


def gonzalez_exact(a, b, c, eps, x0, h, n, max_iter=MAX_ITER, strict=True):
    """``n`` exact Gonzalez steps of the relaxing rigid body from ``x0``: a ``FloorRun``."""
    return FloorRun(*_gonzalez_run(a, b, c, eps, np.asarray(x0, dtype=np.float64), h, n, max_iter, strict))


@njit(cache=True, parallel=True, error_model="numpy")
def _gonzalez_batch(a, b, c, eps, X0, h, n, max_iter, strict):
    m = X0.shape[0]
    out = np.empty_like(X0)
    failures, iterations = np.zeros(m, dtype=np.int64), np.zeros(m, dtype=np.int64)
    worst_h, worst_s = np.zeros(m), np.zeros(m)
    for i in prange(m):
        x, failures[i], iterations[i], worst_h[i], worst_s[i] = _gonzalez_run(
            a, b, c, eps, X0[i], h, n, max_iter, strict
        )
        out[i, 0], out[i, 1], out[i, 2] = x[0], x[1], x[2]
    return out, failures.sum(), iterations.sum(), worst_h.max(), worst_s.max()


def gonzalez_exact_ensemble(a, b, c, eps, X0, h, n, max_iter=MAX_ITER, strict=True):
    """``gonzalez_exact`` from every row of ``X0`` over numba's parallel range (as many threads as numba is set to):
    a ``FloorRun`` with the final states (rows), failures and iterations summed, the worst H and S of all."""
    return FloorRun(*_gonzalez_batch(a, b, c, eps, np.ascontiguousarray(X0, dtype=np.float64), h, n, max_iter, strict))
