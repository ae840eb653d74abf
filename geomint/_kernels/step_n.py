"""The steps in R^n: the projected metriplectic discrete-gradient step, solved to round-off, and RK4.

For discrete gradients ``dgH``, ``dgS`` (``dgF . (x' - x) = F(x') - F(x)``) the step solves

    x' - x = h [ Pbar dgH + eps Dbar dgS ],   Pbar = Pi_S P(xbar) Pi_S,   xbar = (x + x') / 2,
    Pi_S = I - s s^T,  s = dgS / |dgS|,
    Dbar = dgH dgH^T - |dgH|^2 I            (the paper's metric, from the discrete gradient)
         = Pi_H M(xbar) Pi_H                (a metric M the user gives; Pi_H likewise from dgH)

so that ``H(x') - H(x) = dgH . (x' - x) = 0`` (Pbar skew, ``Dbar dgH = 0``) and
``S(x') - S(x) = h eps dgS . Dbar dgS``, of the metric's sign (``Pbar dgS = 0``
by the projection; without it S is a Casimir of ``P(xbar)`` for ``grad S(xbar)``
only, not for ``dgS``, and drifts).  Order 2 for the symmetric discrete
gradients (Gonzalez, AVF, symmetrized Itoh-Abe), 1 for Itoh-Abe.  In R^3,
``Pi P Pi v = v x (J . s) s``: the R^3 kernels' ``Jbar`` (``discrete_field``).
Reference: docs/engine_rn.md; the scheme for R^3 is Fish's construction with
Gonzalez's discrete gradient (docs/theory.md).

**Solving the step.**  Two solvers, chosen per step by how the iteration
contracts (``choose_solver``; docs/engine_rn.md, "Solving the step"):

* simplified Newton with the matrix ``A = I - (h/2) D xi`` (the continuous
  field's Jacobian, by differences at the state: n field evaluations, each in
  the operators' native form), LU-factored in place (by hand below
  ``LAPACK_MIN_N``, by LAPACK's ``dgetrf`` from it) and kept in the workspace
  across iterations and steps while the iteration contracts, refreshed where
  it does not or where ``h`` changes (the rules of SUNDIALS and RADAU5);
  O(n^2) per iteration, O(n^3) per refresh;
* above ``SPARSE_MIN_N``, the same Newton with ``D xi`` differenced and factored by its zero pattern where the
  pattern pays (``sparse_n``: probed once a run, coloured, block by block, a dense row whose coordinate feeds
  nothing back solved exactly by one directional difference a solve);
* either Jacobian taken fresh at every step where a refresh costs at most ``FRESH_REFRESH_COST`` field
  evaluations (a few coordinates, or a cheap pattern);
* the fixed-point iteration ``x' <- x + h F(x, x')``, no Jacobian: O(cost of
  the field) per iteration, converging linearly at the rate ``~ (h/2) |D xi|``:
  kept while its iterations cost less than Newton's (its rate makes its count:
  ``log(round-off / start error) / log(rate)``), Newton taking over where they
  do not or where it stops contracting.

Both start from a predictor (the increment extrapolated from the last three;
without a history, the linearly implicit step at a fresh Jacobian for Newton,
the explicit Euler step for the fixed point) and stop at round-off: when the
correction is within a few ulps of the increment, its contraction bounds the
remaining error below that, or it stops shrinking.  **Exact under a stopped
solve**: a solve stopped with residual r moves H by ``dgH . r``; the step
then moves along ``d = Pi_S grad H(x')`` (which leaves S unchanged to first
order) to ``H(x') = H(x0)`` by scalar Newton (``to_level``), and, where S has
moved against its direction by more than round-off, along
``Pi_H grad S(x')`` back to S(x) (which leaves H unchanged to first order).
Both moves are of the size of the residual, so they keep the order, whichever
solver stopped.  A step whose result still misses H by ``ACCEPT_ULPS`` of its
terms, or S by ``ACCEPT_S_ULPS``, fails (``NOT_ACCEPTED``) and the run stops
with the state before it.

**Damped** (``DampedGonzalez``): the dissipation is scaled by
``phi = 1 / sqrt(1 + (h kappa / 2)^2)``, ``kappa = |D (eps D grad S)(x)|_inf``
(as ``dg_step.damping_factor`` in R^3), so that the midpoint-type step damps a
stiff dissipative mode by ``(1 - w) / (1 + w)``, ``w -> 1``, instead of
reflecting it; ``phi = 1 + O(h^2)`` keeps order 2 and any ``phi > 0`` keeps H
exact and S monotone.  kappa comes with the Jacobian (each refresh
differences the Hamiltonian and dissipative parts apart, at no extra field
evaluation) and is kept until the next refresh; a run that never refreshes
(fixed point) takes it once by differences (n evaluations of the dissipative
part).
"""

import numpy as np
from numba import njit

from .discrete_gradient import SWITCH
from .field_n import (
    apply_M,
    apply_P,
    dissipative_into,
    dissipative_norm,
    field_into,
    jacobian_into,
    jacobian_parts_into,
    non_finite_culprit_n,
)
from .jit import hot, inner
from .layout import (
    ACCEPT_S_ULPS,
    ACCEPT_ULPS,
    AVF,
    EPS,
    GONZALEZ,
    ITOH_ABE,
    M_ACTION,
    NEWTON_FAILED,
    NON_FINITE,
    NOT_ACCEPTED,
    OK,
    P_ACTION,
    PAPER_METRIC,
    SQRT_EPS,
    SYMMETRIZED_ITOH_ABE,
    UNKNOWN,
    StepResult,
)
from .newton import ARMIJO, HOMING_MIN_DAMPING
from .sparse_n import factor as factor_blocks
from .sparse_n import fits, keep_base, probe, refresh_evaluations
from .sparse_n import refresh as refresh_blocks
from .sparse_n import refresh_cost as refresh_cost_blocks
from .sparse_n import solve as solve_blocks
from .sparse_n import solve_weight as solve_weight_blocks
from .vecn import (
    LAPACK_INT,
    abs_dot,
    axpy_into,
    copy_into,
    dot,
    lapack_factor,
    lapack_solve,
    lu_factor,
    lu_solve,
    norm_inf,
    remove_along,
    remove_scaled,
    scaled_norm2,
)

#: a first contraction rate above this makes the next step take a fresh Jacobian
THETA_REFRESH = 0.1


#: the level corrections move along the plain gradient where its part off the other gradient is below this
PARALLEL = 1e-4


#: a step whose increment is below this fraction of |x| is at rest: where the corrections cannot keep H and S
#: (an equilibrium), it keeps x
REST = SQRT_EPS


#: the evaluations a level correction spends bracketing and bisecting the level where scalar Newton ends outside
#: its tolerance (``to_level``)
LEVEL_SEARCH = 16


#: rounds of the level corrections (each a few scalar Newton steps)
CORRECTION_ROUNDS = 3


#: the largest n for which the symmetrized Itoh-Abe gradient (an average over the n! coordinate orders) is offered
MAX_SYMMETRIZED_DIM = 5


#: the solvers (``choose_solver``) compare costs in units of one evaluation of the discrete field, modelled as
#: ``FIELD_COST_FIXED + FIELD_COST_MATRIX n^2`` flops where P and M are matrices (forming, applying and sizing P) and
#: ``FIELD_COST_FIXED + FIELD_COST_ACTION n`` where one of them is an action (the fixed part: the discrete
#: gradients, projections and calls around the user's functions, ~1 us at n = 4 to 24); a Newton iteration adds
#: the solve, 2 n^2 flops, a refresh n + 1 field evaluations and the factorisation, 2 n^3 / 3 flops
#: (docs/engine_rn_speed.md: the calibration)
FIELD_COST_FIXED = 1000.0
FIELD_COST_MATRIX = 4.0
FIELD_COST_ACTION = 100.0


#: a fixed point whose mean contraction rate exceeds this stops (it is not contracting usefully)
THETA_DIVERGE = 0.9


#: above this n the first step iterates the fixed point (a first Jacobian costs n field evaluations and O(n^3));
#: at or below it, Newton
FIRST_NEWTON_N = 64


#: above this n a run probes its Jacobian's zero pattern (n + 1 field evaluations, once) and, where the pattern
#: pays (``sparse_n``), differences and factors the Newton matrix by it
SPARSE_MIN_N = 64


#: a refresh that costs at most this many field evaluations (``refresh_cost``: with the zero pattern, or dense for
#: n <= 4) is taken at every Newton step, with the linearly implicit start (fewer iterations than kept factors and
#: the extrapolated start: the pendula, the gas containers 3.7 against 7.1)
FRESH_REFRESH_COST = 6.0


#: Newton iterations per step, and refreshes per Newton step, assumed before any are measured: one refresh per
#: probe interval (``PROBE_MIN`` steps), the one a return to Newton after fixed-point steps takes
NEWTON_ITERATIONS_ASSUMED = 3.0
REFRESHES_ASSUMED = 0.125


#: the largest n whose workspace holds the dense Jacobian and its factors (2 n^2 floats: 64 MiB at 2048); above
#: it the step iterates the fixed point only
DENSE_MAX_N = 2048


#: the LU factors by LAPACK's dgetrf from this n on, by hand below (docs/engine_rn_speed.md)
LAPACK_MIN_N = 24


#: fixed-point iterations allowed per step, per Newton iteration allowed (``max_iter``), where Newton is not
#: available (n > ``DENSE_MAX_N``) or not wanted (``FIXED_POINT_ONLY``)
FIXED_POINT_ITERATIONS = 8


#: the running averages of a Newton step's iterations and refreshes follow each new step with this weight
COST_WEIGHT = 0.125


#: in Newton mode the fixed point is tried again after this many steps, the interval doubling after each failed
#: try up to ``PROBE_MAX``
PROBE_MIN = 8
PROBE_MAX = 512


# -- the solver a workspace asks for (``WN_SOLVER``; a new workspace holds 0: chosen per step) -------------------
AUTO = 0
NEWTON_ONLY = 1
FIXED_POINT_ONLY = 2


# -- the workspace of a run in R^n: a header, vectors of length n, the Jacobian and its LU factors ---------------
WN_H = 0  # the step the history was taken with
WN_HISTORY = 1  # increments in the history (0..3)
WN_FACTORED = 2  # 1: the LU factors of A = I - h/2 D xi at WN_LU_H are valid
WN_LU_H = 3  # the step the factors were taken with
WN_LAPACK = 4  # 1: the factors are LAPACK's (``lapack_solve``), 0: ``lu_factor``'s
WN_MODE = 5  # 1: the next step starts with the fixed point, 0: with Newton
WN_RATE = 6  # the last fixed-point contraction rate measured (the geometric mean over the step)
WN_PROBE = 7  # Newton mode: steps before the fixed point is tried again
WN_BACKOFF = 8  # the interval between those tries
WN_KAPPA = 9  # the damped step's kappa, |D (eps D grad S)|_inf, valid where WN_KAPPA_VALID is 1
WN_KAPPA_VALID = 10
WN_SOLVER = 11  # AUTO, NEWTON_ONLY or FIXED_POINT_ONLY (set by the caller)
WN_NEWTON_ITERATIONS = 12  # the running average of a Newton step's iterations (0: none measured yet)
WN_FIXED_POINT_ITERATIONS = 13  # the iterations of the last fixed-point step
WN_REFRESHES = 14  # the running average of a Newton step's refreshes (the first step's not counted)
WN_SPARSE = 15  # the Jacobian's zero pattern (``sparse_n``): 0 not probed yet, 1 in use, -1 not used
WN_GAINS = 16  # and 17: the gains (``gains``) of the last step's first iterate over |h|, 0 before any
WN_HEADER = 18
V_DX1, V_DX2, V_DX3 = 0, 1, 2  # the last three increments
V_NEW = 3  # the new state
V_MID = 4  # the midpoint, and scratch of the field's Jacobian
V_DGH, V_DGS = 5, 6  # the discrete gradients
V_F = 7  # the discrete field
V_R = 8  # the residual / the Newton correction
V_A, V_B, V_C = 9, 10, 11  # scratch
V_K1, V_K2, V_K3, V_K4 = 12, 13, 14, 15  # RK4 stages
V_PIVOTS = 16  # the pivots of the factors (LAPACK's: integers in the same space)
V_G0 = 17  # the dissipative part at x (damped step)
V_ROWS = 18  # scratch (row sums)
V_EH, V_ES = 19, 20  # the discrete gradients scaled by their largest component (``discrete_field_n``)
V_GATHER = 21  # scratch of the block solve (``sparse_n.solve``)
V_BASE, V_MOVED = 22, 23  # the point of the block Jacobian, and scratch of the solve's directional difference
N_VECTORS = 24


@njit(inline="always")  # called from Python (the run's workspace) and from the kernels
def work_size(n):
    """Floats of the workspace of a run in R^n (one slot): header, ``N_VECTORS`` vectors and, for n up to
    ``DENSE_MAX_N``, D xi and the LU factors."""
    return WN_HEADER + N_VECTORS * n + (2 * n * n if n <= DENSE_MAX_N else 0)


@inner
def vector(work, k, n):
    """The workspace's vector ``k`` (``V_*``), a view of length n."""
    start = WN_HEADER + k * n
    return work[start : start + n]


@inner
def jacobian_matrix(work, n):
    start = WN_HEADER + N_VECTORS * n
    return work[start : start + n * n].reshape((n, n))


@inner
def lu_matrix(work, n):
    start = WN_HEADER + N_VECTORS * n + n * n
    return work[start : start + n * n].reshape((n, n))


@inner
def lu_flat(work, n):
    """The LU factors' n^2 floats as one vector (``vecn.lu_factor``'s layout; ``lu_matrix`` as a matrix)."""
    start = WN_HEADER + N_VECTORS * n + n * n
    return work[start : start + n * n]


@inner
def blocks_struct(work, n):
    """Where the workspace uses the Jacobian's zero pattern (``WN_SPARSE`` 1): ``sparse_n``'s struct, in the LU
    factors' n^2 floats."""
    return lu_flat(work, n)


@inner
def blocks_factors(work, n):
    """And ``sparse_n``'s packed factors, in the dense Jacobian's n^2 floats."""
    start = WN_HEADER + N_VECTORS * n
    return work[start : start + n * n]


@inner
def sparse(work):
    return work[WN_SPARSE] > 0.0


@inner
def lapack_pivots(work, n):
    """The pivots of LAPACK's factors: ``LAPACK_INT`` integers in the space of the vector ``V_PIVOTS``."""
    return vector(work, V_PIVOTS, n).view(LAPACK_INT)[:n]


@hot
def term_scale_n(f_old, f_new, gradient, x, constant):
    """``max(|F(x)|, |F(x')|, sum_i |d_i F x_i|) + |F(0)|``: the size of the terms of F (the round-off of its
    values, ``roundoff.term_scale`` in R^3)."""
    return max(abs(f_old), abs(f_new), abs_dot(gradient, x)) + abs(constant)


# -- discrete gradients ------------------------------------------------------------------------------------------
@hot
def _project_identity(out, f_old, f_new, dx, y, gain, constant):
    """Gonzalez's projection of ``out`` onto ``out . dx = F(x') - F(x)``, in place, under the R^3 switching rule
    (``discrete_gradient.gonzalez``): only where the defect exceeds its round-off bound and its correction's
    round-off, carried into the step by ``gain``, stays below 1% of the step.  Returns that round-off (0 where
    the correction is skipped)."""
    slope = dot(out, dx)
    defect = f_new - f_old - slope
    bound = 2.0 * EPS * term_scale_n(f_old, f_new, out, y, constant)
    largest = norm_inf(dx)
    if not abs(defect) > bound or not bound * gain <= 0.01 * largest * largest or largest == 0.0:
        return 0.0
    inverse = 1.0 / largest  # dx scaled by its largest component: |dx|^2 neither underflows nor overflows
    length2 = scaled_norm2(dx, inverse)
    c = defect * inverse * inverse / length2
    for i in range(dx.shape[0]):
        out[i] += c * dx[i]
    return bound / (largest * np.sqrt(length2))


@inner
def _itoh_abe_order(out, F, grad_F, params, x, y, f_old, f_new, order, vertex, mid, weight):
    """``out += weight *`` Itoh-Abe's gradient with the coordinates changed in ``order``; the quotient of a
    coordinate that moves by at most ``SWITCH |x|_inf`` is the partial derivative at the edge's midpoint."""
    n = x.shape[0]
    size = max(norm_inf(x), norm_inf(y))
    copy_into(vertex, x)
    f_prev = f_old
    for k in range(n):
        i = int(order[k])
        d = y[i] - x[i]
        vertex[i] = y[i]
        f_next = f_new if k == n - 1 else F(vertex, params)
        if abs(d) <= SWITCH * size:
            copy_into(mid, vertex)
            mid[i] = 0.5 * (x[i] + y[i])
            out[i] += weight * grad_F(mid, params)[i]
        else:
            out[i] += weight * (f_next - f_prev) / d
        f_prev = f_next


@hot
def discrete_gradient_n(kind, coeffs, F, grad_F, params, x, y, f_old, f_new, gain, constant, out, scratch):
    """A discrete gradient of ``F`` between ``x`` and ``y`` into ``out`` (``kind``: ``layout`` codes):

    * Gonzalez: ``grad F(xbar) + N dx / |dx|^2``, ``N = F(y) - F(x) - grad F(xbar) . dx``
      (J. Nonlinear Sci. 6 (1996) 449); symmetric, order 2;
    * AVF: ``sum_k w_k grad F(x + s_k dx)`` (Gauss-Legendre nodes ``s_k`` and weights ``w_k`` in ``coeffs``),
      projected onto the identity as Gonzalez's (Quispel & McLaren, J. Phys. A 41 (2008) 045206); order 2;
    * Itoh-Abe: coordinate increments in the order 1..n (J. Comput. Phys. 76 (1988) 85); order 1;
    * symmetrized Itoh-Abe: Itoh-Abe averaged over the n! orders (n <= ``MAX_SYMMETRIZED_DIM``); order 2.

    ``f_old`` is F at ``x`` (for H: the energy anchor, so the root lands on the anchor's level);
    ``scratch`` holds five vectors (the increment, two points, the coordinate order and Heap's counters).
    Returns the round-off bound of the quotients.
    """
    n = x.shape[0]
    dx, mid, vertex = scratch[0], scratch[1], scratch[2]
    for i in range(n):
        dx[i] = y[i] - x[i]
    if kind == GONZALEZ:
        for i in range(n):
            mid[i] = 0.5 * (x[i] + y[i])
        copy_into(out, grad_F(mid, params))
    else:
        out[:] = 0.0
    if kind == AVF:
        nodes = coeffs.shape[0] // 2
        for k in range(nodes):
            for i in range(n):
                mid[i] = x[i] + coeffs[k] * dx[i]
            g = grad_F(mid, params)
            w = coeffs[nodes + k]
            for i in range(n):
                out[i] += w * g[i]
    elif kind == ITOH_ABE:
        order = scratch[3]
        for i in range(n):
            order[i] = i
        _itoh_abe_order(out, F, grad_F, params, x, y, f_old, f_new, order, vertex, mid, 1.0)
    elif kind == SYMMETRIZED_ITOH_ABE:
        _symmetrized(out, F, grad_F, params, x, y, f_old, f_new, vertex, mid, scratch[3], scratch[4])
    return _project_identity(out, f_old, f_new, dx, y, gain, constant)


@inner
def _symmetrized(out, F, grad_F, params, x, y, f_old, f_new, vertex, mid, order, counters):
    """Itoh-Abe's gradient averaged over every order of the coordinates (Heap's algorithm, n! orders;
    ``order`` and ``counters`` are scratch vectors)."""
    n = x.shape[0]
    for i in range(n):
        order[i] = i
        counters[i] = 0.0
    total = 1
    for k in range(2, n + 1):
        total *= k
    weight = 1.0 / total
    _itoh_abe_order(out, F, grad_F, params, x, y, f_old, f_new, order, vertex, mid, weight)
    i = 1
    while i < n:
        if counters[i] < i:
            j = int(counters[i]) if i % 2 == 1 else 0
            order[j], order[i] = order[i], order[j]
            _itoh_abe_order(out, F, grad_F, params, x, y, f_old, f_new, order, vertex, mid, weight)
            counters[i] += 1
            i = 1
        else:
            counters[i] = 0
            i += 1


# -- the discrete field ------------------------------------------------------------------------------------------
@hot
def discrete_field_n(kind, coeffs, model, eps, hamiltonian, x, H_x, S_x, y, gain_h, gain_s, work, sized):
    """``F(x, y)`` of the module docstring into the workspace's ``V_F``; returns ``(H(y), S(y), noise, |P|, |M|)``
    with ``noise`` the round-off bound of the discrete gradients' quotients and the sizes of ``P(xbar)`` and
    ``M(xbar)`` (``field_n.apply_P``: the infinity norm of a matrix, the gain of an action on the vector it is
    applied to; 0 where not evaluated), from which the next iterate's gains are taken (``gains``).  P and M are
    applied in their native form: an action costs what it costs, a matrix O(n^2)."""
    n = x.shape[0]
    p = model.params
    dgh, dgs, F = vector(work, V_DGH, n), vector(work, V_DGS, n), vector(work, V_F, n)
    mid, a, b = vector(work, V_MID, n), vector(work, V_A, n), vector(work, V_B, n)
    scratch = (a, b, vector(work, V_C, n), vector(work, V_K1, n), vector(work, V_K2, n))
    H_y, S_y = model.H(y, p), model.S(y, p)
    noise = discrete_gradient_n(
        kind, coeffs, model.H, model.grad_H, p, x, y, H_x, H_y, gain_h, model.origin[0], dgh, scratch
    )
    with_s = eps != 0.0 or hamiltonian
    if with_s:
        noise += discrete_gradient_n(
            kind, coeffs, model.S, model.grad_S, p, x, y, S_x, S_y, gain_s, model.origin[1], dgs, scratch
        )
    for i in range(n):
        mid[i] = 0.5 * (x[i] + y[i])
    norm_p, norm_m = 0.0, 0.0
    user_metric = eps != 0.0 and model.metric != PAPER_METRIC
    # The projections along dgS and dgH (``vecn.remove_along``: u - (u . e / e . e) e, e = d / |d|_inf), each
    # direction scaled once for all of them (``vecn.remove_scaled``).
    eh, es, c = vector(work, V_EH, n), vector(work, V_ES, n), vector(work, V_C, n)
    size_h, size_s = norm_inf(dgh), norm_inf(dgs) if hamiltonian else 0.0
    with_h = size_h != 0.0 and np.isfinite(size_h)
    with_s = hamiltonian and size_s != 0.0 and np.isfinite(size_s)
    inverse_h = 1.0 / size_h if with_h else 0.0
    inverse_s = 1.0 / size_s if with_s else 0.0
    for i in range(n):
        eh[i] = dgh[i] * inverse_h
        es[i] = dgs[i] * inverse_s
    hh, s_h = (dot(eh, eh), dot(dgs, eh)) if with_h else (0.0, 0.0)  # eh . eh, dgS . eh
    ss, h_s = (dot(es, es), dot(dgh, es)) if with_s else (0.0, 0.0)  # es . es, dgH . es
    if hamiltonian:  # Pi_S P(xbar) Pi_S dgH
        k = h_s / ss if with_s else 0.0
        for i in range(n):
            a[i] = dgh[i] - k * es[i] if with_s else dgh[i]
        norm_p = apply_P(model, mid, a, F, sized)
    else:
        F[:] = 0.0
    if user_metric:  # Pi_H M(xbar) Pi_H dgS
        k = s_h / hh if with_h else 0.0
        for i in range(n):
            c[i] = dgs[i] - k * eh[i] if with_h else dgs[i]
        norm_m = apply_M(model, mid, c, b, sized)
    k_f = dot(F, es) / ss if with_s else 0.0  # the products' components along es and eh
    k_b = dot(b, eh) / hh if user_metric and with_h else 0.0
    for i in range(n):
        if with_s:
            F[i] -= k_f * es[i]
        if user_metric:
            if with_h:
                b[i] -= k_b * eh[i]
            F[i] += eps * b[i]
    if eps != 0.0 and model.metric == PAPER_METRIC:  # (dgH . dgS) dgH - |dgH|^2 dgS = -|dgH|^2 Pi_H dgS
        cd, dd = dot(dgh, dgs), dot(dgh, dgh)
        for i in range(n):
            F[i] += eps * (cd * dgh[i] - dd * dgs[i])
    remove_scaled(F, eh, hh)  # F . dgH = 0 holds identically; this removes the rounding of the products along dgH
    return H_y, S_y, noise, norm_p, norm_m


@inner
def gains(model, eps, h, dgh, dgs, norm_p, norm_m):
    """How far the step moves per unit change of ``dgH`` and of ``dgS`` (bounds of ``|h| |dF/d dgF|``), which
    carry the quotients' round-off into the step (``_project_identity``): ``|h| (|P| + 2 eps |dgH| |dgS|)`` and
    ``|h| (|P| |dgH| / |dgS| + eps |dgH|^2)`` for the paper's metric (the projection turns with dgS), ``|M|``
    in place of ``|dgH| |dgS|`` and ``|dgH|^2`` for the user's."""
    a, b = norm_inf(dgh), norm_inf(dgs)
    if model.metric == PAPER_METRIC:
        return abs(h) * (norm_p + 2.0 * eps * a * b), abs(h) * (norm_p * a / b + eps * a * a)
    return abs(h) * (norm_p + eps * norm_m * b / a), abs(h) * (norm_p * a / b + eps * norm_m)


# -- the level corrections ---------------------------------------------------------------------------------------
@inner
def to_level(model, y, value, target, energy, d, before, tolerance):
    """Move ``y`` (in place) towards ``F(y) = target`` within ``tolerance``: F = H and G = S where ``energy``
    (S unchanged to first order), else F = S and G = H.  Along ``d = Pi_G grad F(y)``, or ``d = grad F`` where
    the two gradients are nearly parallel (an equilibrium: ``|Pi_G grad F|^2 < PARALLEL |grad F|^2``), where
    that direction is ill-conditioned and a move of the size of the level's round-off changes G by round-off
    too.

    Scalar Newton, at most 3 steps, each kept only where it brings F closer to the target.  Its moves end in
    the round-off of F's evaluation, which for a sum of many terms spans several ulps of them and is not smooth
    on that scale (a sum's terms are rounded into its partial sums), wider than ``tolerance``: a step then
    lands anywhere in that noise.  Where Newton stops outside ``tolerance``, the level is bracketed along
    ``d`` (the predicted root, then twice as far, ...) and bisected, at most ``LEVEL_SEARCH`` evaluations, until
    F reads within ``tolerance`` of the target; the closest reading is kept.  Each point tried is within the
    level's round-off of the root.
    ``d`` and ``before`` are scratch vectors.  Returns ``(F(y), evaluations)``."""
    p = model.params
    evaluations = 0
    slope = 0.0
    for _ in range(3):
        if abs(value - target) <= tolerance:
            return value, evaluations
        g = model.grad_H(y, p) if energy else model.grad_S(y, p)
        o = model.grad_S(y, p) if energy else model.grad_H(y, p)
        remove_along(copy_into(d, g), o)
        slope, full = dot(g, d), dot(g, g)
        if not slope >= PARALLEL * full:
            copy_into(d, g)
            slope = full
        if not (slope > 0.0) or not np.isfinite(slope):
            return value, evaluations
        lam = (target - value) / slope
        copy_into(before, y)
        for i in range(y.shape[0]):
            y[i] += lam * d[i]
        moved = model.H(y, p) if energy else model.S(y, p)
        evaluations += 1
        if not abs(moved - target) < abs(value - target):
            copy_into(y, before)
            break
        value = moved
    if abs(value - target) <= tolerance or not tolerance > 0.0 or not slope > 0.0:
        return value, evaluations
    # bracket the level along d from y (lam = 0) and bisect
    copy_into(before, y)
    best, best_lam = value, 0.0
    lo, f_lo = 0.0, value - target
    reach = (target - value) / slope
    hi, bracketed = reach, False
    for _ in range(LEVEL_SEARCH):
        lam = 0.5 * (lo + hi) if bracketed else hi
        if bracketed and (lam == lo or lam == hi):  # bisected to the spacing of lam
            break
        for i in range(y.shape[0]):
            y[i] = before[i] + lam * d[i]
        moved = model.H(y, p) if energy else model.S(y, p)
        evaluations += 1
        f = moved - target
        if abs(f) < abs(best - target):
            best, best_lam = moved, lam
            if abs(f) <= tolerance:
                break
        if not np.isfinite(f):
            break
        if (f > 0.0) == (f_lo > 0.0):  # the same side as lo: the level lies beyond
            lo, f_lo = lam, f
            if not bracketed:
                reach *= 2.0
                hi = lo + reach
        else:
            hi, bracketed = lam, True
    for i in range(y.shape[0]):
        y[i] = before[i] + best_lam * d[i]
    return best, evaluations


# -- the Jacobian, the damping and the predictor -----------------------------------------------------------------
@inner
def damping(kappa, h):
    """``phi = 1 / sqrt(1 + (h kappa / 2)^2)`` (``dg_step.damping_factor``), 1 where that is not finite."""
    z = 0.5 * h * kappa
    if not np.isfinite(z):
        return 1.0
    return 1.0 / np.sqrt(1.0 + z * z)


@inner
def damped_eps(damped, eps, h, work):
    """The dissipation's factor of this step: ``eps phi`` with the workspace's kappa where ``damped``."""
    return eps * damping(work[WN_KAPPA], h) if damped and eps != 0.0 else eps


@hot
def refresh(model, eps, hamiltonian, damped, x, h, work):
    """``D xi(x)`` by differences into the workspace and ``A = I - h/2 D xi`` factored; returns False where
    ``A`` is singular.  Leaves ``xi(x)`` in ``V_K1``.  ``damped``: the Hamiltonian and dissipative parts are
    differenced apart (the dissipative Jacobian in the factors' space until they are formed), kappa is taken
    from the latter, and xi and D xi are those of the damped field ``P grad H + phi eps D grad S``."""
    n = x.shape[0]
    f0, g0 = vector(work, V_K1, n), vector(work, V_G0, n)
    jac = jacobian_matrix(work, n)
    shifted, column = vector(work, V_MID, n), vector(work, V_A, n)
    if damped and eps != 0.0:
        field_into(f0, model, 0.0, hamiltonian, x)
        dissipative_into(g0, model, eps, x)
        dis = lu_matrix(work, n)
        kappa = jacobian_parts_into(jac, dis, model, eps, hamiltonian, x, f0, g0, shifted, column, vector(work, V_B, n))
        work[WN_KAPPA], work[WN_KAPPA_VALID] = kappa, 1.0
        phi = damping(kappa, h)
        for i in range(n):
            f0[i] += phi * g0[i]
            for j in range(n):
                jac[i, j] += phi * dis[i, j]
    elif sparse(work):
        refresh_blocks(model, eps, hamiltonian, x, blocks_struct(work, n), blocks_factors(work, n), f0, shifted)
        keep_base(blocks_struct(work, n), x, f0, vector(work, V_BASE, n))
    else:
        field_into(f0, model, eps, hamiltonian, x)
        jacobian_into(jac, model, eps, hamiltonian, x, f0, shifted, column)
    return factor(work, n, h)


@hot
def factor(work, n, h):
    """``A = I - h/2 D xi`` from the kept Jacobian, factored in place: by hand below ``LAPACK_MIN_N``, by LAPACK
    from it; block by block where the workspace uses the Jacobian's zero pattern.  Returns False where A is
    singular."""
    if sparse(work):
        ok = factor_blocks(blocks_struct(work, n), blocks_factors(work, n), n, h)
        work[WN_FACTORED] = 1.0 if ok else 0.0
        work[WN_LU_H] = h
        return ok
    jac, lu = jacobian_matrix(work, n), lu_matrix(work, n)
    for i in range(n):
        for j in range(n):
            lu[i, j] = -0.5 * h * jac[i, j]
        lu[i, i] += 1.0
    if n >= LAPACK_MIN_N:
        ok = lapack_factor(lu, lapack_pivots(work, n))
        work[WN_LAPACK] = 1.0
    else:
        ok = lu_factor(lu_flat(work, n), 0, n, vector(work, V_PIVOTS, n), 0)
        work[WN_LAPACK] = 0.0
    work[WN_FACTORED] = 1.0 if ok else 0.0
    work[WN_LU_H] = h
    return ok


@hot
def solve(model, eps, hamiltonian, work, n, b):
    """``b = A^-1 b`` (in place) with the kept factors; returns the field evaluations it took (the block solve's
    bordered rows: ``sparse_n.solve``)."""
    if sparse(work):
        return solve_blocks(
            model,
            eps,
            hamiltonian,
            work[WN_LU_H],
            blocks_struct(work, n),
            blocks_factors(work, n),
            n,
            b,
            vector(work, V_GATHER, n),
            vector(work, V_BASE, n),
            vector(work, V_MOVED, n),
        )
    if work[WN_LAPACK] > 0.0:
        lapack_solve(lu_matrix(work, n), lapack_pivots(work, n), b)
    else:
        lu_solve(lu_flat(work, n), 0, n, vector(work, V_PIVOTS, n), 0, b)
    return 0


@inner
def kappa_by_differences(model, eps, x, work):
    """kappa (``WN_KAPPA``) for a step that holds no Jacobian: ``|D (eps D grad S)(x)|_inf`` by differences,
    n + 1 evaluations of the dissipative part.  Returns the evaluations."""
    n = x.shape[0]
    g0 = dissipative_into(vector(work, V_G0, n), model, eps, x)
    work[WN_KAPPA] = dissipative_norm(
        model, eps, x, g0, vector(work, V_MID, n), vector(work, V_A, n), vector(work, V_ROWS, n)
    )
    work[WN_KAPPA_VALID] = 1.0
    return n + 1


@inner
def predict(work, n, y, x):
    """``y = x +`` the increment extrapolated from the last (up to) three: error O(h^2), O(h^3), O(h^4)."""
    d1, d2, d3 = vector(work, V_DX1, n), vector(work, V_DX2, n), vector(work, V_DX3, n)
    k = work[WN_HISTORY]
    for i in range(n):
        if k >= 3.0:
            y[i] = x[i] + 3.0 * (d1[i] - d2[i]) + d3[i]
        elif k >= 2.0:
            y[i] = x[i] + 2.0 * d1[i] - d2[i]
        else:
            y[i] = x[i] + d1[i]


@inner
def remember_n(work, n, y, x, h):
    same = work[WN_H] == h and work[WN_HISTORY] > 0.0
    d1, d2, d3 = vector(work, V_DX1, n), vector(work, V_DX2, n), vector(work, V_DX3, n)
    for i in range(n):
        d3[i] = d2[i]
        d2[i] = d1[i]
        d1[i] = y[i] - x[i]
    work[WN_HISTORY] = min(3.0, work[WN_HISTORY] + 1.0) if same else 1.0
    work[WN_H] = h


# -- the solvers -------------------------------------------------------------------------------------------------
@inner
def _iterate(kind, max_iter, coeffs, model, eps, hamiltonian, x, H_x, S_x, h, work, newton, give_up, carry):
    """Iterate from the workspace's ``V_NEW`` (the start): simplified Newton with the kept factors where
    ``newton``, else the fixed point ``y <- x + h F(x, y)`` (the same iteration with A = I).  Returns
    ``(status, H(y), S(y), iterations, evaluations, rate, culprit)``: ``rate`` is the first contraction rate
    measured above round-off (Newton: how stale the factors are), or the geometric mean of the rates measured
    above the floor of round-off but the first (fixed point: how fast it converges; the first ratio can be a
    transient growth, where the Jacobian is far from normal).  A fixed point whose mean rate exceeds ``give_up``
    over two ratios or more stops (``NEWTON_FAILED``): another solver will do better.  ``carry``: the first
    iterate takes the last step's gains (below)."""
    n = x.shape[0]
    y, F, r = vector(work, V_NEW, n), vector(work, V_F, n), vector(work, V_R, n)
    previous, best, rate, measured, reference = np.inf, np.inf, 0.0, 0, np.inf
    extra = 0  # field evaluations of the solves (``solve``)
    # the first iterate takes the gains of the last step's first iterate where ``carry`` (the linearly implicit
    # start; else, and in the run's first step, none: the gradients uncorrected, which serve an extrapolated start
    # better); the later iterates those of the first (the sizes of P and M change by O(h) over a step)
    known = carry and work[WN_GAINS] > 0.0 and work[WN_GAINS + 1] > 0.0
    gain_h = work[WN_GAINS] * abs(h) if known else np.inf
    gain_s = work[WN_GAINS + 1] * abs(h) if known else np.inf
    H_y, S_y = np.nan, np.nan
    for iteration in range(1, max_iter + 1):
        sized = iteration == 1  # the sizes of P and M for the gains: the step's first iterate's serve the rest
        H_y, S_y, noise, norm_p, norm_m = discrete_field_n(
            kind, coeffs, model, eps, hamiltonian, x, H_x, S_x, y, gain_h, gain_s, work, sized
        )
        increment, size_f = 0.0, 0.0  # and norm_inf(F), NaN where F is not finite: one pass
        for i in range(n):
            r[i] = (y[i] - x[i]) - h * F[i]
            increment = max(increment, abs(y[i] - x[i]))
            a = abs(F[i])
            size_f = a if a > size_f or a != a else size_f
        if not (np.isfinite(size_f) and np.isfinite(H_y) and np.isfinite(S_y)):
            culprit = non_finite_culprit_n(model, y, hamiltonian)
            return NON_FINITE, H_y, S_y, iteration, iteration + extra, np.inf, culprit
        if sized:
            gain_h, gain_s = gains(model, eps, h, vector(work, V_DGH, n), vector(work, V_DGS, n), norm_p, norm_m)
            work[WN_GAINS], work[WN_GAINS + 1] = gain_h / abs(h), gain_s / abs(h)
        if newton:
            extra += solve(model, eps, hamiltonian, work, n, r)
        error = 0.0  # norm_inf(r), as y moves by r
        for i in range(n):
            a = abs(r[i])
            error = a if a > error or a != a else error
            y[i] -= r[i]
        resolution = EPS * (increment + abs(h) * size_f)
        theta = error / previous
        if newton and iteration == 2 and previous > 64.0 * resolution:  # a rate measured above round-off
            rate = theta
        if not np.isfinite(error) or error > 1e3 * (norm_inf(x) + increment + 1.0):
            break
        contracting = iteration > 1 and theta < 0.5 and theta / (1.0 - theta) * error <= resolution
        converged = error <= 4.0 * resolution or contracting
        floor = 64.0 * resolution + 16.0 * abs(h) * noise
        stalled = error >= 0.5 * best and (error <= floor or error <= SQRT_EPS * (norm_inf(x) + increment))
        if converged or stalled or error == 0.0:
            p = model.params
            return OK, model.H(y, p), model.S(y, p), iteration, iteration + 1 + extra, rate, UNKNOWN
        if not newton and iteration >= 2 and previous > floor:  # a rate above the noise of the quotients
            measured += 1
            if measured == 1:  # the first ratio is a transient (a non-normal Jacobian's: s of the pendula)
                reference = error
            else:
                rate = (error / reference) ** (1.0 / (measured - 1))  # the mean rate since
                if measured >= 3 and rate > give_up:
                    break
                # at that rate, round-off is more iterations away than allowed: the same failure, sooner
                far = iteration + np.log(4.0 * resolution / error) / np.log(rate) > max_iter
                if measured >= 3 and 0.0 < rate < 1.0 and far:
                    break
        best = min(best, error)
        previous = error
    return NEWTON_FAILED, H_y, S_y, iteration, iteration + extra, max(rate, previous), UNKNOWN


@inner
def _residual_n(kind, coeffs, model, eps, hamiltonian, x, H_x, S_x, h, work):
    """``R = y - x - h F(x, y)`` at the workspace's ``V_NEW`` into ``V_R``; returns ``|R|^2`` (inf where not
    finite).  The gradients uncorrected (the damped attempt's residual, no gains at hand)."""
    n = x.shape[0]
    y, F, r = vector(work, V_NEW, n), vector(work, V_F, n), vector(work, V_R, n)
    H_y, S_y = discrete_field_n(kind, coeffs, model, eps, hamiltonian, x, H_x, S_x, y, np.inf, np.inf, work, False)[:2]
    for i in range(n):
        r[i] = (y[i] - x[i]) - h * F[i]
    size = dot(r, r)
    return size if np.isfinite(size) and np.isfinite(H_y) and np.isfinite(S_y) else np.inf


@inner
def _homed_n(kind, max_iter, coeffs, model, eps, hamiltonian, x, comp, H_x, S_x, h, work):
    """The R^n step's last attempt, as the R^3 step's (``newton._homed``): damped Newton from the RK4 step
    into ``V_NEW``, each direction ``A^-1 R`` with ``A = I - h/2 D xi(xbar)`` refreshed at the midpoint of the
    iterate, ``y - lambda A^-1 R`` with ``lambda`` halved from 1 until ``|R|^2 / 2`` falls by Armijo's fraction,
    at most ``max_iter`` steps, until ``|R|`` is within sqrt(eps) of the increment.  Returns ``(found,
    evaluations, refreshes)``: ``found`` where it got there within half the RK4 increment (a root far from the
    flow is no step), the factors then those ``_iterate`` finishes with."""
    n = x.shape[0]
    y, r = vector(work, V_NEW, n), vector(work, V_R, n)
    direction, saved, reference = vector(work, V_K3, n), vector(work, V_K4, n), vector(work, V_ROWS, n)
    rk4_step_n(model, eps, hamiltonian, x, comp, h, work)
    for i in range(n):
        reference[i] = y[i] - x[i]
    size = _residual_n(kind, coeffs, model, eps, hamiltonian, x, H_x, S_x, h, work)
    evaluations, refreshes = 5, 0
    for k in range(max_iter + 1):
        if not np.isfinite(size):
            return False, evaluations, refreshes
        increment, off, reach = 0.0, 0.0, 0.0
        for i in range(n):
            increment = max(increment, abs(y[i] - x[i]))
            off = max(off, abs((y[i] - x[i]) - reference[i]))
            reach = max(reach, abs(reference[i]))
        if norm_inf(r) <= SQRT_EPS * increment:
            return off <= 0.5 * reach, evaluations, refreshes
        if k == max_iter:
            break
        for i in range(n):
            direction[i] = 0.5 * (x[i] + y[i])
        if sparse(work):  # the last attempt takes dense Jacobians: the zero pattern is given up for the run
            work[WN_SPARSE] = -1.0
        if not refresh(model, eps, hamiltonian, False, direction, h, work):
            return False, evaluations, refreshes
        evaluations += n + 1
        refreshes += 1
        copy_into(direction, r)
        solve(model, eps, hamiltonian, work, n, direction)
        copy_into(saved, y)
        damping = 1.0
        while True:
            for i in range(n):
                y[i] = saved[i] - damping * direction[i]
            trial = _residual_n(kind, coeffs, model, eps, hamiltonian, x, H_x, S_x, h, work)
            evaluations += 1
            if trial <= (1.0 - 2.0 * ARMIJO * damping) * size:
                break
            damping *= 0.5
            if damping < HOMING_MIN_DAMPING:
                return False, evaluations, refreshes
        size = trial
    return False, evaluations, refreshes


@inner
def _start(model, eps, hamiltonian, damped, x, h, work):
    """A fresh Jacobian at ``x`` and the linearly implicit start ``y = x + A^-1 h xi(x)`` (the explicit Euler step
    where A is singular); returns the field evaluations: n + 1 for a dense Jacobian, one per colour and one at x
    with the zero pattern (``sparse_n``), and the solve's."""
    n = x.shape[0]
    evaluations = refresh_evaluations(blocks_struct(work, n)) if sparse(work) else n + 1
    ok = refresh(model, eps, hamiltonian, damped, x, h, work)
    y, f0 = vector(work, V_NEW, n), vector(work, V_K1, n)
    for i in range(n):
        y[i] = h * f0[i]
    if ok:
        evaluations += solve(model, eps, hamiltonian, work, n, y)
    for i in range(n):
        y[i] += x[i]
    return evaluations


@inner
def field_cost(model, n):
    """The modelled flops of one evaluation of the discrete field (``FIELD_COST_*``)."""
    return FIELD_COST_FIXED + (FIELD_COST_ACTION * n if model.actions != 0 else FIELD_COST_MATRIX * n * n)


@inner
def newton_weight(work, model, n):
    """The cost of a Newton iteration in fixed-point iterations: ``1 + 2 n^2 / c_f``, ``c_f`` the modelled cost
    of the field (``field_cost``); with the Jacobian's zero pattern, the blocks' solve in place of ``2 n^2``."""
    if sparse(work):
        return solve_weight_blocks(blocks_struct(work, n), field_cost(model, n))
    return 1.0 + 2.0 * n * n / field_cost(model, n)


@inner
def refresh_cost(work, model, n):
    """A refresh in field evaluations: n + 1 of them and the factorisation, ``2 n^3 / 3`` flops; with the
    Jacobian's zero pattern, one per colour and the blocks' factorisation (``sparse_n.refresh_cost``)."""
    if sparse(work):
        return refresh_cost_blocks(blocks_struct(work, n), field_cost(model, n))
    return n + 1.0 + 2.0 * n * n * n / (3.0 * field_cost(model, n))


@inner
def newton_cost(work, n, model):
    """The cost of a Newton step in field evaluations: its iterations (running average, ``WN_NEWTON_ITERATIONS``)
    times ``newton_weight`` and its refreshes (``WN_REFRESHES``) times ``refresh_cost``; before any is measured,
    ``NEWTON_ITERATIONS_ASSUMED`` and ``REFRESHES_ASSUMED``."""
    measured = work[WN_NEWTON_ITERATIONS] > 0.0
    iterations = work[WN_NEWTON_ITERATIONS] if measured else NEWTON_ITERATIONS_ASSUMED
    refreshes = work[WN_REFRESHES] if measured else REFRESHES_ASSUMED
    return iterations * newton_weight(work, model, n) + refreshes * refresh_cost(work, model, n)


@inner
def choose_solver(work, n, model, max_iter):
    """``(fixed point first, its iterations allowed)`` for this step, from counts and rates only (never timings:
    a run is reproducible bit for bit).

    * A solver the workspace forces (``WN_SOLVER``), the fixed point with ``FIXED_POINT_ITERATIONS max_iter``.
    * No dense Jacobian (n > ``DENSE_MAX_N``): the fixed point, as many.
    * The fixed point where the last one cost fewer field evaluations than a Newton step (``newton_cost``;
      ``WN_MODE``), and, in Newton mode, once every ``WN_BACKOFF`` steps given a history (a probe); allowed as
      many iterations as a Newton step costs.  The first step: the fixed point for n > ``FIRST_NEWTON_N`` (a
      first Jacobian costs n field evaluations and O(n^3)), Newton otherwise.
    """
    forced = work[WN_SOLVER]
    if forced == FIXED_POINT_ONLY or n > DENSE_MAX_N:
        return True, FIXED_POINT_ITERATIONS * max_iter
    if forced == NEWTON_ONLY:
        return False, 0
    affordable = int(np.ceil(newton_cost(work, n, model)))
    if work[WN_NEWTON_ITERATIONS] == 0.0 and work[WN_FIXED_POINT_ITERATIONS] == 0.0:  # the first step
        return n > FIRST_NEWTON_N and not sparse(work), affordable
    if work[WN_MODE] > 0.0 or (work[WN_PROBE] <= 0.0 and work[WN_HISTORY] > 0.0):
        return True, affordable
    return False, 0


@inner
def after_fixed_point(work, n, model, status, iterations):
    """The mode after a fixed-point attempt: kept where it converged in no more field evaluations than a Newton
    step costs; else Newton, the fixed point tried again after twice the last interval (``PROBE_MIN`` to
    ``PROBE_MAX``)."""
    work[WN_FIXED_POINT_ITERATIONS] = iterations
    if status == OK and iterations <= newton_cost(work, n, model):
        work[WN_MODE] = 1.0
        work[WN_BACKOFF] = PROBE_MIN
        return
    work[WN_MODE] = 0.0
    work[WN_BACKOFF] = min(PROBE_MAX, max(PROBE_MIN, 2.0 * work[WN_BACKOFF]))
    work[WN_PROBE] = work[WN_BACKOFF]


@inner
def after_newton(work, iterations, refreshes, probed):
    """The running averages of a Newton step's iterations and refreshes (the first step's refresh, an investment
    of the steps after it, is not counted)."""
    if work[WN_NEWTON_ITERATIONS] == 0.0:
        work[WN_NEWTON_ITERATIONS] = iterations
        work[WN_REFRESHES] = REFRESHES_ASSUMED
    else:
        work[WN_NEWTON_ITERATIONS] += COST_WEIGHT * (iterations - work[WN_NEWTON_ITERATIONS])
        work[WN_REFRESHES] += COST_WEIGHT * (refreshes - work[WN_REFRESHES])
    if not probed:
        work[WN_PROBE] -= 1.0


@inner
def probe_pattern(model, eps, hamiltonian, damped, x, work):
    """The run's first step: whether its Newton matrix is taken from the Jacobian's zero pattern (``sparse_n``;
    ``WN_SPARSE``), probed where it may pay: n above ``SPARSE_MIN_N`` with a dense Jacobian in the workspace,
    Newton allowed, no damping (whose refresh differences two parts apart), P and M (where the field uses them)
    given as actions.  Returns the evaluations."""
    n = x.shape[0]
    work[WN_SPARSE] = -1.0
    if not (SPARSE_MIN_N < n <= DENSE_MAX_N and fits(n) and work[WN_SOLVER] != FIXED_POINT_ONLY):
        return 0
    if damped and eps != 0.0:
        return 0
    # an operator given as a matrix costs O(n^2) an evaluation, the probe then O(n^3): as a dense refresh
    if hamiltonian and not model.actions & P_ACTION:
        return 0
    if eps != 0.0 and model.metric != PAPER_METRIC and not model.actions & M_ACTION:
        return 0
    found = probe(
        model,
        eps,
        hamiltonian,
        x,
        blocks_struct(work, n),
        blocks_factors(work, n),
        vector(work, V_MID, n),
        vector(work, V_K1, n),
        vector(work, V_A, n),
        vector(work, V_B, n),
    )
    work[WN_SPARSE] = 1.0 if found else -1.0
    return n + 1


@hot
def discrete_gradient_step_n(kind, max_iter, damped, coeffs, model, eps, hamiltonian, x, comp, H_x, S_x, h, work):
    """One step of the module docstring from ``x`` to the workspace's ``V_NEW``: a ``layout.StepResult`` whose
    ``x`` is that view (the loop copies it), ``comp`` passed through (no compensated summation in R^n).

    ``H_x`` is the energy anchor (H(x0)), ``S_x`` S(x).  ``damped`` (a bool): ``DampedGonzalez``'s factor phi on
    the dissipation.  The solver is chosen by ``choose_solver``.  The fixed point starts from the extrapolated
    increment (the explicit Euler step without a history); Newton from the extrapolated increment with the kept
    factors, or, without a history, with another ``h``, or where that start fails, from a fresh Jacobian and
    the linearly implicit start.  A fixed point that does not converge hands the step to Newton where the
    workspace holds a dense Jacobian (n <= ``DENSE_MAX_N``).  Iterations of both count in ``iterations``.
    """
    n = x.shape[0]
    p = model.params
    y = vector(work, V_NEW, n)
    evaluations, iterations = 0, 0
    if work[WN_SPARSE] == 0.0:
        evaluations += probe_pattern(model, eps, hamiltonian, damped, x, work)
    history = work[WN_HISTORY] > 0.0 and work[WN_H] == h
    fixed_point, cap = choose_solver(work, n, model, max_iter)
    status, H_y, S_y, theta, culprit = NEWTON_FAILED, np.nan, np.nan, 0.0, UNKNOWN
    newton_used = False
    if fixed_point:
        if damped and eps != 0.0 and not work[WN_KAPPA_VALID] > 0.0:
            evaluations += kappa_by_differences(model, eps, x, work)
        eps_step = damped_eps(damped, eps, h, work)
        if history:
            predict(work, n, y, x)
        else:
            axpy_into(y, h, field_into(vector(work, V_K1, n), model, eps_step, hamiltonian, x), x)
            evaluations += 1
        status, H_y, S_y, it, ev, theta, culprit = _iterate(
            kind, max(cap, 2), coeffs, model, eps_step, hamiltonian, x, H_x, S_x, h, work, False, THETA_DIVERGE, False
        )
        iterations += it
        evaluations += ev
        work[WN_RATE] = theta
        if work[WN_SOLVER] == AUTO:
            after_fixed_point(work, n, model, status, it)
    if status != OK and n <= DENSE_MAX_N and work[WN_SOLVER] != FIXED_POINT_ONLY:
        newton_used = True
        kept = history and work[WN_FACTORED] > 0.0 and work[WN_LU_H] == h
        fresh = not kept or refresh_cost(work, model, n) <= FRESH_REFRESH_COST
        newton_iterations, refreshes = 0, 0
        for attempt in range(2):
            if attempt == 1 and fresh:
                break
            if fresh or attempt == 1:
                evaluations += _start(model, eps, hamiltonian, damped, x, h, work)
                refreshes += 1
                fresh = True
            else:
                predict(work, n, y, x)
            eps_step = damped_eps(damped, eps, h, work)
            status, H_y, S_y, it, ev, theta, culprit = _iterate(
                kind, max_iter, coeffs, model, eps_step, hamiltonian, x, H_x, S_x, h, work, True, np.inf, fresh
            )
            iterations += it
            newton_iterations += it
            evaluations += ev
            if status != NEWTON_FAILED:
                break
        if status == NEWTON_FAILED:  # the last attempt: damped Newton from the RK4 step
            eps_step = damped_eps(damped, eps, h, work)
            found, ev, refreshed = _homed_n(
                kind, max_iter, coeffs, model, eps_step, hamiltonian, x, comp, H_x, S_x, h, work
            )
            evaluations += ev
            refreshes += refreshed
            if found:
                status, H_y, S_y, it, ev, theta, culprit = _iterate(
                    kind, max_iter, coeffs, model, eps_step, hamiltonian, x, H_x, S_x, h, work, True, np.inf, False
                )
                iterations += it
                newton_iterations += it
                evaluations += ev
        if work[WN_SOLVER] == AUTO:
            after_newton(work, newton_iterations, refreshes, fixed_point)
    if status != OK:
        work[WN_HISTORY] = 0.0
        return StepResult(y, comp, H_y, S_y, status, iterations, evaluations, theta, culprit)
    # exact under a stopped solve: back onto H = H_x, and S not against its direction
    d, before = vector(work, V_R, n), vector(work, V_C, n)
    terms_h = term_scale_n(H_x, H_y, model.grad_H(y, p), y, model.origin[0])
    H_y, ev = to_level(model, y, H_y, H_x, True, d, before, EPS * terms_h)
    evaluations += ev
    against = -model.direction * np.sign(h)  # > 0: S moved against its direction
    current = False  # S_y and terms_s taken at y as it is
    for _ in range(CORRECTION_ROUNDS):
        S_y = model.S(y, p)
        terms_s = term_scale_n(S_x, S_y, model.grad_S(y, p), y, model.origin[1])
        current = True
        if eps == 0.0 and hamiltonian:  # no dissipation: S is a Casimir, kept like H
            if abs(S_y - S_x) <= EPS * terms_s:
                break
        elif not against * (S_y - S_x) > 0.5 * EPS * terms_s:
            break
        S_y, ev = to_level(model, y, S_y, S_x, False, d, before, 0.5 * EPS * terms_s)
        H_y, ev2 = to_level(model, y, model.H(y, p), H_x, True, d, before, EPS * terms_h)
        evaluations += ev + ev2 + 1
        current = False
    if not current:
        S_y = model.S(y, p)
        terms_s = term_scale_n(S_x, S_y, model.grad_S(y, p), y, model.origin[1])
    # a dissipative step must not move S against its direction beyond ACCEPT_S_ULPS; one without dissipation
    # keeps the Casimir S as it keeps H, to ACCEPT_ULPS either way (as the R^3 step)
    conserve_s = eps == 0.0 and hamiltonian
    s_off, s_ulps = (abs(S_y - S_x), ACCEPT_ULPS) if conserve_s else (against * (S_y - S_x), ACCEPT_S_ULPS)
    if not (abs(H_y - H_x) <= ACCEPT_ULPS * EPS * terms_h and s_off <= s_ulps * EPS * terms_s):
        increment = 0.0
        for i in range(n):
            increment = max(increment, abs(y[i] - x[i]))
        if not increment <= REST * norm_inf(x):
            work[WN_HISTORY] = 0.0
            return StepResult(y, comp, H_y, S_y, NOT_ACCEPTED, iterations, evaluations, theta, UNKNOWN)
        # at rest: near an equilibrium grad H and grad S are parallel, the level sets of H and S touch, and no
        # state within round-off of the root keeps H with S not rising; x itself does (it was accepted)
        copy_into(y, x)
        H_y, S_y = model.H(y, p), S_x
    remember_n(work, n, y, x, h)
    if newton_used and theta > THETA_REFRESH:
        work[WN_FACTORED] = 0.0  # the factors have gone stale: fresh ones next step
    return StepResult(y, comp, H_y, S_y, OK, iterations, evaluations, theta, UNKNOWN)


@hot
def rk4_step_n(model, eps, hamiltonian, x, comp, h, work):
    """The classical Runge-Kutta step (order 4) into the workspace's ``V_NEW``; H and S are not evaluated."""
    n = x.shape[0]
    k1, k2, k3, k4 = vector(work, V_K1, n), vector(work, V_K2, n), vector(work, V_K3, n), vector(work, V_K4, n)
    stage, y = vector(work, V_A, n), vector(work, V_NEW, n)
    field_into(k1, model, eps, hamiltonian, x)
    field_into(k2, model, eps, hamiltonian, axpy_into(stage, 0.5 * h, k1, x))
    field_into(k3, model, eps, hamiltonian, axpy_into(stage, 0.5 * h, k2, x))
    field_into(k4, model, eps, hamiltonian, axpy_into(stage, h, k3, x))
    for i in range(n):
        y[i] = x[i] + (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return StepResult(y, comp, np.nan, np.nan, OK, 0, 4, 0.0, UNKNOWN)
