"""The one engine for splittings, compositions, projection and the monotone safeguard.

A method of type ``layout.ComposedStep`` is a flat program (numba has no
recursion, so nesting is unrolled into fixed levels):

    full step   = anchor or projection( safeguard( composition ) )
    composition = base(gamma_1 h) ... base(gamma_G h)
    base        = stage_1(f_1 h) ... stage_N(f_N h)      (a splitting, or one stage)
    stage       = one leaf method with its own data on one flow: FULL (xi_P + eps xi_g),
                  HAMILTONIAN (xi_P) or GRADIENT (eps xi_g)

Layout (built by ``geomint.integrators.program.Program.lower``): ``iopts`` is a
header (``layout.P_*``) and one row per stage (``layout.R_*``: leaf, flow,
discrete-gradient kind and options, where the leaf's coefficients start and how
many), the safeguard's fallback leaf last; ``coeffs`` holds gamma_1..gamma_G,
f_1..f_N, then every leaf's coefficients (AVF's nodes, a rigid body's moments).
Each sub-step position ``(g, s)`` has its own slot of the workspace
(``layout.WORK`` floats), so every implicit sub-step keeps its own Newton
Jacobian and extrapolates from its own history.

What compiles.  The rows are read at run time, so one compiled engine runs
every program with the same ``ComposedStep.uses``: the markers of the leaves
the program can run.  ``leaf_step`` is compiled with only those leaves, a
program whose discrete-gradient stages share one kind compiles that discrete
gradient alone (``stage_kind``), and one without damped stages does not
compile the damping factor (``stage_damped``).  Each distinct set of markers
is a type of its own, so it compiles (and caches) a step loop of its own
(docs/design.md section 5).

Energy.  The discrete-gradient sub-steps are anchored to the evaluated H of
their own sub-state: a sub-step anchored to H(x0) would have to remove the few
ulps an exact-flow stage leaves, which a tiny gradient step near an
equilibrium cannot do (its field is orthogonal to dgH).  What a sub-step leaves
is below 2 ulp of the terms of H, but it has a consistent sign along a
trajectory (the midpoint defect the switching rule skips), so over many steps
it would drift linearly.  ``P_ANCHOR`` (set for energy-exact programs without a
projection) pulls the full step back onto ``H = H(x0)``: when H has strayed by
more than 2 ulp of its terms, a projection along grad H (a move of a few ulps)
restores it, keeping S at most where the full step started, to an ulp of its
terms (moving along grad S too where grad H alone would raise it beyond
that); where no such point is near (at rest where grad S || grad H, H and S
locked) it restores H as far as that allows (``projection.lower_S``), and is
skipped where that finds no point.
Compensated summation (``vec3.advance``) runs through every sub-step; a
projection restarts it (the projected state is the state).

Caller: ``step.step`` (and ``control.Counting``'s attempts, which count S rises).
"""

import numpy as np

from .dg_step import discrete_gradient_step
from .exact_flows import rigid_body_flow, rotation, rotor_splitting
from .jit import hot, inner, typed_inline
from .layout import (
    EPS,
    GRADIENT,
    HAMILTONIAN,
    HEADER,
    KIND_MARKERS,
    LEAF_DISCRETE_GRADIENT,
    LEAF_RIGID_BODY_FLOW,
    LEAF_RK4,
    LEAF_ROTATION,
    LEAF_ROTOR_SPLITTING,
    NEWTON_FAILED,
    NO_PROJECTION,
    NON_FINITE,
    OK,
    P_ANCHOR,
    P_GAMMAS,
    P_MAX_ITER,
    P_MONOTONE,
    P_PROJECTION,
    P_STAGES,
    PROJECTION_FAILED,
    R_COEFF_AT,
    R_COEFF_COUNT,
    R_COMPENSATED,
    R_DAMPED,
    R_FLOW,
    R_KIND,
    R_LEAF,
    R_MAX_ITER,
    ROW,
    SQRT_EPS,
    SYMMETRIC,
    UNKNOWN,
    WORK,
    Damped,
    RigidBodyFlowLeaf,
    RK4Leaf,
    RotationLeaf,
    RotorSplittingLeaf,
    StepResult,
    Undamped,
)
from .projection import S_CAP_ULPS, lower_S, project_both, project_energy, project_step
from .roundoff import kept, origin_terms, term_scale
from .runge_kutta import rk4_step
from .vec3 import ZERO, add, advance, as_vector, axpy, dot, is_finite, load, norm_inf, sub

#: a composed step off H(x0) by more than this many ulps of the terms of H is pulled back
ANCHOR_ULPS = 2.0


@inner
def _invariants(model, buf, x):
    load(buf, x)
    return model.H(buf, model.params), model.S(buf, model.params)


def _leaf_step_for(present):
    """The leaf dispatch for a program whose ``uses`` markers have the classes ``present``: a leaf that is
    not present is pruned from it before numba types it, so it is never compiled."""
    rk4 = RK4Leaf in present
    implicit = any(kind in present for kind in KIND_MARKERS.values())
    rigid_body, rotor, rotating = RigidBodyFlowLeaf in present, RotorSplittingLeaf in present, RotationLeaf in present

    def leaf_step(uses, coeffs, iopts, row, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, work):
        """One step of the leaf in program row ``row`` on its flow (a ``StepResult``)."""
        leaf, flow = iopts[row + R_LEAF], iopts[row + R_FLOW]
        if flow == HAMILTONIAN:
            eps, active = 0.0, hamiltonian
        elif flow == GRADIENT:
            hamiltonian, active = False, eps != 0.0
        else:
            active = True
        if not active or h == 0.0:
            return StepResult(x, comp, H_x, S_x, OK, 0, 0, 0.0, UNKNOWN)
        at = iopts[row + R_COEFF_AT]
        data = coeffs[at : at + iopts[row + R_COEFF_COUNT]]
        if rk4 and leaf == LEAF_RK4:
            return rk4_step(model, eps, hamiltonian, buf, x, comp, h)
        if implicit and leaf == LEAF_DISCRETE_GRADIENT:
            return discrete_gradient_step(
                stage_kind(uses, iopts[row + R_KIND]),
                iopts[row + R_MAX_ITER],
                stage_damped(uses, iopts[row + R_DAMPED] != 0),
                iopts[row + R_COMPENSATED] != 0,
                data,
                model,
                eps,
                hamiltonian,
                buf,
                x,
                comp,
                H_x,
                S_x,
                h,
                work,
            )
        if rigid_body and leaf == LEAF_RIGID_BODY_FLOW:
            return _flowed(x, comp, rigid_body_flow(data[0], data[1], data[2], x, h), 0)
        if rotor and leaf == LEAF_ROTOR_SPLITTING:
            return _flowed(x, comp, rotor_splitting(model.grad_H, model.params, buf, x, h), 5)
        if rotating and leaf == LEAF_ROTATION:
            return _flowed(x, comp, rotation(model.J, model.params, buf, x, h), 1)
        # not reached: ``Program.lower`` lists in ``uses`` every leaf a row of the program can run
        return StepResult(x, comp, np.nan, np.nan, NON_FINITE, 0, 0, 0.0, UNKNOWN)

    return leaf_step


#: under ``NUMBA_DISABLE_JIT=1``: every leaf
leaf_step = _leaf_step_for({RK4Leaf, *KIND_MARKERS.values(), RigidBodyFlowLeaf, RotorSplittingLeaf, RotationLeaf})


@typed_inline(leaf_step)
def _leaf_step_typed(uses, coeffs, iopts, row, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, work):
    return _leaf_step_for({marker.instance_class for marker in uses.types})


@inner
def _flowed(x, comp, x_flow, evaluations):
    """The step of an exact-flow leaf that moved ``x`` to ``x_flow``."""
    x_new, comp_new = advance(x, comp, sub(x_flow, x))
    status = OK if is_finite(x_new) else NON_FINITE
    return StepResult(x_new, comp_new, np.nan, np.nan, status, 0, evaluations, 0.0, UNKNOWN)


def stage_kind(uses, code):
    """The discrete gradient of a stage: the program's one kind marker where all its discrete-gradient
    leaves share one (compiled alone), else the stage's integer ``code`` (every kind compiled)."""
    return code


@typed_inline(stage_kind)
def _stage_kind_typed(uses, code):
    at = [k for k, marker in enumerate(uses.types) if marker.instance_class in KIND_MARKERS.values()]
    if len(at) == 1:
        at = at[0]
        return lambda uses, code: uses[at]
    return lambda uses, code: code


def stage_damped(uses, flag):
    """A stage's damping: ``Undamped`` where no stage of the program is damped (the damping factor is not
    compiled), else the stage's run-time ``flag``."""
    return flag


@typed_inline(stage_damped)
def _stage_damped_typed(uses, flag):
    if any(marker.instance_class is Damped for marker in uses.types):
        return lambda uses, flag: flag
    return lambda uses, flag: Undamped(False)


@hot
def _composition(uses, coeffs, iopts, model, eps, hamiltonian, buf, x, comp, H_x, S_x, h, rise_ulps, work):
    """``base(gamma_G h) o ... o base(gamma_1 h)`` from ``x`` with ``H_x = H(x)``.

    Returns ``(StepResult, sub-steps that raised S)``.
    """
    n_gamma, n_stages = iopts[P_GAMMAS], iopts[P_STAGES]
    iterations, evaluations, residual, rises = 0, 0, 0.0, 0
    for g in range(n_gamma):
        for s in range(n_stages):
            slot = (g * n_stages + s) * WORK
            r = leaf_step(
                uses,
                coeffs,
                iopts,
                HEADER + ROW * s,
                model,
                eps,
                hamiltonian,
                buf,
                x,
                comp,
                H_x,
                S_x,
                coeffs[g] * coeffs[n_gamma + s] * h,
                work[slot : slot + WORK],
            )
            iterations += r.iterations
            evaluations += r.evaluations
            residual = r.residual
            if r.status != OK:
                return StepResult(r.x, r.comp, r.H, r.S, r.status, iterations, evaluations, residual, r.culprit), rises
            H_new, S_new = r.H, r.S
            if np.isnan(S_new):
                H_new, S_new = _invariants(model, buf, r.x)
            if S_new - S_x > rise_ulps * EPS * max(abs(S_x), abs(S_new)):
                rises += 1
            x, comp, H_x, S_x = r.x, r.comp, H_new, S_new
    return StepResult(x, comp, H_x, S_x, OK, iterations, evaluations, residual, UNKNOWN), rises


@inner
def _symmetric_projection(uses, coeffs, iopts, model, eps, hamiltonian, buf, x, target, h, work):
    """Hairer's symmetric projection (BIT 40 (2000) 726, doi:10.1023/A:1022344502818):

        x^ = x + mu grad H(x),   y~ = Phi_h(x^),   y = y~ + mu grad H(y),   H(y) = H0,

    one ``mu`` for both ends, so the adjoint of the projected method is the
    projected adjoint.  Fixed point in ``y``, Newton in ``mu`` with
    ``dPhi ~ I``: ``dH(y)/dmu ~ grad H(y) . (grad H(x) + grad H(y))``.  Stops
    when the update is within 4 ulp, or has stopped shrinking below sqrt(eps)
    (the noise of an implicit ``Phi_h`` solved to round-off).
    """
    p = model.params
    gx = as_vector(model.grad_H(load(buf, x), p))
    mu = 0.0
    y = x
    gy = gx
    iterations, evaluations = 0, 0
    previous = np.inf
    moved = np.inf
    for _ in range(iopts[P_MAX_ITER]):
        x_hat = axpy(mu, gx, x)
        H_hat, S_hat = _invariants(model, buf, x_hat)
        r, _ = _composition(uses, coeffs, iopts, model, eps, hamiltonian, buf, x_hat, ZERO, H_hat, S_hat, h, 0.0, work)
        iterations += r.iterations + 1
        evaluations += r.evaluations + 1
        if r.status != OK:
            return StepResult(r.x, ZERO, r.H, r.S, r.status, iterations, evaluations, r.residual, r.culprit)
        y_new = axpy(mu, gy, r.x)
        gy = as_vector(model.grad_H(load(buf, y_new), p))
        slope = dot(gy, add(gx, gy))
        d_mu = (model.H(buf, p) - target) / slope if slope != 0.0 else 0.0
        mu -= d_mu
        moved = norm_inf(sub(y_new, y)) + abs(d_mu) * norm_inf(gx)
        y = y_new
        size = norm_inf(y)
        if moved <= 4.0 * EPS * size or (moved >= 0.5 * previous and moved <= np.sqrt(EPS) * size):
            H_y, S_y = _invariants(model, buf, y)
            return StepResult(y, ZERO, H_y, S_y, OK, iterations, evaluations, moved, UNKNOWN)
        previous = moved
    return StepResult(y, ZERO, np.nan, np.nan, NEWTON_FAILED, iterations, evaluations, moved, UNKNOWN)


@inner
def pull_back(model, buf, y, H_y, S_y, anchor, S_limit, max_iter):
    """``y`` moved along grad H back onto ``H = anchor`` when it strayed beyond ``ANCHOR_ULPS`` of the
    terms of H (see the module docstring), keeping S at most ``S_limit`` (S at the start of the full
    step, or the step's own S where it rose) to ``projection.S_CAP_ULPS`` of its terms.  Returns ``(y, H(y), S(y),
    evaluations)``.

    Where the move along grad H raises S beyond that, the point of ``H = anchor, S = S_limit`` is sought
    (``project_both``) within ``sqrt(eps) |y|``.  Where there is none (near an equilibrium of the gradient part,
    grad S || grad H, where H and S are locked: a state at rest at the stable pole with H a few ulps below H(x0))
    the moved state gives back along grad S what raised S beyond the allowance (``projection.lower_S``): H then
    rejoins H(x0) over a few steps, S rising by at most the allowance in each, not by 4-6 ulps in one (the
    allowance of a projection, ``rise_tolerance``, is 4 ulps of S on the rigid body).
    """
    grad_h = as_vector(model.grad_H(load(buf, y), model.params))
    if abs(H_y - anchor) <= ANCHOR_ULPS * EPS * term_scale(anchor, H_y, grad_h, y, origin_terms(model.origin, 0, y)):
        return y, H_y, S_y, 1
    z, H_z, it = project_energy(model, buf, y, anchor, max_iter)
    S_z = model.S(load(buf, z), model.params)
    grad_s = as_vector(model.grad_S(buf, model.params))
    terms_s = term_scale(S_limit, S_z, grad_s, z, origin_terms(model.origin, 4, z))
    if not kept(S_limit, S_z, terms_s, S_CAP_ULPS, 1.0):
        # along grad S too: H = anchor, S = S_limit
        w, H_w, S_w, converged, more = project_both(model, buf, y, anchor, S_limit, max_iter, SQRT_EPS * norm_inf(y))
        it += more
        if converged and kept(S_limit, S_w, terms_s, S_CAP_ULPS, 1.0):
            z, H_z, S_z = w, H_w, S_w
        else:  # none nearby: as close to the anchor as S allows
            z, H_z, S_z, more = lower_S(model, buf, z, H_z, S_z, S_limit, anchor, abs(H_y - anchor))
            it += more
            if not kept(S_limit, S_z, terms_s, S_CAP_ULPS, 1.0):
                return y, H_y, S_y, it + 4
    if abs(H_z - anchor) < abs(H_y - anchor):
        return z, H_z, S_z, it + 4
    return y, H_y, S_y, it + 4


@hot
def composed_step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work, rise_ulps):
    """One full step from ``x`` (``H_anchor``: H(x0)); returns ``(StepResult, sub-steps raising S,
    safeguard fired)``."""
    coeffs, iopts = method.coeffs, method.iopts
    projection = iopts[P_PROJECTION]
    H_start = model.H(load(buf, x), model.params)
    rises = 0
    if projection == SYMMETRIC:
        r = _symmetric_projection(method.uses, coeffs, iopts, model, eps, hamiltonian, buf, x, H_anchor, h, work)
    else:
        r, rises = _composition(
            method.uses, coeffs, iopts, model, eps, hamiltonian, buf, x, comp, H_start, S_x, h, rise_ulps, work
        )
    if r.status != OK:
        return r, rises, 0
    y, comp_y, H_y, S_y = r.x, r.comp, r.H, r.S
    iterations, evaluations, residual = r.iterations, r.evaluations + 1, r.residual
    fired = 0
    if iopts[P_MONOTONE] and S_y > S_x:
        row = HEADER + ROW * iopts[P_STAGES]
        slot = iopts[P_GAMMAS] * iopts[P_STAGES] * WORK
        r = leaf_step(
            method.uses,
            coeffs,
            iopts,
            row,
            model,
            eps,
            hamiltonian,
            buf,
            x,
            comp,
            H_anchor,
            S_x,
            h,
            work[slot : slot + WORK],
        )
        iterations += r.iterations
        evaluations += r.evaluations
        fired = 1
        if r.status != OK:
            return r, rises, fired
        y, comp_y, H_y, S_y = r.x, r.comp, r.H, r.S
    max_iter = iopts[P_MAX_ITER]
    if projection != NO_PROJECTION:
        y, H_y, S_y, projected, ev = project_step(model, buf, y, H_y, S_y, H_anchor, S_x, max_iter)
        evaluations += ev
        comp_y = ZERO
        if not projected:
            return (
                StepResult(y, comp_y, H_y, S_y, PROJECTION_FAILED, iterations, evaluations, residual, UNKNOWN),
                rises,
                fired,
            )
    elif iopts[P_ANCHOR]:
        z, H_y, S_y, ev = pull_back(model, buf, y, H_y, S_y, H_anchor, max(S_x, S_y), max_iter)
        evaluations += ev
        if z[0] != y[0] or z[1] != y[1] or z[2] != y[2]:
            y, comp_y = z, ZERO
    status = OK if is_finite(y) and np.isfinite(H_y) and np.isfinite(S_y) else NON_FINITE
    return StepResult(y, comp_y, H_y, S_y, status, iterations, evaluations, residual, UNKNOWN), rises, fired
