"""The metriplectic discrete-gradient step, and its damping.

``discrete_gradient_step`` solves ``x' = x + h F(x, x')`` (``discrete_field``)
to round-off (``newton``); ``H`` and ``S`` in its ``layout.StepResult`` are the
invariants at the new state, which the step evaluates to check them.
``damped_eps`` scales the dissipation by ``damping_factor`` for
``DampedGonzalez``.  A forward dissipative step whose root raised S beyond
round-off (at rest where grad S || grad H, the anchor's pull on H raises S with
it) gives that back along grad S (``projection.lower_S``).
"""

import numpy as np
from numba import types

from .field import field
from .jit import hot, inner, typed_inline
from .layout import (
    ACCEPT_ULPS,
    EPS,
    NEWTON_FAILED,
    OK,
    UNKNOWN,
    W_H,
    W_HISTORY,
    W_JACOBIAN_VALID,
    Damped,
    StepResult,
    Undamped,
)
from .newton import THETA_REFRESH, attempts, jacobian, newton, newton_matrix, predictor, remember
from .projection import S_CAP_ULPS, lower_S
from .roundoff import origin_terms, term_scale
from .vec3 import ZERO, as_vector, load, same, sub


def damped_eps(damped, model, eps, buf, x, h):
    """``(eps', field evaluations)``: ``eps`` times ``damping_factor`` where ``damped``, else ``eps``.

    ``damped`` is a ``layout.Damped``/``Undamped`` marker (a standalone step,
    or a stage of a program without damped stages: ``composition.stage_damped``),
    whose type decides when the step is compiled, so an undamped run does not
    compile the damping factor; or a flag read at run time (a stage of a program
    with damped stages).
    """
    on = damped.on if isinstance(damped, (Damped, Undamped)) else bool(damped)
    return (eps * damping_factor(model, eps, buf, x, h), 4) if on else (eps, 0)


@typed_inline(damped_eps)
def _damped_eps_typed(damped, model, eps, buf, x, h):
    marker = getattr(damped, "instance_class", None) if isinstance(damped, types.BaseNamedTuple) else None
    if marker is Undamped:
        return lambda damped, model, eps, buf, x, h: (eps, 0)
    if marker is Damped:
        return lambda damped, model, eps, buf, x, h: (eps * damping_factor(model, eps, buf, x, h), 4)
    return lambda damped, model, eps, buf, x, h: (
        (eps * damping_factor(model, eps, buf, x, h), 4) if damped else (eps, 0)
    )


@inner
def damping_factor(model, eps, buf, x, h):
    """``phi = 1 / sqrt(1 + (h kappa / 2)^2)``, ``kappa = |D (eps xi_g)(x)|_inf`` (4 gradient calls).

    ``eps xi_g`` is differentiated as a whole, so that ``eps`` scales the
    product before it can underflow (states of size 1e-150 with eps ~ 1e150).

    Multiplying the dissipation by ``phi`` (still exact in H, monotone in S)
    makes the midpoint-type step damp a dissipative mode of rate ``lambda ~ kappa``
    by ``(1 - w) / (1 + w)``, ``w = (h lambda / 2) phi -> 1`` as ``h kappa -> oo``,
    instead of reflecting it; ``phi = 1 + O(h^2)`` keeps order 2.
    """
    g0 = field(model, eps, False, buf, x)
    c0, c1, c2 = jacobian(model, eps, False, buf, x, g0)
    row_sum = max(
        abs(c0[0]) + abs(c1[0]) + abs(c2[0]), abs(c0[1]) + abs(c1[1]) + abs(c2[1]), abs(c0[2]) + abs(c1[2]) + abs(c2[2])
    )
    z = 0.5 * h * row_sum
    if not np.isfinite(z):
        return 1.0
    return 1.0 / np.sqrt(1.0 + z * z)


@hot
def discrete_gradient_step(
    kind, max_iter, damped, compensated, coeffs, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, work
):
    """One metriplectic discrete-gradient step ``x' = x + h F(x, x')`` (``discrete_field``), solved to round-off.

    ``H_x`` is the energy the step keeps: the loop passes H(x0), not H(x_n),
    so that the discrete-gradient identity ``dgH . dx = H(x') - H_x`` pulls
    every step back onto the initial level set and the rounding of the states
    does not random-walk the energy.  ``S_x`` is S(x_n).  With ``damped`` (``damped_eps``) the
    dissipation is scaled by ``damping_factor`` (stiff problems: the
    midpoint-type step then damps the fast mode instead of reflecting it).

    Simplified Newton (``newton``): the matrix ``I - h/2 D xi`` is built from a
    Jacobian kept in the slot's workspace ``work`` (``layout.W_*``) across steps
    and refreshed when the iteration contracts slowly (``THETA_REFRESH``), and
    the start is the increment extrapolated from the slot's last three
    (error O(h^4)).  Without a history (first step, a new ``h``) the Jacobian
    is taken at ``x`` and the start is the linearly implicit midpoint predictor
    ``(I - h/2 D xi)^-1 h xi(x)``.  A failed attempt is retried that way; then
    from the explicit RK4 increment (O(h^5) from the flow, so O(h^3) from the
    root: it converges where a step near the time scale defeats the linear
    predictor, as a composition's long backward sub-step can); if that fails
    too, once more with the step anchored to H(x_n) instead of H(x0).  Why: near an equilibrium a step moves by
    ``|dx| << |x|``, and
    removing an energy offset of a few ulps (``|H(x_n) - H(x0)|``) would need a
    discrete-gradient correction ~ ulp / |dx| that is noise; the un-anchored
    step keeps ``H(x') = H(x_n)`` to round-off, and later steps, anchored
    again, take the offset back once they move.
    """
    if not compensated:
        comp = ZERO
    eps, evaluations = damped_eps(damped, model, eps, buf, x, h)
    fresh = not (work[W_HISTORY] > 0.0 and work[W_H] == h and work[W_JACOBIAN_VALID] > 0.0)
    attempt = 0
    status, iterations = NEWTON_FAILED, 0
    if not fresh:  # the usual step: the extrapolated start with the slot's Newton matrix
        status, x_new, comp_new, H_new, S_new, iterations, ev, rate, culprit = newton(
            kind,
            max_iter,
            coeffs,
            model,
            eps,
            hamiltonian,
            buf,
            x,
            comp,
            H_x,
            S_x,
            h,
            predictor(work),
            newton_matrix(work, h),
        )
        evaluations += ev
    if fresh or status == NEWTON_FAILED:
        status, x_new, comp_new, H_new, S_new, it, ev, rate, culprit, attempt = attempts(
            kind, max_iter, coeffs, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, work, 0 if fresh else 1
        )
        iterations += it
        evaluations += ev
        fresh = True
    if status != OK:
        work[W_HISTORY] = 0.0
        return StepResult(x_new, comp_new, H_new, S_new, status, iterations, evaluations, rate, culprit)
    if h > 0.0 and eps > 0.0 and S_new - S_x > S_CAP_ULPS * EPS * max(abs(S_x), abs(S_new)):
        # S rose beyond the ulps of its value (the root is accepted within 2 ulps of its terms): at a state at rest
        # where grad S || grad H, the anchor's pull of H(x_n) back onto H(x0) raises S with H; give back the part
        # beyond round-off (``projection.lower_S``), H staying within the root's own allowance of the anchor
        load(buf, x_new)
        grad_h = as_vector(model.grad_H(buf, model.params))
        allowed = ACCEPT_ULPS * EPS * term_scale(H_x, H_new, grad_h, x_new, origin_terms(model.origin, 0, x_new))
        x_low, H_new, S_new, ev = lower_S(model, buf, x_new, H_new, S_new, S_x, H_x, allowed)
        evaluations += ev + 1
        if not same(x_low, x_new):  # the moved state is the state: its carry restarts, as after a projection
            x_new, comp_new = x_low, ZERO
    remember(work, sub(x_new, x), h)
    if rate > THETA_REFRESH and not fresh:
        work[W_JACOBIAN_VALID] = 0.0  # the Jacobian has gone stale: a fresh one next step
    if not compensated:
        comp_new = ZERO
    return StepResult(x_new, comp_new, H_new, S_new, OK, iterations, evaluations, float(attempt), UNKNOWN)
