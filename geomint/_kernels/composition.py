"""The one engine for splittings, compositions, projection and the monotone safeguard.

A method of family ``steps.COMPOSED`` is a flat program (numba has no
recursion, so nesting is unrolled into three fixed levels):

    full step   = projection( safeguard( composition ) )
    composition = base(gamma_1 h) ... base(gamma_G h)
    base        = stage_1(f_1 h) ... stage_N(f_N h)      (a splitting, or one stage)
    stage       = one leaf method on one flow: FULL (xi_P + eps xi_g),
                  HAMILTONIAN (xi_P) or GRADIENT (eps xi_g)

Layout (built by ``geomint.integrators.program.Program.lower``)::

    iopts[0:HEADER]   N_GAMMA, N_STAGES, MONOTONE, PROJECTION, MAX_ITER
    iopts[HEADER + ROW * s : ...]  stage s: (leaf code, flow, offset of its iopts);
                      row N_STAGES is the safeguard's fallback leaf (a discrete gradient)
    coeffs[0 : G]     gamma_1 .. gamma_G;  then f_1 .. f_N

Energy anchor: the driver passes ``H_x = H(x0)``; it is the projection's
target.  The discrete-gradient sub-steps are not anchored to it but to the
evaluated H of their own sub-state: an anchored sub-step must also remove the
H error of the stage before it (O(h^3) for an explicit stage, which cuts a
composition to order 2; a few ulps for an exact flow, which a tiny gradient
step near an equilibrium cannot remove: Newton stalls).  So H random-walks at
round-off level over long runs (``Projected`` pins it).  Compensated summation
(``steps.advance``) runs through every sub-step; a projection restarts it
(the projected state is the state).

Leaf codes are the families of ``steps`` (RK4, DISCRETE_GRADIENT) and the
exact flows below.  Caller: ``steps.step`` (and ``rise_statistics``).  The two
modules import each other: ``steps.step`` branches here for ``COMPOSED``, and
the leaves here call ``steps``' kernels; numba resolves ``_steps.*`` when it
compiles, after both modules are loaded.
"""

import numpy as np
from numba import njit, types

from . import steps as _steps
from .exact_flows import rigid_body_flow, rotation, rotor_splitting
from .projection import project_both, project_energy, rise_tolerance
from .signatures import f64, i64, ivec, model_kernel, vec
from .vec3 import add, as_vector, axpy, dot, load, norm_inf, sub

# iopts header
N_GAMMA = 0
N_STAGES = 1
MONOTONE = 2
PROJECTION = 3
MAX_ITER = 4
HEADER = 5
ROW = 3

# flows
FULL = 0
HAMILTONIAN = 1
GRADIENT = 2

# leaf codes beyond the families of steps
RIGID_BODY_FLOW = 11
ROTOR_SPLITTING = 12
ROTATION = 13

# projection
NO_PROJECTION = 0
STANDARD = 1
SYMMETRIC = 2

ZERO = (0.0, 0.0, 0.0)


@njit(inline="always")
def _invariants(H, S, params, buf, x):
    load(buf, x)
    return H(buf, params), S(buf, params)


@njit
def leaf_step(
    leaf, flow, io, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, h
):
    """One step of the leaf method ``leaf`` on the sub-flow ``flow`` (``steps.step``'s return)."""
    if flow == HAMILTONIAN:
        eps, active = 0.0, hamiltonian
    elif flow == GRADIENT:
        hamiltonian, active = False, eps != 0.0
    else:
        active = True
    if not active or h == 0.0:
        return x, comp, H_x, S_x, _steps.OK, 0, 0, 0.0
    if leaf == _steps.RK4:
        return _steps.rk4_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, comp, h)
    if leaf == _steps.DISCRETE_GRADIENT:
        return _steps.discrete_gradient_step(
            iopts[io + _steps.DG_KIND], iopts[io + _steps.DG_MAX_ITER], iopts[io + _steps.DG_DAMPED],
            iopts[io + _steps.DG_COMPENSATED], coeffs[:0],  # leaves carry no coefficients (program.leaf_data)
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, buf, x, comp, H_x, S_x, h,
        )
    if leaf == RIGID_BODY_FLOW:
        x_flow, evaluations = rigid_body_flow(params[0], params[1], params[2], x, h), 0
    elif leaf == ROTOR_SPLITTING:
        x_flow, evaluations = rotor_splitting(grad_H, params, buf, x, h), 5
    else:
        x_flow, evaluations = rotation(J, params, buf, x, h), 1
    x_new, comp_new, H_new, S_new = _steps.advance(H, S, params, buf, x, comp, sub(x_flow, x))
    return x_new, comp_new, H_new, S_new, _steps.OK, 0, evaluations, 0.0


@njit(inline="always")
def _row(iopts, s):
    at = HEADER + ROW * s
    return iopts[at], iopts[at + 1], iopts[at + 2]


@njit
def _composition(H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, h, rise_ulps):
    """``base(gamma_G h) o ... o base(gamma_1 h)`` from ``x`` with ``H_x = H(x)``; also counts the
    sub-steps that raised S."""
    n_gamma, n_stages = iopts[N_GAMMA], iopts[N_STAGES]
    iterations, evaluations, residual, rises = 0, 0, 0.0, 0
    for g in range(n_gamma):
        for s in range(n_stages):
            leaf, flow, io = _row(iopts, s)
            hs = coeffs[g] * coeffs[n_gamma + s] * h
            x_new, comp_new, H_new, S_new, status, it, ev, residual = leaf_step(
                leaf, flow, io, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, hs
            )
            iterations += it
            evaluations += ev
            if status != _steps.OK:
                return x_new, comp_new, H_new, S_new, status, iterations, evaluations, residual, rises
            if S_new - S_x > rise_ulps * _steps.EPS * max(abs(S_x), abs(S_new)):
                rises += 1
            x, comp, H_x, S_x = x_new, comp_new, H_new, S_new
    return x, comp, H_x, S_x, _steps.OK, iterations, evaluations, residual, rises


@njit
def _symmetric_projection(H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, target, h):
    """Hairer's symmetric projection (BIT 40 (2000) 726, doi:10.1023/A:1022344502818):

        x^ = x + mu grad H(x),   y~ = Phi_h(x^),   y = y~ + mu grad H(y),   H(y) = H0,

    one ``mu`` for both ends, so the adjoint of the projected method is the
    projected adjoint.  Fixed point in ``y``, Newton in ``mu`` with
    ``dPhi ~ I``: ``dH(y)/dmu ~ grad H(y) . (grad H(x) + grad H(y))``.  Stops
    when the update is within 4 ulp, or has stopped shrinking below sqrt(eps)
    (the noise of an implicit ``Phi_h`` solved to round-off).
    """
    gx = as_vector(grad_H(load(buf, x), params))
    mu = 0.0
    y = x
    gy = gx
    iterations, evaluations = 0, 0
    previous = np.inf
    moved = np.inf
    for _ in range(iopts[MAX_ITER]):
        x_hat = axpy(mu, gx, x)
        H_hat, S_hat = _invariants(H, S, params, buf, x_hat)
        y_tilde, _, _, _, status, it, ev, res, _ = _composition(
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x_hat, ZERO, H_hat, S_hat, h, 0.0
        )
        iterations += it + 1
        evaluations += ev + 1
        if status != _steps.OK:
            return y_tilde, status, iterations, evaluations, res
        y_new = axpy(mu, gy, y_tilde)
        gy = as_vector(grad_H(load(buf, y_new), params))
        slope = dot(gy, add(gx, gy))
        d_mu = (H(buf, params) - target) / slope if slope != 0.0 else 0.0
        mu -= d_mu
        moved = norm_inf(sub(y_new, y)) + abs(d_mu) * norm_inf(gx)
        y = y_new
        size = norm_inf(y)
        if moved <= 4.0 * _steps.EPS * size or (moved >= 0.5 * previous and moved <= _steps.SQRT_EPS * size):
            return y, _steps.OK, iterations, evaluations, moved
        previous = moved
    return y, _steps.NEWTON_FAILED, iterations, evaluations, moved


@njit
def composed_step(H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_x, S_x, h, rise_ulps):
    """One full step from ``x`` (``H_x``: the anchor H(x0)); returns ``steps.step``'s tuple plus
    (sub-steps raising S, safeguard fired)."""
    projection = iopts[PROJECTION]
    H_start = H(load(buf, x), params)
    if projection == SYMMETRIC:
        y, status, iterations, evaluations, residual = _symmetric_projection(
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, H_x, h
        )
        comp_y = ZERO
        H_y, S_y = _invariants(H, S, params, buf, y)
        rises = 0
    else:
        y, comp_y, H_y, S_y, status, iterations, evaluations, residual, rises = _composition(
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_start, S_x, h, rise_ulps
        )
    if status != _steps.OK:
        return y, comp_y, H_y, S_y, status, iterations, evaluations, residual, rises, 0
    fired = 0
    if iopts[MONOTONE] and S_y > S_x:
        leaf, flow, io = _row(iopts, iopts[N_STAGES])
        y, comp_y, H_y, S_y, status, it, ev, residual = leaf_step(
            leaf, flow, io, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_start, S_x, h
        )
        iterations += it
        evaluations += ev
        fired = 1
        if status != _steps.OK:
            return y, comp_y, H_y, S_y, status, iterations, evaluations, residual, rises, fired
    if projection != NO_PROJECTION:
        max_iter = iopts[MAX_ITER]
        y, H_y, it = project_energy(H, grad_H, params, buf, y, H_x, max_iter)
        evaluations += it + 2
        comp_y = ZERO
        grad_h = as_vector(grad_H(load(buf, y), params))
        if not _steps._kept(H_x, H_y, grad_h, norm_inf(y), 64.0, 0.0):  # no point of H = H0 along grad H
            return y, comp_y, H_y, S_y, _steps.NEWTON_FAILED, iterations, evaluations, residual, rises, fired
        S_y = S(load(buf, y), params)
        grad_s = as_vector(grad_S(buf, params))
        if S_y - S_x > rise_tolerance(S_x, S_y, grad_s, y):
            y, H_y, S_y, converged, it = project_both(H, grad_H, S, grad_S, params, buf, y, H_x, S_x, max_iter)
            evaluations += it + 1
            if not converged:
                return y, comp_y, H_y, S_y, _steps.NEWTON_FAILED, iterations, evaluations, residual, rises, fired
    return y, comp_y, H_y, S_y, _steps.OK, iterations, evaluations, residual, rises, fired


@model_kernel(types.void, f64, types.boolean, vec, ivec, vec, f64, i64, f64, ivec)
def rise_statistics(H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, state, h, n_steps, rise_ulps, out):
    """Run ``n_steps`` full steps from ``state`` (updated) and count S rises beyond ``rise_ulps`` ulp.

    ``out``: steps taken, sub-steps, sub-steps raising S, full steps raising S,
    safeguard firings, status.  Caller: ``geomint.integrators.S_rise_statistics``.
    """
    buf = np.empty(3)
    x = (state[0], state[1], state[2])
    comp = ZERO
    anchor, S_x = _invariants(H, S, params, buf, x)
    per_step = iopts[N_GAMMA] * iopts[N_STAGES]
    for _ in range(n_steps):
        x_new, comp_new, _, S_new, status, _, _, _, rises, fired = composed_step(
            H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, anchor, S_x, h, rise_ulps
        )
        if status != _steps.OK:
            out[5] = status
            break
        out[0] += 1
        out[1] += per_step
        out[2] += rises
        out[3] += S_new - S_x > rise_ulps * _steps.EPS * max(abs(S_x), abs(S_new))
        out[4] += fired
        x, comp, S_x = x_new, comp_new, S_new
    state[0], state[1], state[2] = x
