"""The Newton solve of an implicit step to round-off: predictor, Jacobian workspace, acceptance rule.

``newton`` solves ``x' = x + h F(x, x')`` (``discrete_field``) by simplified
Newton with the matrix ``I - h/2 D xi``, built from a Jacobian kept in the
slot's workspace (``layout.W_*``) across steps; ``predictor`` extrapolates the
start from the slot's last three increments, ``attempts`` the starts a step
tries without one (``dg_step.discrete_gradient_step`` says when).  A root is
accepted only when it keeps H and S to ``GUARD`` ulps of their terms
(``roundoff.kept``).
"""

import numpy as np

from .discrete_field import discrete_field
from .field import field, non_finite_culprit
from .jit import hot, inner
from .layout import (
    ACCEPT_S_ULPS,
    ACCEPT_ULPS,
    EPS,
    NEWTON_FAILED,
    NON_FINITE,
    OK,
    SQRT_EPS,
    UNKNOWN,
    W_DX1,
    W_DX2,
    W_DX3,
    W_H,
    W_HISTORY,
    W_JACOBIAN,
    W_JACOBIAN_VALID,
)
from .roundoff import kept, origin_terms, term_scale
from .runge_kutta import rk4_increment
from .vec3 import abs_dot, add, advance, as_vector, axpy, dot, is_finite, load, norm_inf, same, scale, solve, sub

#: a root found to round-off must keep H and S to this many ulps of their terms; a far-away
#: spurious root (a step far beyond the time scale) does not
GUARD = 1024.0


#: a first contraction rate above this makes the slot take a fresh Jacobian at its next step
THETA_REFRESH = 1e-2


@inner
def jacobian(model, eps, hamiltonian, buf, x, f0):
    """Columns of ``D xi(x)`` by forward differences (3 field calls); ``f0 = xi(x)``."""
    size = norm_inf(x)
    delta = SQRT_EPS * (size if size > 0.0 else 1.0)
    c0 = scale(1.0 / delta, sub(field(model, eps, hamiltonian, buf, (x[0] + delta, x[1], x[2])), f0))
    c1 = scale(1.0 / delta, sub(field(model, eps, hamiltonian, buf, (x[0], x[1] + delta, x[2])), f0))
    c2 = scale(1.0 / delta, sub(field(model, eps, hamiltonian, buf, (x[0], x[1], x[2] + delta)), f0))
    return c0, c1, c2


@inner
def store_jacobian(work, c0, c1, c2):
    for k in range(3):
        work[W_JACOBIAN + k] = c0[k]
        work[W_JACOBIAN + 3 + k] = c1[k]
        work[W_JACOBIAN + 6 + k] = c2[k]
    work[W_JACOBIAN_VALID] = 1.0


@inner
def newton_matrix(work, h):
    """Rows of ``I - h/2 D xi`` from the slot's stored Jacobian (columns)."""
    a = -0.5 * h
    j = W_JACOBIAN
    return (
        (1.0 + a * work[j], a * work[j + 3], a * work[j + 6]),
        (a * work[j + 1], 1.0 + a * work[j + 4], a * work[j + 7]),
        (a * work[j + 2], a * work[j + 5], 1.0 + a * work[j + 8]),
    )


@inner
def _residual(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, x_new, scales):
    F = discrete_field(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, x_new, h, scales)[0]
    return sub(sub(x_new, x), scale(h, F))


@inner
def _residual_column(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, shifted, scales, r0, delta):
    """One column of the residual's Jacobian: ``(R(shifted) - R(x_new)) / delta``, ``r0 = R(x_new)``."""
    r = _residual(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, shifted, scales)
    return scale(1.0 / delta, sub(r, r0))


@inner
def _residual_matrix(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, x_new, scales):
    """Rows of the Jacobian of ``R(x') = x' - x - h F(x, x')`` at ``x_new`` (4 discrete-field calls)."""
    r0 = _residual(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, x_new, scales)
    size = norm_inf(x_new)
    d = SQRT_EPS * (size if size > 0.0 else 1.0)
    a, b, c = x_new
    at = (kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h)
    c0 = _residual_column(*at, (a + d, b, c), scales, r0, d)
    c1 = _residual_column(*at, (a, b + d, c), scales, r0, d)
    c2 = _residual_column(*at, (a, b, c + d), scales, r0, d)
    return ((c0[0], c1[0], c2[0]), (c0[1], c1[1], c2[1]), (c0[2], c1[2], c2[2]))


@inner
def _kept_at(model, buf, y, dy, H_x, S_x, H_y, S_y, terms_h, terms_s, s_ulps, s_direction):
    """Whether the corrected iterate ``y = x + dy`` keeps H and S as an accepted root must, and the evaluations
    spent (0 or 1).

    ``terms_h``, ``terms_s`` are the terms of H and S measured at the *uncorrected* iterate, from its discrete
    gradients; they are also measured at ``y`` (its gradients, the same two parts as in ``newton``) and the
    smaller of the two is the round-off allowed.  Where one component of the state is far below the others the
    two differ by orders of magnitude: on the degenerate example's tail (z ~ 1e-55, x ~ 1) an iterate with
    z ~ 1e-47 made the terms of S 1e9 times S itself, and a corrected root at which S had risen by 25 % was
    accepted.  The values alone decide first (the terms are at least the values), so the gradients at ``y``
    are evaluated only where a change exceeds the ulps of the values themselves.
    """
    if not (np.isfinite(H_y) and np.isfinite(S_y)):
        return False, 0
    if kept(H_x, H_y, max(abs(H_x), abs(H_y)), ACCEPT_ULPS, 0.0) and kept(
        S_x, S_y, max(abs(S_x), abs(S_y)), s_ulps, s_direction
    ):
        return True, 0
    if not (kept(H_x, H_y, terms_h, ACCEPT_ULPS, 0.0) and kept(S_x, S_y, terms_s, s_ulps, s_direction)):
        return False, 0
    load(buf, y)
    grad_h = as_vector(model.grad_H(buf, model.params))
    grad_s = as_vector(model.grad_S(buf, model.params))
    at_h = term_scale(H_x, H_y, grad_h, y, origin_terms(model.origin, 0, y)) + abs_dot(grad_h, dy)
    at_s = term_scale(S_x, S_y, grad_s, y, origin_terms(model.origin, 4, y)) + abs_dot(grad_s, dy)
    return kept(H_x, H_y, at_h, ACCEPT_ULPS, 0.0) and kept(S_x, S_y, at_s, s_ulps, s_direction), 1


@hot
def newton(kind, max_iter, coeffs, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, dx, m):
    """Solve ``x' = x + h F(x, x')`` from the increment ``dx`` with the Newton matrix ``m``.

    Returns ``(status, x', comp', H(x'), S(x'), iterations, evaluations, r, culprit)`` with ``r`` the
    first measured contraction rate on success (1 if none was measured) and the last correction on failure.

    Every iterate is formed as the state it would be, ``x' = x + dx`` by
    compensated summation, and the discrete field evaluates H and S there; an
    iterate is accepted only if it *is* exact: H within ``ACCEPT_ULPS`` of its
    terms of the anchor ``H_x``, S not above ``S_x`` by more than
    ``ACCEPT_S_ULPS`` (not below it for ``h < 0``, the backward sub-steps of a
    composition; within ``ACCEPT_ULPS`` either way where eps = 0, a Hamiltonian
    sub-step, which keeps the Casimir S as it keeps H).  It is accepted when

    * **converged**: the correction is within 4 ulp of the increment (of
      ``|dx|`` and of the terms of ``h F``: not of ``|x|``, so that a state
      resting near an equilibrium, where ``|dx| << |x|``, does not random-walk
      by the solution error), or
    * **contracting**: with the contraction rate ``theta`` measured from two
      corrections, ``theta / (1 - theta) |correction|`` bounds the distance from
      the corrected iterate to the root (Hairer & Wanner, *Solving ODEs II*,
      section IV.8) and is within an ulp of the increment;

      then the correction is applied (never the start as it is: an
      extrapolated start's error, below the threshold but of one sign, would
      add up) and the corrected iterate is accepted if exact (2 function
      values instead of a further discrete field; none where it rounds to
      the same state, the correction then living in the compensation),
      judged against the terms of H and S at it as well (``_kept_at``).  A converged root far from
      keeping H and S (``GUARD`` ulps, beyond what the remaining correction
      moves them: a component of dx far smaller than |dx| is resolved only
      as the iteration goes on) is a spurious root, reached from a step far
      beyond the time scale: the attempt fails.
    * **at the floor**: a correction that no longer shrinks (half the best so
      far), is below 16 times the round-off floor (4 ulp of the increment plus
      ``|h|`` times the noise of the discrete-gradient quotients) or sqrt(eps)
      of the state: the iterate is accepted if exact.
      Whenever the iteration stalls without that, the Newton matrix becomes the
      finite-difference Jacobian of the discrete residual at the iterate (Newton's
      method proper: the hard cases, far from the simplified matrix).

    Fails on divergence, on a spurious root, at a fixed point (zero correction)
    that is not exact, after ``max_iter`` iterations; a
    non-finite value is reported as such, naming the user function that gave it.
    """
    direction = np.sign(h)
    # a step without dissipation (eps = 0: the Hamiltonian sub-step of a splitting) keeps the Casimir S
    # as it keeps H, to ACCEPT_ULPS either way; a dissipative one must not raise it beyond ACCEPT_S_ULPS
    s_ulps, s_direction = (ACCEPT_S_ULPS, direction) if eps > 0.0 else (ACCEPT_ULPS, 0.0)
    reach = norm_inf(x) + 4.0 * norm_inf(dx)
    x_new, comp_new = advance(x, comp, dx)
    evaluations = 0
    best = np.inf
    previous = np.inf
    error = 0.0
    first_theta = 0.0
    scales = (0.0, 0.0, 0.0)
    for iteration in range(1, max_iter + 1):
        F, H_new, S_new, dg_h, dg_s, axial, noise = discrete_field(
            kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, x_new, h, scales
        )
        evaluations += 1
        scales = (norm_inf(axial), norm_inf(dg_h), norm_inf(dg_s))
        if not (is_finite(F) and np.isfinite(H_new) and np.isfinite(S_new)):
            culprit = non_finite_culprit(model, buf, x_new, hamiltonian)
            if culprit == 0:
                culprit = non_finite_culprit(model, buf, axpy(0.5, sub(x_new, x), x), hamiltonian)
            return NON_FINITE, x_new, comp_new, H_new, S_new, iteration, evaluations, np.inf, culprit
        correction = solve(m, sub(dx, scale(h, F)))
        error = norm_inf(correction)
        size = max(norm_inf(x_new), norm_inf(dx))
        # the terms of F and of the identity dgF . dx = F(x') - F(x) (the increment rounds at the size of the
        # terms of h F, and carries that into F through dgF: at (1, 0, 0) on the Lorenz-Nevir system the
        # terms of H are ~1e-5 while |dgH . dx| terms are ~1e-2)
        terms_h = term_scale(H_x, H_new, dg_h, x_new, origin_terms(model.origin, 0, x_new)) + abs_dot(dg_h, dx)
        terms_s = term_scale(S_x, S_new, dg_s, x_new, origin_terms(model.origin, 4, x_new)) + abs_dot(dg_s, dx)
        # the round-off of the increment itself: of |dx| and of h F (terms |dgH| (|Jbar| + eps |dgH| |dgS|))
        resolution = EPS * (norm_inf(dx) + abs(h) * scales[1] * (scales[0] + eps * scales[1] * scales[2]))
        converged = error <= 4.0 * resolution
        exact = kept(H_x, H_new, terms_h, ACCEPT_ULPS, 0.0) and kept(S_x, S_new, terms_s, s_ulps, s_direction)
        # a spurious root: the invariants the scheme guarantees are far off, by more than the remaining
        # correction explains (a component of dx much smaller than |dx| is still being resolved)
        if converged and not (
            kept(H_x, H_new, terms_h + 8.0 * abs_dot(dg_h, correction) / (GUARD * EPS), GUARD, 0.0)
            and kept(S_x, S_new, terms_s + 8.0 * abs_dot(dg_s, correction) / (GUARD * EPS), GUARD, s_direction)
        ):
            break
        theta = error / previous
        if iteration == 2:
            first_theta = theta
        if converged or (theta < 0.5 and theta / (1.0 - theta) * error <= resolution):
            dx_next = sub(dx, correction)
            x_next, comp_next = advance(x, comp, dx_next)
            if same(x_next, x_new):  # a correction below the state's ulps (a state at rest): H, S just evaluated
                H_next, S_next = H_new, S_new
                exact_next = exact
            else:
                load(buf, x_next)
                H_next, S_next = model.H(buf, model.params), model.S(buf, model.params)
                exact_next, more = _kept_at(
                    model, buf, x_next, dx_next, H_x, S_x, H_next, S_next, terms_h, terms_s, s_ulps, s_direction
                )
                evaluations += 1 + more
            if exact_next:
                return OK, x_next, comp_next, H_next, S_next, iteration, evaluations, max(theta, first_theta), UNKNOWN
        stalled = converged or error >= 0.5 * best
        floor = 4.0 * resolution + 2.0 * abs(h) * noise
        if stalled and exact and (error <= 16.0 * floor or error <= SQRT_EPS * size):
            return OK, x_new, comp_new, H_new, S_new, iteration, evaluations, first_theta, UNKNOWN
        if not (error <= 1e3 * reach) or error == 0.0:
            break  # diverged, or a fixed point that is not exact: no iteration moves it
        if stalled:  # Newton's method proper from here: the Jacobian of the discrete residual at the iterate
            m = _residual_matrix(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, x_new, scales)
            evaluations += 4
        best = min(best, error)
        previous = error
        dx = sub(dx, correction)
        x_new, comp_new = advance(x, comp, dx)
    return NEWTON_FAILED, x_new, comp_new, H_x, S_x, iteration, evaluations, error, UNKNOWN


@inner
def predictor(work):
    """The increment extrapolated from the slot's last (up to) three of the same ``h``:
    ``dx_1``, ``2 dx_1 - dx_2`` or ``3 dx_1 - 3 dx_2 + dx_3``, error O(h^2), O(h^3), O(h^4)."""
    d1 = (work[W_DX1], work[W_DX1 + 1], work[W_DX1 + 2])
    if work[W_HISTORY] < 2.0:
        return d1
    d2 = (work[W_DX2], work[W_DX2 + 1], work[W_DX2 + 2])
    if work[W_HISTORY] < 3.0:
        return sub(scale(2.0, d1), d2)
    d3 = (work[W_DX3], work[W_DX3 + 1], work[W_DX3 + 2])
    return add(scale(3.0, sub(d1, d2)), d3)


@inner
def remember(work, dx, h):
    same = work[W_H] == h and work[W_HISTORY] > 0.0
    for k in range(3):
        work[W_DX3 + k] = work[W_DX2 + k]
        work[W_DX2 + k] = work[W_DX1 + k]
        work[W_DX1 + k] = dx[k]
    work[W_HISTORY] = min(3.0, work[W_HISTORY] + 1.0) if same else 1.0
    work[W_H] = h


@inner
def seed_predictor(work, dx, h):
    """Make the slot's next attempt with step ``h`` start from the increment ``dx`` (an adaptive run seeds
    the explicit RK4 increment its error estimate computes: O(h^3) from the root).  Used only while
    the slot holds a Jacobian; otherwise the step takes a fresh one and its own start."""
    for k in range(3):
        work[W_DX1 + k] = dx[k]
    work[W_HISTORY] = 1.0
    work[W_H] = h


#: the smallest damping factor of a step's last attempt (``_homed``)
HOMING_MIN_DAMPING = 2.0**-12

#: Armijo's sufficient decrease of ``|R|^2 / 2`` along the Newton direction (Nocedal & Wright, section 3.1)
ARMIJO = 1e-4


@inner
def _homed(kind, max_iter, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h):
    """A start near the root of the discrete residual ``R(x') = x' - x - h F(x, x')`` where Newton's full steps
    diverge from every other start: a step long against the field's nonlinearity (docs/hard_cases.md, "Long
    forward steps").

    Damped Newton from the explicit RK4 increment, at most ``max_iter`` steps: each takes the Newton direction
    ``d = R'(y)^-1 R(y)`` and ``y - lambda d`` with ``lambda`` halved from 1 until ``|R|^2 / 2`` falls by
    ``ARMIJO lambda |R|^2`` (Deuflhard, *Newton Methods for Nonlinear Problems*, 2004, section 3.1; Nocedal &
    Wright, *Numerical Optimization*, 2006, section 3.1), until ``|R|`` is within sqrt(eps) of the increment.
    ``newton`` then finishes from it under the acceptance rule of every attempt.  Returns ``(found, dx,
    evaluations)``, ``found`` only where the damped steps got there and within half the RK4 increment: a root
    far from the flow is no step (a composition's backward sub-step in its documented band).
    """
    reference = rk4_increment(model, eps, hamiltonian, buf, x, h)
    evaluations = 5
    scales = (0.0, 0.0, 0.0)
    y = add(x, reference)
    r = _residual(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, y, scales)
    size = dot(r, r)
    for k in range(max_iter + 1):
        if not np.isfinite(size):
            return False, reference, evaluations
        if norm_inf(r) <= SQRT_EPS * norm_inf(sub(y, x)):
            dx = sub(y, x)
            return norm_inf(sub(dx, reference)) <= 0.5 * norm_inf(reference), dx, evaluations
        if k == max_iter:
            break
        m = _residual_matrix(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, y, scales)
        d = solve(m, r)
        evaluations += 4
        damping = 1.0
        while True:
            y_try = sub(y, scale(damping, d))
            r_try = _residual(kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, y_try, scales)
            evaluations += 1
            size_try = dot(r_try, r_try)
            if size_try <= (1.0 - 2.0 * ARMIJO * damping) * size:
                break
            damping *= 0.5
            if damping < HOMING_MIN_DAMPING:
                return False, reference, evaluations
        y, r, size = y_try, r_try, size_try
    return False, reference, evaluations


@inner
def attempts(kind, max_iter, coeffs, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, work, first):
    """The starts a step tries when it has no extrapolated one, or when that failed (``first = 1``), in turn:
    a fresh Jacobian and the linearly implicit start; the explicit RK4 increment; a fresh Jacobian with the
    step anchored to H(x_n) (and S(x_n)); damped Newton's iterate (``_homed``) with the residual's Jacobian
    there, anchored as the first three.  Returns ``newton``'s tuple and the attempt that ended it."""
    iterations = 0
    evaluations = 0
    target, S_target = H_x, S_x
    for attempt in range(first, 5):
        if attempt == 1 and first == 0:
            continue  # attempt 0 already started from a fresh Jacobian
        if attempt == 4:
            found, dx, ev = _homed(kind, max_iter, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h)
            evaluations += ev
            if not found:
                break
            target, S_target = H_x, S_x
            m = _residual_matrix(
                kind, coeffs, model, eps, hamiltonian, buf, x, H_x, S_x, h, add(x, dx), (0.0, 0.0, 0.0)
            )
            evaluations += 4
        elif attempt == 2:
            dx = rk4_increment(model, eps, hamiltonian, buf, x, h)
            evaluations += 4
        else:
            f0 = field(model, eps, hamiltonian, buf, x)
            c0, c1, c2 = jacobian(model, eps, hamiltonian, buf, x, f0)
            store_jacobian(work, c0, c1, c2)
            evaluations += 4
            dx = _start(work, h, f0)
            if attempt == 3:  # S too: at eps = 0 the step was given S(x0) (``loop.run``), else this is S_x itself
                load(buf, x)
                target, S_target = model.H(buf, model.params), model.S(buf, model.params)
        if attempt != 4:
            m = newton_matrix(work, h)
        status, x_new, comp_new, H_new, S_new, it, ev, rate, culprit = newton(
            kind, max_iter, coeffs, model, eps, hamiltonian, buf, x, comp, target, S_target, h, dx, m
        )
        iterations += it
        evaluations += ev
        if status != NEWTON_FAILED:
            break
    return status, x_new, comp_new, H_new, S_new, iterations, evaluations, rate, culprit, attempt


@inner
def _start(work, h, f0):
    """The linearly implicit midpoint increment ``(I - h/2 D xi)^-1 h xi(x)`` (explicit Euler where
    that matrix is nearly singular)."""
    euler = scale(h, f0)
    dx = solve(newton_matrix(work, h), euler)
    if not (norm_inf(dx) <= 4.0 * norm_inf(euler)):
        return euler
    return dx
