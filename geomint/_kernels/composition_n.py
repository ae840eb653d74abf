"""Splittings, compositions, the monotone safeguard and the standard projection in R^n.

The same flat program as in R^3 (``composition``: ``layout.ComposedStep``,
built by ``geomint.integrators.program.Program.lower``)

    full step   = anchor or projection( safeguard( composition ) )
    composition = base(gamma_1 h) ... base(gamma_G h),   base = stage_1(f_1 h) ... stage_N(f_N h)

run on states of length n.  Each sub-step position has its own slot of the
workspace (``step_n.work_size(n)`` floats): its own Newton factors and
history, and its own result vector, from which the next sub-step reads while
it writes its own, so no sub-step overwrites its input.  The leaves in R^n are
the discrete-gradient step (``step_n.discrete_gradient_step_n``) and RK4; the
exact flows are R^3 only (refused by ``geomint.run.solve.check_in_rn``), as is
Hairer's symmetric projection.  Sub-steps are anchored to the H of their own
sub-state; the full step is then settled onto H(x0) with S not against its
direction beyond where the step started (``projection_n.settle``): by the
projection where the program has one, by the anchor's pull back otherwise.
"""

import numpy as np

from .jit import hot, inner
from .layout import (
    EPS,
    GRADIENT,
    HAMILTONIAN,
    HEADER,
    LEAF_DISCRETE_GRADIENT,
    LEAF_RK4,
    NO_PROJECTION,
    NON_FINITE,
    OK,
    P_ANCHOR,
    P_GAMMAS,
    P_MONOTONE,
    P_PROJECTION,
    P_STAGES,
    PROJECTION_FAILED,
    R_COEFF_AT,
    R_COEFF_COUNT,
    R_DAMPED,
    R_FLOW,
    R_KIND,
    R_LEAF,
    R_MAX_ITER,
    ROW,
    UNKNOWN,
    StepResult,
)
from .projection_n import settle
from .step_n import V_C, V_R, discrete_gradient_step_n, rk4_step_n, vector, work_size
from .vecn import all_finite


@inner
def leaf_step_n(coeffs, iopts, row, model, eps, hamiltonian, x, comp, H_x, S_x, h, work):
    """One step of the leaf in program row ``row`` on its flow (a ``StepResult`` whose ``x`` is the slot's)."""
    leaf, flow = iopts[row + R_LEAF], iopts[row + R_FLOW]
    if flow == HAMILTONIAN:
        eps, active = 0.0, hamiltonian
    elif flow == GRADIENT:
        hamiltonian, active = False, eps != 0.0
    else:
        active = True
    if not active or h == 0.0:
        return StepResult(x, comp, H_x, S_x, OK, 0, 0, 0.0, UNKNOWN)
    if leaf == LEAF_RK4:
        return rk4_step_n(model, eps, hamiltonian, x, comp, h, work)
    if leaf == LEAF_DISCRETE_GRADIENT:
        at = iopts[row + R_COEFF_AT]
        return discrete_gradient_step_n(
            iopts[row + R_KIND],
            iopts[row + R_MAX_ITER],
            iopts[row + R_DAMPED] != 0,
            coeffs[at : at + iopts[row + R_COEFF_COUNT]],
            model,
            eps,
            hamiltonian,
            x,
            comp,
            H_x,
            S_x,
            h,
            work,
        )
    return StepResult(x, comp, np.nan, np.nan, NON_FINITE, 0, 0, 0.0, UNKNOWN)  # an R^3 leaf: refused before


@inner
def _slot(work, k, n):
    size = work_size(n)
    return work[k * size : (k + 1) * size]


@hot
def composed_step_n(method, model, eps, hamiltonian, x, comp, H_anchor, S_x, h, work, rise_ulps):
    """One full step from ``x`` (``H_anchor``: H(x0)); returns ``(StepResult, sub-steps moving S against its
    direction, safeguard fired)``."""
    coeffs, iopts = method.coeffs, method.iopts
    n = x.shape[0]
    p = model.params
    n_gamma, n_stages = iopts[P_GAMMAS], iopts[P_STAGES]
    against = -model.direction * np.sign(h)
    y, H_y, S_y = x, model.H(x, p), S_x
    iterations, evaluations, residual, rises = 0, 1, 0.0, 0
    for g in range(n_gamma):
        for s in range(n_stages):
            r = leaf_step_n(
                coeffs,
                iopts,
                HEADER + ROW * s,
                model,
                eps,
                hamiltonian,
                y,
                comp,
                H_y,
                S_y,
                coeffs[g] * coeffs[n_gamma + s] * h,
                _slot(work, g * n_stages + s, n),
            )
            iterations += r.iterations
            evaluations += r.evaluations
            residual = r.residual
            if r.status != OK:
                return StepResult(r.x, comp, r.H, r.S, r.status, iterations, evaluations, residual, r.culprit), rises, 0
            H_new, S_new = r.H, r.S
            if np.isnan(S_new):
                H_new, S_new = model.H(r.x, p), model.S(r.x, p)
                evaluations += 1
            if against * (S_new - S_y) > rise_ulps * EPS * max(abs(S_y), abs(S_new)):
                rises += 1
            y, H_y, S_y = r.x, H_new, S_new
    fired = 0
    if iopts[P_MONOTONE] and against * (S_y - S_x) > 0.0:
        r = leaf_step_n(
            coeffs,
            iopts,
            HEADER + ROW * n_stages,
            model,
            eps,
            hamiltonian,
            x,
            comp,
            H_anchor,
            S_x,
            h,
            _slot(work, n_gamma * n_stages, n),
        )
        iterations += r.iterations
        evaluations += r.evaluations
        fired = 1
        if r.status != OK:
            return r, rises, fired
        y, H_y, S_y = r.x, r.H, r.S
    if not all_finite(y):
        return StepResult(y, comp, H_y, S_y, NON_FINITE, iterations, evaluations, residual, UNKNOWN), rises, fired
    projected = iopts[P_PROJECTION] != NO_PROJECTION
    if projected or iopts[P_ANCHOR]:
        scratch = _slot(work, n_gamma * n_stages, n)
        conserve_s = eps == 0.0 and hamiltonian
        limit = S_x if projected or conserve_s else (S_y if against * (S_y - S_x) > 0.0 else S_x)
        H_y, S_y, settled, ev = settle(
            model, y, H_y, H_anchor, limit, against, conserve_s, vector(scratch, V_R, n), vector(scratch, V_C, n)
        )
        evaluations += ev
        if projected and not settled:
            return (
                StepResult(y, comp, H_y, S_y, PROJECTION_FAILED, iterations, evaluations, residual, UNKNOWN),
                rises,
                fired,
            )
    return StepResult(y, comp, H_y, S_y, OK, iterations, evaluations, residual, UNKNOWN), rises, fired
