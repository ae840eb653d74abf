"""The one step loop every method runs through, and the dispatch from method data to its step.

``step(method, ...)`` picks the step by the *type* of ``method``
(``layout.RungeKutta4``, ``layout.DiscreteGradientStep``,
``layout.ComposedStep``, ``layout.EmbeddedPairStep``) when ``integrate`` is compiled, so a run compiles only
what it uses; under ``NUMBA_DISABLE_JIT=1`` the same choice is made in Python.
"""

from collections import namedtuple

import numpy as np
from numba import njit
from numba.extending import overload

from .._cache import CACHE
from .composition import composed_step
from .field import non_finite_culprit
from .jit import inner
from .layout import (
    CULPRIT, FAILED_STEP, FIELD_EVALUATIONS, NEWTON_ITERATIONS, NON_FINITE, OK, RAISED, ROWS, STATE_ANCHOR, STATE_COMP,
    STATE_S, STATE_X, STATUS, STEPS, USER_RAISED, ComposedStep, DiscreteGradientStep, EmbeddedPairStep, RungeKutta4,
)
from .pairs import pair_step
from .steps import discrete_gradient_step, rk4_step
from .vec3 import flush_tiny, is_finite, load, same

#: the step grid: step ``k`` goes from ``t0 + k h`` to ``t0 + (k+1) h``, the last one has length ``h_last``;
#: states ``k`` with ``k % save_every == 0`` and the last are saved
Grid = namedtuple("Grid", "t0 h n_steps h_last save_every")
#: the output arrays: saved times, states, H, S; ``counters`` (``layout`` codes); the last residual
Output = namedtuple("Output", "t x H S counters residual")


@njit(inline="always")
def _rk4(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return rk4_step(model, eps, hamiltonian, buf, x, comp, h)


@njit(inline="always")
def _discrete_gradient(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return discrete_gradient_step(method.kind, method.max_iter, method.damped, method.compensated, method.coeffs, model,
                                  eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work)


@njit(inline="always")
def _composed(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return composed_step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work, 0.0)[0]


@njit(inline="always")
def _pair(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return pair_step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work, False)[0]


_STEPS = {RungeKutta4: _rk4, DiscreteGradientStep: _discrete_gradient, ComposedStep: _composed,
          EmbeddedPairStep: _pair}


def step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    """One step of ``method`` from ``x`` (a ``layout.StepResult``); ``H_anchor`` is H(x0), ``S_x`` S(x)."""
    return _STEPS[type(method)](method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work)


@overload(step, inline="always")
def _step_typed(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    impl = _STEPS[method.instance_class]
    return lambda method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work: impl(
        method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work
    )


@inner
def _save(out, t, x, H_x, S_x):
    row = out.counters[ROWS]
    out.t[row] = t
    out.x[row, 0], out.x[row, 1], out.x[row, 2] = x
    out.H[row] = H_x
    out.S[row] = S_x
    out.counters[ROWS] = row + 1


@njit(cache=CACHE, error_model="numpy")
def integrate(model, eps, hamiltonian, method, state, work, k_begin, k_end, grid, out):
    """Take steps ``k_begin .. k_end - 1`` of ``grid.n_steps`` from ``state`` (updated in place).

    ``state`` (``layout.N_STATE``) holds the state, its compensation (the
    rounding error carried by compensated summation, ``steps.advance``), the
    energy every step is anchored to, H(x0), and S at the state; the first
    chunk sets the last two and saves the initial state as row 0.  ``work`` is
    the method's workspace (``layout.WORK`` floats per slot), kept across chunks.

    A failed step stops the loop with the last good state saved and
    ``STATUS``, ``FAILED_STEP`` and ``CULPRIT`` (the user function that gave a
    non-finite value, when known) set in ``out.counters``; ``out.residual[0]``
    holds the last Newton correction.  ``out.counters[RAISED]`` counts the
    exceptions user functions raised (``geomint._user_errors`` counts them while
    the loop runs): a step during which it became non-zero fails.  H and S are evaluated only for the
    states saved (and by the steps that need them).

    Components below ``FLUSH * |x|_inf`` are set to zero after each step
    (``vec3.flush_tiny``), so decaying components never reach the slow
    subnormal range.

    Caller: ``geomint.solve`` (chunks of steps between progress reports and
    interrupt checks); it has validated every argument.
    """
    buf = np.empty(3)
    p = model.params
    x = (state[STATE_X], state[STATE_X + 1], state[STATE_X + 2])
    comp = (state[STATE_COMP], state[STATE_COMP + 1], state[STATE_COMP + 2])
    if k_begin == 0:
        load(buf, x)
        state[STATE_ANCHOR] = model.H(buf, p)
        state[STATE_S] = model.S(buf, p)
        _save(out, grid.t0, x, state[STATE_ANCHOR], state[STATE_S])
    anchor = state[STATE_ANCHOR]
    S_x = state[STATE_S]
    t0, h, n_steps, save_every = grid.t0, grid.h, grid.n_steps, grid.save_every
    steps, iterations, evaluations, residual = 0, 0, 0, 0.0
    countdown = save_every - k_begin % save_every  # steps to the next saved state
    for k in range(k_begin, k_end):
        last = k == n_steps - 1
        r = step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, grid.h_last if last else h, work)
        iterations += r.iterations
        evaluations += r.evaluations
        residual = r.residual
        status, culprit = r.status, r.culprit
        if out.counters[RAISED] != 0:  # a user function raised inside the step: its values were garbage
            status = USER_RAISED
        x_new, comp_new = flush_tiny(r.x, r.comp)
        H_new, S_new = r.H, r.S
        countdown -= 1
        saving = countdown == 0 or last
        if status == OK and not is_finite(x_new):
            status = NON_FINITE
        if status == OK and (saving or not np.isnan(S_new)) and (np.isnan(H_new) or not same(x_new, r.x)):
            load(buf, x_new)
            H_new, S_new = model.H(buf, p), model.S(buf, p)
        if status == OK and saving and not (np.isfinite(H_new) and np.isfinite(S_new)):
            status = NON_FINITE
        if status != OK:
            if status == NON_FINITE and culprit == 0:
                culprit = non_finite_culprit(model, buf, x_new if is_finite(x_new) else x, hamiltonian)
            out.counters[STATUS] = status
            out.counters[FAILED_STEP] = k + 1
            out.counters[CULPRIT] = culprit
            if countdown != save_every - 1:  # the last good state was not saved yet
                load(buf, x)
                _save(out, t0 + k * h, x, model.H(buf, p), model.S(buf, p))
            break
        x, comp, S_x = x_new, comp_new, S_new
        steps += 1
        if saving:
            _save(out, t0 + (n_steps - 1) * h + grid.h_last if last else t0 + (k + 1) * h, x, H_new, S_new)
            countdown = save_every
    out.counters[STEPS] += steps
    out.counters[NEWTON_ITERATIONS] += iterations
    out.counters[FIELD_EVALUATIONS] += evaluations
    out.residual[0] = residual
    state[STATE_X], state[STATE_X + 1], state[STATE_X + 2] = x
    state[STATE_COMP], state[STATE_COMP + 1], state[STATE_COMP + 2] = comp
    state[STATE_S] = S_x
