"""Hand-written exact steps in R^n: the floors the R^n engine is measured against (experiments/engine_speed_rn.py).

Each floor takes the step geomint's ``Gonzalez()`` takes in R^n (docs/engine_rn.md, ``geomint/_kernels/step_n.py``):

    x' - x = h [ Pi_S P(xbar) Pi_S dgH + eps Dbar dgS ],   xbar = (x + x') / 2,   Pi_S = I - s s^T,  s = dgS / |dgS|,
    Dbar dgS = (dgH . dgS) dgH - |dgH|^2 dgS   (the paper's metric)   or   Pi_H M(xbar) Pi_H dgS   (GENERIC's M),

with Gonzalez's discrete gradients ``dgF = grad F(xbar) + N dx / |dx|^2``, ``N = F(x') - F(x) - grad F(xbar) . dx``,
the correction taken where N exceeds its round-off bound ``2 eps (max(|F(x)|, |F(x')|, sum_i |y_i g_i|) + |F(0)|)``
and H's ``F(x)`` the anchor H(x0) (so the root lands on the anchor's level), as the library does; the final
states agree with geomint's to round-off (tests/test_experiments.py).  What the floors write by hand:

* **the field, inline**: H, S, their gradients, P (L) and M typed out for the system, reading the system's params,
  every intermediate in vectors allocated once per run (no first-class function, no array returned per call), P
  and M applied as actions from the formulas' zero pattern: the gas containers' L acts on (q, p) and M is rank
  one on (S1, S2); Zeitlin's P from index tables built once (``euler_tables``); the random Fish system's
  ``K(x) = A + sum_k x_k B_k`` formed over its upper triangle (A and B_k are skew), n^3 / 2 multiply-adds
  streamed along the params; the pendula's L and M in O(n), dgS = e_s exactly (S = s);
* **simplified Newton to round-off** with ``A = I - (h/2) D xi``, D xi the continuous field's Jacobian at the
  step's start, as a hand-coder would choose it per system (``REFRESH``): for the gas containers (n = 4) by
  forward differences of the inlined field, fresh at every step (5 evaluations of a 4-vector and a 4 x 4 LU: about
  one iteration); for 2-D Euler (n = 24) by differences too, LU by LAPACK's dgetrf (vecn's binding), kept across
  steps while the first contraction rate stays below the library's 0.1; for the random Fish system likewise kept,
  its differences taken with K affine in x (``K(x + d e_j) = K(x) + d B_j``: a column costs O(n^2), the Jacobian
  O(n^3), not n + 1 fields of O(n^3) each); for the pendula by hand from the zero pattern of L and M (each
  pendulum's 2 x 2 block and the s row, O(n) to form and to solve), fresh at every step.  A step starts from the
  increment extrapolated from the last three with kept factors, from the linearly implicit step with fresh ones;
  it stops as the library's does: a correction within 4 ulps of the increment, a contraction that bounds the rest
  below that, or a correction that no longer shrinks within the round-off of the quotients and of the state;
* **the library's acceptance** (``step_n.discrete_gradient_step_n``): where H is more than an ulp of its terms off
  H(x0), a scalar Newton move along ``Pi_S grad H`` puts it back (the library's ``to_level``); a step then counts
  as exact only with H within ``ACCEPT_ULPS`` (4) ulps of its terms of H(x0) and S not against its direction by
  more than ``ACCEPT_S_ULPS`` (2) ulps of its terms.  A step that misses is counted (``failures``) and the floor
  goes on from it: a floor with failures is not a floor.

``floor_for(system)`` gives the ``Floor`` of a catalogue system; ``Floor.run(x0, h, steps)`` a ``FloorRun``: the
final state, the steps that failed, those that did not converge, Newton iterations, Jacobians, level moves, and
the largest ``|H - H(x0)|`` and move of S against its direction over the run, in ulps of their terms.
"""

from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import njit

from geomint._kernels.layout import ACCEPT_S_ULPS, ACCEPT_ULPS
from geomint._kernels.step_n import LAPACK_MIN_N, THETA_REFRESH
from geomint._kernels.vecn import LAPACK_INT, lapack_factor, lapack_solve, lu_factor, lu_solve

EPS = np.finfo(float).eps
SQRT_EPS = np.sqrt(EPS)
#: Newton iterations allowed per attempt
MAX_ITER = 50

jit = njit(cache=True, error_model="numpy")


# -- shared vector algebra ---------------------------------------------------------------------------------------
@jit
def _remove_along(u, d):
    """``u - (u . d / d . d) d`` in place (d scaled by its largest entry first, as ``vecn.remove_along``)."""
    size = 0.0
    for i in range(d.shape[0]):
        size = max(size, abs(d[i]))
    if size == 0.0:
        return
    dd, ud = 0.0, 0.0
    for i in range(u.shape[0]):
        e = d[i] / size
        dd += e * e
        ud += u[i] * e
    c = ud / dd / size
    for i in range(u.shape[0]):
        u[i] -= c * d[i]


@jit
def _gonzalez(g, f_old, f_new, x, y, constant):
    """Gonzalez's discrete gradient in place: ``g`` holds grad F(xbar) on entry.  The correction ``N dx / |dx|^2``
    is added where ``|N|`` exceeds its round-off bound (``discrete_gradient.gonzalez``'s rule); returns the
    round-off the correction carries (0 where it is skipped)."""
    n = x.shape[0]
    slope, terms, largest = 0.0, 0.0, 0.0
    for i in range(n):
        d = y[i] - x[i]
        slope += g[i] * d
        terms += abs(g[i] * y[i])
        largest = max(largest, abs(d))
    defect = f_new - f_old - slope
    bound = 2.0 * EPS * (max(abs(f_old), abs(f_new), terms) + abs(constant))
    if not abs(defect) > bound or largest == 0.0:
        return 0.0
    length2 = 0.0
    for i in range(n):
        e = (y[i] - x[i]) / largest
        length2 += e * e
    c = defect / largest / length2
    for i in range(n):
        g[i] += c * ((y[i] - x[i]) / largest)
    return bound / (largest * np.sqrt(length2))


# -- the driver: simplified Newton to round-off and the acceptance -----------------------------------------------
@jit
def _iterate(kind, data, fac, x, y, H0, S_x, h, F, r, scratch):
    """Simplified Newton from ``y`` (in place) with the kept factors: ``(converged, iterations, first rate)``.
    Stops at round-off: a correction within 4 ulps of the increment, a contraction that bounds the rest below one,
    or a correction that no longer shrinks within the round-off of the quotients and of y itself."""
    n = x.shape[0]
    previous, best, rate = np.inf, np.inf, 0.0
    for iteration in range(1, MAX_ITER + 1):
        noise = _field(kind, data, x, y, H0, S_x, F, scratch)
        increment, size_f, size_y = 0.0, 0.0, 0.0
        for i in range(n):
            r[i] = (y[i] - x[i]) - h * F[i]
            increment = max(increment, abs(y[i] - x[i]))
            size_f = max(size_f, abs(F[i]))
            size_y = max(size_y, abs(y[i]))
        _solve(kind, fac, r)
        error = 0.0
        for i in range(n):
            error = max(error, abs(r[i]))
            y[i] -= r[i]
        resolution = EPS * (increment + abs(h) * size_f)
        theta = error / previous
        if iteration == 2 and previous > 64.0 * resolution:
            rate = theta
        if not np.isfinite(error):
            return False, iteration, np.inf
        contracting = iteration > 1 and theta < 0.5 and theta / (1.0 - theta) * error <= resolution
        floor = 64.0 * resolution + 16.0 * abs(h) * noise + 4.0 * EPS * size_y
        stalled = error >= 0.5 * best and error <= floor
        if error <= 4.0 * resolution or contracting or stalled or error == 0.0:
            return True, iteration, rate
        best = min(best, error)
        previous = error
    return False, MAX_ITER, rate


@jit
def _to_level(kind, data, y, H_y, H0, tolerance, gh, gs, before):
    """H back onto H0 within ``tolerance`` (the library's ``step_n.to_level``): scalar Newton along
    ``Pi_S grad H(y)`` (S unchanged to first order), at most 3 moves, a move that does not bring H closer undone.
    Returns ``(H(y), moves)``."""
    n = y.shape[0]
    moves = 0
    for _ in range(3):
        if abs(H_y - H0) <= tolerance:
            break
        _gradients(kind, data, y, gh, gs)
        for i in range(n):
            before[i] = gh[i]
        _remove_along(before, gs)
        slope = 0.0
        for i in range(n):
            slope += gh[i] * before[i]
        if not slope > 0.0:
            break
        lam = (H0 - H_y) / slope
        for i in range(n):
            gs[i] = y[i]  # the state before the move
            y[i] += lam * before[i]
        moved = _energy(kind, data, y)[0]
        moves += 1
        if not abs(moved - H0) < abs(H_y - H0):
            for i in range(n):
                y[i] = gs[i]
            break
        H_y = moved
    return H_y, moves


@jit
def _drive(kind, data, fac, origin, direction, theta_refresh, x0, h, steps):
    """``steps`` floor steps from ``x0``: ``(x, failures, unconverged, iterations, refreshes, level moves, worst_H,
    worst_S)`` (module docstring).  ``kind`` chooses the system's functions (``_field``, ``_xi``, ``_energy``,
    ``_gradients``, ``_refresh``, ``_solve``); ``origin`` is (H(0), S(0)) as the library measures it;
    ``direction`` -1 where S never rises (Fish), +1 where it never falls (GENERIC); a first contraction rate
    above ``theta_refresh`` takes a fresh Jacobian the next step (below 0: a fresh one every step, with the
    linearly implicit start, which the pendula take in fewer iterations than the extrapolated one)."""
    n = x0.shape[0]
    x, y = x0.copy(), np.empty(n)
    F, r, f0 = np.empty(n), np.empty(n), np.empty(n)
    history = np.zeros((3, n))
    scratch = np.empty((6, n))
    H0, _, S_x, _ = _energy(kind, data, x)
    kept, factored_h, past = False, 0.0, 0
    failures, unconverged, iterations, refreshes, moves = 0, 0, 0, 0, 0
    worst_h, worst_s = 0.0, -np.inf
    for _ in range(steps):
        ok, rate = False, 0.0
        if kept and factored_h == h and past > 0:
            for i in range(n):
                if past >= 3:
                    y[i] = x[i] + 3.0 * (history[0, i] - history[1, i]) + history[2, i]
                elif past == 2:
                    y[i] = x[i] + 2.0 * history[0, i] - history[1, i]
                else:
                    y[i] = x[i] + history[0, i]
            ok, its, rate = _iterate(kind, data, fac, x, y, H0, S_x, h, F, r, scratch)
            iterations += its
        if not ok:  # a fresh Jacobian and the linearly implicit start
            kept = _refresh(kind, data, x, h, fac, f0)
            factored_h = h
            refreshes += 1
            for i in range(n):
                y[i] = h * f0[i]
            _solve(kind, fac, y)
            for i in range(n):
                y[i] += x[i]
            ok, its, rate = _iterate(kind, data, fac, x, y, H0, S_x, h, F, r, scratch)
            iterations += its
        if rate > theta_refresh or theta_refresh < 0.0:
            kept = False
        unconverged += not ok
        H_y, terms_h, S_y, terms_s = _energy(kind, data, y)
        scale_h = max(abs(H0), abs(H_y), terms_h) + abs(origin[0])
        if abs(H_y - H0) > EPS * scale_h:
            H_y, m = _to_level(kind, data, y, H_y, H0, EPS * scale_h, scratch[0], scratch[1], scratch[2])
            moves += m
            H_y, terms_h, S_y, terms_s = _energy(kind, data, y)
            scale_h = max(abs(H0), abs(H_y), terms_h) + abs(origin[0])
        scale_s = max(abs(S_x), abs(S_y), terms_s) + abs(origin[1])
        off_h = abs(H_y - H0) / (EPS * scale_h)
        off_s = -direction * (S_y - S_x) / (EPS * scale_s)
        worst_h, worst_s = max(worst_h, off_h), max(worst_s, off_s)
        if not (ok and off_h <= ACCEPT_ULPS and off_s <= ACCEPT_S_ULPS):
            failures += 1
        same = past > 0
        for i in range(n):
            history[2, i] = history[1, i]
            history[1, i] = history[0, i]
            history[0, i] = y[i] - x[i]
            x[i] = y[i]
        past = min(3, past + 1) if same else 1
        S_x = S_y
    return x, failures, unconverged, iterations, refreshes, moves, worst_h, worst_s


# -- dense Jacobians by differences ------------------------------------------------------------------------------
@jit
def _new_dense(n):
    """Storage of a dense factorisation: the matrix, its pivots (by hand, LAPACK's) and two scratch vectors."""
    return np.empty((n, n)), np.empty(n), np.empty(n, dtype=LAPACK_INT), np.empty(n), np.empty(n)


@jit
def _factor(fac, h):
    """``A = I - h/2 D xi`` in place of the Jacobian ``fac[0]``, factored: by hand below ``LAPACK_MIN_N``."""
    a = fac[0]
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            a[i, j] *= -0.5 * h
        a[i, i] += 1.0
    if n >= LAPACK_MIN_N:
        return lapack_factor(a, fac[2])
    return lu_factor(a.ravel(), 0, n, fac[1], 0)


@jit
def _dense_solve(fac, b):
    if fac[0].shape[0] >= LAPACK_MIN_N:
        lapack_solve(fac[0], fac[2], b)
    else:
        lu_solve(fac[0].ravel(), 0, fac[0].shape[0], fac[1], 0, b)


@jit
def _differences(kind, data, x, fac, f0):
    """D xi(x) by forward differences into ``fac[0]`` (n + 1 field evaluations, step ``sqrt(eps) |x|_inf``)."""
    n = x.shape[0]
    jac, shifted, column = fac[0], fac[3], fac[4]
    _xi(kind, data, x, f0)
    size = 0.0
    for i in range(n):
        size = max(size, abs(x[i]))
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    for j in range(n):
        for i in range(n):
            shifted[i] = x[i]
        shifted[j] = x[j] + delta
        _xi(kind, data, shifted, column)
        for i in range(n):
            jac[i, j] = (column[i] - f0[i]) / delta


# -- gas containers (n = 4, GENERIC) ----------------------------------------------------------------------------
@jit
def _gas_energies(q, s1, s2):
    """``U_1 = (e^{S_1} / q)^{2/3}``, ``U_2 = (e^{S_2} / (2 - q))^{2/3}`` (as ``systems.gas_containers``)."""
    return np.exp((2.0 / 3.0) * (s1 - np.log(q))), np.exp((2.0 / 3.0) * (s2 - np.log(2.0 - q)))


@jit
def _gas_energy(data, y):
    U1, U2 = _gas_energies(y[0], y[2], y[3])
    T1, T2 = (2.0 / 3.0) * U1, (2.0 / 3.0) * U2
    H = 0.5 * y[1] * y[1] + U1 + U2
    terms = abs(y[0] * (-T1 / y[0] + T2 / (2.0 - y[0]))) + abs(y[1] * y[1]) + abs(y[2] * T1) + abs(y[3] * T2)
    return H, terms, y[2] + y[3], abs(y[2]) + abs(y[3])


@jit
def _gas_gradients(data, y, gh, gs):
    U1, U2 = _gas_energies(y[0], y[2], y[3])
    T1, T2 = (2.0 / 3.0) * U1, (2.0 / 3.0) * U2
    gh[0], gh[1], gh[2], gh[3] = -T1 / y[0] + T2 / (2.0 - y[0]), y[1], T1, T2
    gs[0], gs[1], gs[2], gs[3] = 0.0, 0.0, 1.0, 1.0


@jit
def _gas_field(data, x, y, H0, S_x, F, scratch):
    """``Pi_S L Pi_S dgE + Pi_E M(xbar) Pi_E dgS``: L canonical on (q, p), ``M = gamma w w^T`` on (S1, S2),
    ``w = (1 / T_1, -1 / T_2)`` at xbar."""
    gamma = data[0][0]
    dge, dgs, a = scratch[0], scratch[1], scratch[2]
    U1, U2 = _gas_energies(y[0], y[2], y[3])
    H_y, S_y = 0.5 * y[1] * y[1] + U1 + U2, y[2] + y[3]
    q, p = 0.5 * (x[0] + y[0]), 0.5 * (x[1] + y[1])
    V1, V2 = _gas_energies(q, 0.5 * (x[2] + y[2]), 0.5 * (x[3] + y[3]))
    T1, T2 = (2.0 / 3.0) * V1, (2.0 / 3.0) * V2
    dge[0], dge[1], dge[2], dge[3] = -T1 / q + T2 / (2.0 - q), p, T1, T2
    noise = _gonzalez(dge, H0, H_y, x, y, 0.0)
    dgs[0], dgs[1], dgs[2], dgs[3] = 0.0, 0.0, 1.0, 1.0
    noise += _gonzalez(dgs, S_x, S_y, x, y, 0.0)
    for i in range(4):
        a[i] = dge[i]
    _remove_along(a, dgs)
    F[0], F[1], F[2], F[3] = a[1], -a[0], 0.0, 0.0
    _remove_along(F, dgs)
    for i in range(4):
        a[i] = dgs[i]
    _remove_along(a, dge)
    w1, w2 = 1.5 / V1, -1.5 / V2
    c = gamma * (w1 * a[2] + w2 * a[3])
    a[0], a[1], a[2], a[3] = 0.0, 0.0, c * w1, c * w2
    _remove_along(a, dge)
    for i in range(4):
        F[i] += a[i]
    _remove_along(F, dge)
    return noise


@jit
def _gas_xi(data, x, out):
    gamma = data[0][0]
    U1, U2 = _gas_energies(x[0], x[2], x[3])
    T1, T2 = (2.0 / 3.0) * U1, (2.0 / 3.0) * U2
    w1, w2 = 1.5 / U1, -1.5 / U2
    out[0] = x[1]
    out[1] = T1 / x[0] - T2 / (2.0 - x[0])
    out[2] = gamma * w1 * (w1 + w2)
    out[3] = gamma * w2 * (w1 + w2)


# -- 2-D Euler, Zeitlin's truncation (n = N^2 - 1, the paper's metric) -------------------------------------------
@jit
def _euler_index(k1, k2, M):
    if k1 == 0:
        return k2 - 1 if 0 < k2 <= M else -1
    if 0 < k1 <= M and -M <= k2 <= M:
        return M + (k1 - 1) * (2 * M + 1) + (k2 + M)
    return -1


@jit
def _euler_wrap(m, N, M):
    r = m % N
    return r - N if r > M else r


@jit
def _euler_half(m1, m2, N, M):
    """The half mode holding omega_m (wrapped modulo N) and the sign of its imaginary part: ``(index, 1.0, sign)``,
    or ``(0, 0.0, 0.0)`` for m = 0 (no coefficient)."""
    m1, m2 = _euler_wrap(m1, N, M), _euler_wrap(m2, N, M)
    i = _euler_index(m1, m2, M)
    if i >= 0:
        return i, 1.0, 1.0
    i = _euler_index(-m1, -m2, M)
    if i >= 0:
        return i, 1.0, -1.0
    return 0, 0.0, 0.0


@jit
def euler_tables(N):
    """The structure of Zeitlin's P for N (``systems.euler._P``'s formula), once per run: for each pair of half
    modes (k, p) the half modes of omega_{k-p} and omega_{k+p} (index, real factor, imaginary sign) and the
    sine-bracket coefficients c_1 = c(p, k - p), c_2 = c(-p, k + p); and the weights of H (1 / |k|^2 per coordinate)."""
    M = (N - 1) // 2
    half = M + M * (2 * M + 1)
    modes = np.empty((half, 2), dtype=np.int64)
    weights = np.empty(2 * half)
    i = 0
    for k1 in range(0, M + 1):
        for k2 in range(-M, M + 1):
            if k1 == 0 and k2 <= 0:
                continue
            modes[i, 0], modes[i, 1] = k1, k2
            weights[2 * i] = weights[2 * i + 1] = 1.0 / (k1 * k1 + k2 * k2)
            i += 1
    sines = np.empty(N)
    for r in range(0, M + 1):
        s = N / (2.0 * np.pi) * np.sin(2.0 * np.pi * r / N)
        sines[M + r], sines[M - r] = s, -s
    index = np.zeros((half, half, 2), dtype=np.int64)
    factors = np.zeros((half, half, 6))  # real factor 1, imaginary sign 1, c_1, real factor 2, imaginary sign 2, c_2
    for i in range(half):
        k1, k2 = modes[i, 0], modes[i, 1]
        for j in range(half):
            if i == j:
                continue
            p1, p2 = modes[j, 0], modes[j, 1]
            cross1 = p1 * (k2 - p2) - p2 * (k1 - p1)
            cross2 = -p1 * (k2 + p2) + p2 * (k1 + p1)
            a, ra, sa = _euler_half(k1 - p1, k2 - p2, N, M)
            b, rb, sb = _euler_half(k1 + p1, k2 + p2, N, M)
            index[i, j, 0], index[i, j, 1] = a, b
            factors[i, j, 0], factors[i, j, 1], factors[i, j, 2] = ra, sa, sines[M + _euler_wrap(cross1, N, M)]
            factors[i, j, 3], factors[i, j, 4], factors[i, j, 5] = rb, sb, sines[M + _euler_wrap(cross2, N, M)]
    return index, factors, weights


@jit
def _euler_P(index, factors, w, v, out):
    """``out = P(w) v`` from the tables, O(n^2) (P linear in w; 0.5 c_1 omega_{k-p} + 0.5 c_2 omega_{k+p} per
    2 x 2 block, as ``systems.euler._P``)."""
    half = index.shape[0]
    for i in range(half):
        o0, o1 = 0.0, 0.0
        for j in range(half):
            if i == j:
                continue
            ia, ib = index[i, j, 0], index[i, j, 1]
            f = factors[i, j]
            a1, b1 = f[0] * w[2 * ia], f[1] * w[2 * ia + 1]
            a2, b2 = f[3] * w[2 * ib], f[4] * w[2 * ib + 1]
            c1, c2 = f[2], f[5]
            v0, v1 = v[2 * j], v[2 * j + 1]
            o0 += 0.5 * (c1 * a1 + c2 * a2) * v0 + 0.5 * (c2 * b2 - c1 * b1) * v1
            o1 += 0.5 * (c1 * b1 + c2 * b2) * v0 + 0.5 * (c1 * a1 - c2 * a2) * v1
        out[2 * i], out[2 * i + 1] = o0, o1


@jit
def _euler_energy(data, y):
    weights = data[0]
    H, terms_h, S = 0.0, 0.0, 0.0
    for i in range(y.shape[0]):
        s = y[i] * y[i]
        H += weights[i] * s
        S += s
        terms_h += 2.0 * weights[i] * s
    return H, terms_h, S, 2.0 * S


@jit
def _euler_gradients(data, y, gh, gs):
    weights = data[0]
    for i in range(y.shape[0]):
        gh[i] = 2.0 * weights[i] * y[i]
        gs[i] = 2.0 * y[i]


@jit
def _euler_field(data, x, y, H0, S_x, F, scratch):
    """``Pi_S P(xbar) Pi_S dgH + eps ((dgH . dgS) dgH - |dgH|^2 dgS)``, H and S quadratic: grad H = 2 x / |k|^2,
    grad S = 2 x."""
    weights, eps, index, factors = data[0], data[1], data[2], data[3]
    n = x.shape[0]
    dgh, dgs, a, mid = scratch[0], scratch[1], scratch[2], scratch[3]
    H_y, _, S_y, _ = _euler_energy(data, y)
    for i in range(n):
        mid[i] = 0.5 * (x[i] + y[i])
        dgh[i] = 2.0 * weights[i] * mid[i]
        dgs[i] = 2.0 * mid[i]
    noise = _gonzalez(dgh, H0, H_y, x, y, 0.0) + _gonzalez(dgs, S_x, S_y, x, y, 0.0)
    for i in range(n):
        a[i] = dgh[i]
    _remove_along(a, dgs)
    _euler_P(index, factors, mid, a, F)
    _remove_along(F, dgs)
    c, d = 0.0, 0.0
    for i in range(n):
        c += dgh[i] * dgs[i]
        d += dgh[i] * dgh[i]
    for i in range(n):
        F[i] += eps * (c * dgh[i] - d * dgs[i])
    _remove_along(F, dgh)
    return noise


@jit
def _euler_xi(data, x, out):
    weights, eps, index, factors = data[0], data[1], data[2], data[3]
    n = x.shape[0]
    g = np.empty(n)
    for i in range(n):
        g[i] = 2.0 * weights[i] * x[i]
    _euler_P(index, factors, x, g, out)
    c, d = 0.0, 0.0
    for i in range(n):
        c += g[i] * 2.0 * x[i]
        d += g[i] * g[i]
    for i in range(n):
        out[i] += eps * (c * g[i] - d * 2.0 * x[i])


# -- a random Fish system (the paper's metric) --------------------------------------------------------------------
#: where ``systems.random_fish``'s params keep the cosine and quartic coefficients and D
_COS, _QUARTIC, _D = 0, 1, 2


@jit
def _fish_K(p, n, w, K):
    """The upper triangle of ``K(w) = A + sum_k w_k B_k`` (A and B_k skew: the lower triangle is minus it),
    n^3 / 2 multiply-adds streamed along the params, each row's segment a contiguous loop (vectorised)."""
    at = _D + n
    flat = K.reshape(n * n)
    for i in range(n):
        for j in range(i + 1, n):
            flat[i * n + j] = p[at + i * n + j]
    for k in range(n):
        wk = w[k]
        B = p[at + n * n * (k + 1) : at + n * n * (k + 2)]
        for i in range(n - 1):
            start, stop = i * n + i + 1, i * n + n
            segment, source = flat[start:stop], B[start:stop]
            for m in range(stop - start):
                segment[m] += wk * source[m]


@jit
def _fish_Kv(K, v, out):
    """``out = K v`` for the skew K held by its upper triangle."""
    n = v.shape[0]
    for i in range(n):
        out[i] = 0.0
    for i in range(n):
        s = 0.0
        vi = v[i]
        for j in range(i + 1, n):
            s += K[i, j] * v[j]
            out[j] -= K[i, j] * vi
        out[i] += s


@jit
def _fish_P(p, n, K, w, v, out, s):
    """``out = P(w) v = Pi K(w) Pi v`` with K formed at w, ``Pi = I - s s^T``, ``s = grad S(w) / |grad S(w)|``
    (``systems.random_fish._P``: its ``(Q - Q^T) / 2`` is Q, K being skew); ``v`` is overwritten with ``Pi v``."""
    q = p[_QUARTIC]
    for i in range(n):
        s[i] = w[i] + 4.0 * q * w[i] * w[i] * w[i]
    _fish_K(p, n, w, K)
    _remove_along(v, s)
    _fish_Kv(K, v, out)
    _remove_along(out, s)


@jit
def _fish_energy(data, y):
    p = data[0]
    c, q = p[_COS], p[_QUARTIC]
    H, terms_h, S, terms_s = 0.0, 0.0, 0.0, 0.0
    for i in range(y.shape[0]):
        yi = y[i]
        y2 = yi * yi
        H += 0.5 * p[_D + i] * y2 + c * np.cos(yi)
        S += 0.5 * y2 + q * y2 * y2
        terms_h += abs(yi * (p[_D + i] * yi - c * np.sin(yi)))
        terms_s += abs(yi * (yi + 4.0 * q * y2 * yi))
    return H, terms_h, S, terms_s


@jit
def _fish_gradients(data, y, gh, gs):
    p = data[0]
    c, q = p[_COS], p[_QUARTIC]
    for i in range(y.shape[0]):
        yi = y[i]
        gh[i] = p[_D + i] * yi - c * np.sin(yi)
        gs[i] = yi + 4.0 * q * yi * yi * yi


@jit
def _fish_field(data, x, y, H0, S_x, F, scratch):
    """``Pi_S P(xbar) Pi_S dgH + eps ((dgH . dgS) dgH - |dgH|^2 dgS)``."""
    p, eps, K = data[0], data[1], data[4]
    n = x.shape[0]
    c, q = p[_COS], p[_QUARTIC]
    dgh, dgs, a, mid, s = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
    H_y, _, S_y, _ = _fish_energy(data, y)
    for i in range(n):
        m = 0.5 * (x[i] + y[i])
        mid[i] = m
        dgh[i] = p[_D + i] * m - c * np.sin(m)
        dgs[i] = m + 4.0 * q * m * m * m
    noise = _gonzalez(dgh, H0, H_y, x, y, c * n) + _gonzalez(dgs, S_x, S_y, x, y, 0.0)
    for i in range(n):
        a[i] = dgh[i]
    _remove_along(a, dgs)
    _fish_P(p, n, K, mid, a, F, s)
    _remove_along(F, dgs)
    u, v = 0.0, 0.0
    for i in range(n):
        u += dgh[i] * dgs[i]
        v += dgh[i] * dgh[i]
    for i in range(n):
        F[i] += eps * (u * dgh[i] - v * dgs[i])
    _remove_along(F, dgh)
    return noise


@jit
def _fish_rest(p, eps, n, K, Bj, delta, x, j, g, gs, s, u, out):
    """xi at ``x + delta e_j`` from K(x) (``K(x + delta e_j) = K(x) + delta B_j``; ``Bj`` the start of B_j in the
    params, -1 for x itself): O(n^2).  ``g``, ``gs``, ``s``, ``u`` scratch."""
    c, q = p[_COS], p[_QUARTIC]
    for i in range(n):
        xi = x[i] + (delta if i == j else 0.0)
        g[i] = p[_D + i] * xi - c * np.sin(xi)
        gs[i] = xi + 4.0 * q * xi * xi * xi
        s[i] = gs[i]
        u[i] = g[i]
    _remove_along(u, s)
    _fish_Kv(K, u, out)
    if Bj >= 0:
        for i in range(n):
            t = 0.0
            row = Bj + i * n
            for k in range(n):
                t += p[row + k] * u[k]
            out[i] += delta * t
    _remove_along(out, s)
    a, b = 0.0, 0.0
    for i in range(n):
        a += g[i] * gs[i]
        b += g[i] * g[i]
    for i in range(n):
        out[i] += eps * (a * g[i] - b * gs[i])


@jit
def _fish_xi(data, x, out):
    p, eps, K = data[0], data[1], data[4]
    n = x.shape[0]
    tmp = np.empty((4, n))
    _fish_K(p, n, x, K)
    _fish_rest(p, eps, n, K, -1, 0.0, x, -1, tmp[0], tmp[1], tmp[2], tmp[3], out)


@jit
def _fish_jacobian(data, x, fac, f0):
    """D xi(x) by forward differences into ``fac[0]``, each column from K(x) and B_j in O(n^2) (K affine in x)."""
    p, eps, K = data[0], data[1], data[4]
    n = x.shape[0]
    jac, column = fac[0], fac[4]
    tmp = np.empty((4, n))
    _fish_K(p, n, x, K)
    _fish_rest(p, eps, n, K, -1, 0.0, x, -1, tmp[0], tmp[1], tmp[2], tmp[3], f0)
    size = 0.0
    for i in range(n):
        size = max(size, abs(x[i]))
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    at = _D + n
    for j in range(n):
        # the column as the library's differences take it: x_j moved by delta, in floating point
        moved = (x[j] + delta) - x[j]
        _fish_rest(p, eps, n, K, at + n * n * (j + 1), moved, x, j, tmp[0], tmp[1], tmp[2], tmp[3], column)
        for i in range(n):
            jac[i, j] = (column[i] - f0[i]) / delta


# -- damped pendula (n = 2N + 1, GENERIC, L and M by their zero pattern) -----------------------------------------
@jit
def _pendula_energy(data, y):
    N = (y.shape[0] - 1) // 2
    s = y[2 * N]
    H, terms = s, abs(s)
    for i in range(N):
        q, p = y[i], y[N + i]
        H += 0.5 * p * p + np.cos(q)
        terms += abs(q * np.sin(q)) + p * p
    return H, terms, s, abs(s)


@jit
def _pendula_gradients(data, y, gh, gs):
    n = y.shape[0]
    N = (n - 1) // 2
    for i in range(N):
        gh[i] = -np.sin(y[i])
        gh[N + i] = y[N + i]
        gs[i] = gs[N + i] = 0.0
    gh[n - 1] = gs[n - 1] = 1.0


@jit
def _pendula_field(data, x, y, H0, S_x, F, scratch):
    """``L dgE + Pi_E M(xbar) Pi_E e_s``: S = s is linear in one coordinate, so dgS = e_s exactly (Gonzalez's
    defect is exactly zero) and ``Pi_S`` zeroes the s entry, which L neither reads nor writes;
    ``M v = gamma (0, v_p - pbar v_s, |pbar|^2 v_s - pbar . v_p)``."""
    gamma = data[0][0]
    n = x.shape[0]
    N = (n - 1) // 2
    dge, a = scratch[0], scratch[1]
    H_y, _, _, _ = _pendula_energy(data, y)
    for i in range(N):
        dge[i] = -np.sin(0.5 * (x[i] + y[i]))
        dge[N + i] = 0.5 * (x[N + i] + y[N + i])
    dge[n - 1] = 1.0
    noise = _gonzalez(dge, H0, H_y, x, y, N)
    norm2 = 0.0
    for i in range(n):
        norm2 += dge[i] * dge[i]
    # Pi_E e_s = e_s - (dgE_s / |dgE|^2) dgE, then M(xbar) of it
    c = dge[n - 1] / norm2
    a_s = 1.0 - c * dge[n - 1]
    last = 0.0
    for i in range(N):
        pbar = 0.5 * (x[N + i] + y[N + i])
        ap = -c * dge[N + i]
        w = ap - pbar * a_s
        a[i] = 0.0
        a[N + i] = gamma * w
        last -= gamma * pbar * w
    a[n - 1] = last
    _remove_along(a, dge)
    for i in range(N):
        F[i] = dge[N + i] + a[i]
        F[N + i] = -dge[i] + a[N + i]
    F[n - 1] = a[n - 1]
    _remove_along(F, dge)
    return noise


@jit
def _pendula_xi(data, x, out):
    gamma = data[0][0]
    n = x.shape[0]
    N = (n - 1) // 2
    last = 0.0
    for i in range(N):
        p = x[N + i]
        out[i] = p
        out[N + i] = np.sin(x[i]) - gamma * p
        last += gamma * p * p
    out[n - 1] = last


@jit
def _pendula_refresh(data, x, h, fac, f0):
    """``A = I - h/2 D xi(x)`` by its zero pattern: per pendulum ``[[1, -h/2], [-h/2 cos q, 1 + h gamma / 2]]``,
    inverted; the s row ``-h gamma p`` on the p entries (unit diagonal)."""
    gamma = data[0][0]
    n = x.shape[0]
    N = (n - 1) // 2
    blocks, row = fac[0], fac[3]
    _pendula_xi(data, x, f0)
    for i in range(N):
        a11, a12 = 1.0, -0.5 * h
        a21, a22 = -0.5 * h * np.cos(x[i]), 1.0 + 0.5 * h * gamma
        det = a11 * a22 - a12 * a21
        blocks[i, 0], blocks[i, 1] = a22 / det, -a12 / det
        blocks[i, 2], blocks[i, 3] = -a21 / det, a11 / det
        row[i] = h * gamma * x[N + i]
    return True


@jit
def _pendula_solve(fac, r):
    blocks, row = fac[0], fac[3]
    N = blocks.shape[0]
    last = r[2 * N]
    for i in range(N):
        r1, r2 = r[i], r[N + i]
        c1 = blocks[i, 0] * r1 + blocks[i, 1] * r2
        c2 = blocks[i, 2] * r1 + blocks[i, 3] * r2
        r[i], r[N + i] = c1, c2
        last += row[i] * c2
    r[2 * N] = last


# -- one driver for the four: the system chosen by ``kind`` (a branch per call, no function passed) -------------
GAS, EULER, FISH, PENDULA = 0, 1, 2, 3

#: when each floor takes a fresh Jacobian: after a first contraction rate above this (the library's 0.1), or at
#: every step (-1) where a Jacobian costs about one iteration or less
REFRESH = {GAS: -1.0, EULER: THETA_REFRESH, FISH: THETA_REFRESH, PENDULA: -1.0}


@jit
def _data(p, eps):
    """The data of a system that needs only its params and eps (the driver's one layout: params, eps, Zeitlin's
    index and factor tables, the random Fish system's K; empty where unused)."""
    return p, eps, np.empty((0, 0, 2), dtype=np.int64), np.empty((0, 0, 6)), np.empty((0, 0))


@jit
def _field(kind, data, x, y, H0, S_x, F, scratch):
    if kind == GAS:
        return _gas_field(data, x, y, H0, S_x, F, scratch)
    if kind == EULER:
        return _euler_field(data, x, y, H0, S_x, F, scratch)
    if kind == FISH:
        return _fish_field(data, x, y, H0, S_x, F, scratch)
    return _pendula_field(data, x, y, H0, S_x, F, scratch)


@jit
def _xi(kind, data, x, out):
    if kind == GAS:
        _gas_xi(data, x, out)
    elif kind == EULER:
        _euler_xi(data, x, out)
    elif kind == FISH:
        _fish_xi(data, x, out)
    else:
        _pendula_xi(data, x, out)


@jit
def _energy(kind, data, y):
    if kind == GAS:
        return _gas_energy(data, y)
    if kind == EULER:
        return _euler_energy(data, y)
    if kind == FISH:
        return _fish_energy(data, y)
    return _pendula_energy(data, y)


@jit
def _gradients(kind, data, y, gh, gs):
    if kind == GAS:
        _gas_gradients(data, y, gh, gs)
    elif kind == EULER:
        _euler_gradients(data, y, gh, gs)
    elif kind == FISH:
        _fish_gradients(data, y, gh, gs)
    else:
        _pendula_gradients(data, y, gh, gs)


@jit
def _refresh(kind, data, x, h, fac, f0):
    if kind == PENDULA:
        return _pendula_refresh(data, x, h, fac, f0)
    if kind == FISH:
        _fish_jacobian(data, x, fac, f0)
    else:
        _differences(kind, data, x, fac, f0)
    return _factor(fac, h)


@jit
def _solve(kind, fac, r):
    if kind == PENDULA:
        _pendula_solve(fac, r)
    else:
        _dense_solve(fac, r)


# -- the catalogue's systems -------------------------------------------------------------------------------------
@jit
def run_floor(kind, data, fac, origin, direction, theta_refresh, x0, h, steps):
    """``steps`` floor steps of the system ``kind`` from ``x0`` (``_drive``)."""
    return _drive(kind, data, fac, origin, direction, theta_refresh, x0, h, steps)


@jit
def field_many(kind, data, x, y, H0, S_x, times):
    """``times`` evaluations of the floor's discrete field F(x, y) (for the cost of one)."""
    n = x.shape[0]
    F, scratch = np.empty(n), np.empty((6, n))
    total, y0 = 0.0, y[0]
    for _ in range(times):
        total += _field(kind, data, x, y, H0, S_x, F, scratch) + F[0]
        y[0] = y0 + 0.0 * total  # nothing hoisted out of the loop
    return total


#: one floor run: the final state, the steps that failed the acceptance (or did not converge), the steps that did
#: not converge, Newton iterations, Jacobians, level moves of H, and the largest |H - H(x0)| and move of S against
#: its direction, in ulps of their terms
FloorRun = namedtuple("FloorRun", "x failures unconverged iterations refreshes moves worst_H worst_S")


@dataclass
class Floor:
    """The floor of one system: its data built once (Zeitlin's tables, the random Fish system's K, the factors'
    storage), ``run(x0, h, steps)`` a ``FloorRun``."""

    kind: int
    data: tuple
    fac: tuple
    origin: np.ndarray
    direction: float
    theta_refresh: float

    def run(self, x0, h, steps):
        x0 = np.ascontiguousarray(x0, dtype=np.float64)
        out = run_floor(self.kind, self.data, self.fac, self.origin, self.direction, self.theta_refresh, x0, h, steps)
        return FloorRun(*out)

    def fields(self, x, y, times):
        """``times`` evaluations of the discrete field between ``x`` and ``y`` (compiled: for the cost of one)."""
        x, y = np.ascontiguousarray(x, dtype=np.float64), np.array(y, dtype=np.float64)
        H0, _, S_x, _ = energy(self.kind, self.data, x)
        return field_many(self.kind, self.data, x, y, H0, S_x, times)

    def residual_ulps(self, x0, x, y, h):
        """How far the step from x to y is from the root of this scheme, in ulps of ``|y|_inf``."""
        x0, x, y = (np.ascontiguousarray(v, dtype=np.float64) for v in (x0, x, y))
        return residual_ulps(self.kind, self.data, x0, x, y, h)


@jit
def residual_ulps(kind, data, x0, x, y, h):
    """The floor's scheme at a step from x to y: ``max_i |(y - x) - h F(x, y)|_i`` in ulps of ``|y|_inf`` (F with
    H anchored to H(x0)): how far y is from the step's root (a few ulps for a step solved to round-off)."""
    n = x.shape[0]
    F, scratch = np.empty(n), np.empty((6, n))
    H0 = _energy(kind, data, x0)[0]
    S_x = _energy(kind, data, x)[2]
    _field(kind, data, x, y, H0, S_x, F, scratch)
    worst, size = 0.0, 0.0
    for i in range(n):
        worst = max(worst, abs((y[i] - x[i]) - h * F[i]))
        size = max(size, abs(y[i]))
    return worst / (EPS * size)


@jit
def energy(kind, data, y):
    """``(H, sum_i |y_i dH_i|, S, sum_i |y_i dS_i|)`` of the system ``kind`` at y."""
    return _energy(kind, data, y)


def floor_for(system, theta_refresh=None):
    """The ``Floor`` of a catalogue system (``gas_containers()``, ``euler_zeitlin(N)``, ``random_fish(n)``,
    ``damped_pendula(N)`` in either form) with its params and eps > 0, or None for another system (or one with a
    part switched off); ``theta_refresh`` defaults to ``REFRESH``'s choice for the system."""
    name = system.name
    if not system.hamiltonian or system.eps == 0.0:  # the floors take both parts (and S's dissipative rule)
        return None
    params = np.ascontiguousarray(system.params, dtype=np.float64)
    n = system.dim
    dense = _new_dense(n)
    if name == "gas_containers":
        kind, data, fac, origin, direction = GAS, _data(params, 1.0), dense, (0.0, 0.0), 1.0  # E(0) not finite: 0
    elif name.startswith("euler_zeitlin_N"):
        index, factors, weights = euler_tables(int(name.removeprefix("euler_zeitlin_N")))
        kind, data, fac = EULER, (weights, float(system.eps), index, factors, np.empty((0, 0))), dense
        origin, direction = (0.0, 0.0), -1.0
    elif name.startswith("random_fish_"):
        empty = (np.empty((0, 0, 2), dtype=np.int64), np.empty((0, 0, 6)))
        kind, data, fac = FISH, (params, float(system.eps), *empty, np.zeros((n, n))), dense
        origin, direction = (params[_COS] * n, 0.0), -1.0  # H(0) = 0.2 n
    elif name.startswith("damped_pendula_"):
        N = (n - 1) // 2
        fac = (np.empty((N, 4)), np.empty(0), np.empty(0, dtype=LAPACK_INT), np.empty(N), np.empty(0))
        kind, data, origin, direction = PENDULA, _data(params, 1.0), (float(N), 0.0), 1.0  # E(0) = N
    else:
        return None
    theta = REFRESH[kind] if theta_refresh is None else float(theta_refresh)
    return Floor(kind, data, fac, np.array(origin, dtype=np.float64), direction, theta)
