"""THE step loop: every run of every method, fixed or adaptive, goes through ``run``.

``run`` attempts steps from the state in ``state`` towards ``stops``; where the
next step goes is its controller's (``control.Constant`` for fixed steps on a
grid, ``control.Control`` for adaptive steps or fixed steps landing on stops),
chosen by the controller's type when ``run`` is compiled.  Each accepted step
is checked (finite state, H and S finite where evaluated, no user function
raised); a failed step stops the run with the last good state saved (a run
saving every k-th state evaluates H and S there only: where the state before
the failing one has a non-finite H or S too, the last saved state is the last
good one, and the failure is reported at the step after it).  At eps = 0 a
step that keeps S is given S(x0), as every step is given H(x0).
"""

from collections import namedtuple

import numpy as np
from numba import njit
from numba.extending import overload

from .._cache import CACHE
from .borrow import borrowed
from .control import FAILED_FACTOR, PULL_BACK_ITER, Control, accept, attempt, now, on_rejection, propose, start, traits
from .jit import OVERLOADED, hot, inner
from .layout import (
    C_COUNT,
    C_H,
    C_REACH,
    C_STOP,
    C_T,
    CULPRIT,
    EPS,
    FAILED_STEP,
    FIELD_EVALUATIONS,
    FULL_STEP_RISES,
    NEWTON_FAILED,
    NEWTON_ITERATIONS,
    NON_FINITE,
    NOT_ACCEPTED,
    OK,
    PROJECTION_FAILED,
    RAISED,
    REJECTED,
    ROWS,
    SAFEGUARD_FIRED,
    STATUS,
    STEP_TOO_SMALL,
    STEPS,
    SUB_STEP_RISES,
    USER_RAISED,
)
from .state import (
    ANCHOR,
    S_AT,
    culprit_of,
    finite,
    flushed,
    keep,
    pack,
    point,
    pulled_back,
    save_row,
    start_point,
    unchanged,
    unpack,
)
from .step import keeps_S

#: the output arrays: saved times, states, H, S; ``counters`` (``layout`` codes); the last residual
Output = namedtuple("Output", "t x H S counters residual")


@inner
def _save(out, t, x, H_x, S_x):
    row = out.counters[ROWS]
    out.t[row] = t
    save_row(out.x, row, x)
    out.H[row] = H_x
    out.S[row] = S_x
    out.counters[ROWS] = row + 1


@hot
def _attempted(
    control,
    method,
    model,
    eps,
    hamiltonian,
    buf,
    x,
    comp,
    anchor,
    H_x,
    S_x,
    S_kept,
    h,
    work,
    clock,
    saving,
):
    """One attempted step from ``x`` as ``run`` takes it: ``(H_x, H_target, iterations, evaluations, residual,
    status, culprit, x', comp', H(x'), S(x'), err, rises, fired)``, ``x'`` flushed (``vec3.flush_tiny``) and
    checked finite, H and S evaluated at it where the step did not give them (``run``'s docstring); ``H_x`` is
    evaluated where an adaptive anchor's reach is short of 1 and not known yet."""
    p = model.params
    adaptive, lazy = traits(control)[:2]
    H_target = anchor
    if adaptive and clock[C_REACH] < 1.0:
        if np.isnan(H_x):
            H_x = model.H(point(buf, x), p)
        H_target = H_x + clock[C_REACH] * (anchor - H_x)
    S_given = S_x if np.isnan(S_kept) or H_target != anchor else S_kept
    r, err, rises, fired = attempt(control, method, model, eps, hamiltonian, buf, x, comp, H_target, S_given, h, work)
    status, culprit = r.status, r.culprit
    x_new, comp_new = flushed(r.x, r.comp)
    H_new, S_new = r.H, r.S
    if status == OK and not finite(x_new):
        status = NON_FINITE
    if lazy:  # H and S only where saved, or where the step knows S
        evaluate = (saving or not np.isnan(S_new)) and (np.isnan(H_new) or not unchanged(x_new, r.x))
    else:
        evaluate = np.isnan(H_new) or np.isnan(S_new) or not unchanged(x_new, r.x)
    if status == OK and evaluate:
        at = point(buf, x_new)
        H_new, S_new = model.H(at, p), model.S(at, p)
    return (
        H_x,
        H_target,
        r.iterations,
        r.evaluations,
        r.residual,
        status,
        culprit,
        x_new,
        comp_new,
        H_new,
        S_new,
        err,
        rises,
        fired,
    )


# (the rare paths' ``try``s are in functions of their own: ``run``'s compile time grows faster than its blocks)
@inner
def _values(model, buf, x, lazy, S_x):
    """H and S at ``x`` (S as given where the run is not lazy); NaN where an inlined user function raised."""
    H_x, S_given = np.nan, np.nan
    try:
        at = point(buf, x)
        H_x, S_given = model.H(at, model.params), (model.S(at, model.params) if lazy else S_x)
    except Exception:  # noqa: BLE001 - as not finite
        pass
    return H_x, S_given


@inner
def _culprit(model, buf, x, hamiltonian):
    """The user function that is not finite at ``x`` (``state.culprit_of``); 0 where one raised instead."""
    culprit = 0
    try:
        culprit = culprit_of(model, buf, x, hamiltonian)
    except Exception:  # noqa: BLE001 - the step's own failure stands
        pass
    return culprit


def onto_anchor(control, model, buf, x, H_x, S_x, anchor, S_cap, work):
    """An adaptive step that kept (nearly) its own energy, pulled back onto the anchor's level set
    (``_pulled_back``); compiled only for the controller that can take such steps (``control.Control``)."""
    return _pulled_back(model, buf, x, H_x, S_x, anchor, S_cap, work)


@overload(onto_anchor, jit_options=OVERLOADED)
def _onto_anchor_typed(control, model, buf, x, H_x, S_x, anchor, S_cap, work):
    if control.instance_class is Control:
        return lambda control, model, buf, x, H_x, S_x, anchor, S_cap, work: _pulled_back(
            model, buf, x, H_x, S_x, anchor, S_cap, work
        )
    return lambda control, model, buf, x, H_x, S_x, anchor, S_cap, work: (x, H_x, S_x, 0, False)


@inner
def _pulled_back(model, buf, x, H_x, S_x, anchor, S_cap, work):
    """``state.pulled_back`` onto the anchor's level set: ``(x', H', S', evaluations, raised)``, ``x`` as it was
    where an inlined user function raised."""
    x_back, H_back, S_back, evaluations, raised = x, H_x, S_x, 0, True
    try:
        x_back, H_back, S_back, evaluations = pulled_back(model, buf, x, H_x, S_x, anchor, S_cap, PULL_BACK_ITER, work)
        raised = False
    except Exception:  # noqa: BLE001 - an inlined user function raised
        pass
    return x_back, H_back, S_back, evaluations, raised


@njit(cache=CACHE, error_model="numpy")
def run(model, eps, hamiltonian, method, control, state, work, clock, stops, budget, out):
    """At most ``budget`` attempted steps towards ``stops[clock[C_STOP]:]``, rows to ``out`` until it is full.

    ``state`` (``layout.STATE_*``) holds the state, its compensation (the
    rounding error carried by compensated summation, ``vec3.advance``), the
    energy every step is anchored to (NaN: take H at the first state) and S at
    the state; ``clock`` (``layout.C_*``, ``layout.new_clock``) where the
    controller stands; ``work`` the method's workspace (``layout.WORK`` floats
    per slot).  All are updated in place and carried from call to call: the
    first call saves the initial state as row 0 and, for an adaptive run whose
    ``clock[C_H]`` is 0, chooses the first step (``control.first_step``).

    ``out.counters`` (``layout``): steps, Newton iterations, field evaluations,
    rejected attempts; a failure sets ``STATUS``, ``FAILED_STEP`` (accepted
    steps + 1) and ``CULPRIT`` (the user function that gave a non-finite value,
    when known), and saves the last good state if it was not saved;
    ``out.residual[0]`` holds the last Newton correction.  ``RAISED`` counts
    the exceptions user functions raised (``geomint._user_errors``): a step
    during which it became non-zero fails.  A ``control.Counting`` run also counts S rises
    (``layout.SUB_STEP_RISES`` ...).  Components below ``FLUSH * |x|_inf``
    are set to zero after each step (``vec3.flush_tiny``).

    Callers: ``geomint.run.chunks`` (chunks of attempts between progress
    reports and Ctrl-C, for ``solve`` and the landing steps of events),
    ``batch.run_batch`` and ``geomint.studies.S_rise_statistics``; they have
    validated every argument.
    """
    owner = np.empty(3)
    buf = borrowed(owner)
    model, method, control, state, work, clock, stops, out = borrowed(
        (model, method, control, state, work, clock, stops, out)
    )
    counters = out.counters
    x, comp = unpack(model, state)
    if counters[ROWS] == 0:
        H0, state[S_AT] = _values(model, buf, x, True, np.nan)  # NaN where a user function raised at x0
        if np.isnan(state[ANCHOR]):
            state[ANCHOR] = H0
        _save(out, clock[C_T], x, H0, state[S_AT])
        # the first step of an adaptive run, when not given, is chosen here (so a solve and a trajectory of an
        # ensemble choose the same); a user function raising there fails the first step, as one raising in it
        if counters[RAISED] == 0 and start(
            control, model, eps, hamiltonian, start_point(model, state), clock, stops[-1]
        ):
            counters[RAISED] += 1
    anchor = state[ANCHOR]
    S_x = state[S_AT]
    # eps = 0: S is conserved as H is; a step that keeps the S it is given (``step.keeps_S``) is given S(x0), the
    # first row, as it is given H(x0), so that the rounding of S does not random-walk (docs/hard_cases.md)
    S_kept = out.S[0] if eps == 0.0 and keeps_S(method, model) else np.nan
    H_x = np.nan  # H at x, evaluated when the anchor's reach is short of 1
    adaptive, lazy, period, exponent, rise = traits(control)  # rise >= 0: S rises counted (``control.Counting``)
    countdown = period - int(clock[C_COUNT]) % period if period > 0 else 0  # saving when it is 1
    after_rejection = False
    streak_h, streak_err = 0.0, 0.0  # the first rejected attempt of the current streak
    steps, iterations, evaluations, rejected, residual = 0, 0, 0, 0, out.residual[0]
    attempts = 0
    while clock[C_STOP] < stops.shape[0] and counters[ROWS] < out.t.shape[0] and attempts < budget:
        attempts += 1
        t_now = now(control, clock)
        target = stops[int(clock[C_STOP])]
        h, landing = propose(control, clock, t_now, target)
        H_target = anchor
        saving = landing or countdown == 1
        # an inlined user function (``geomint.model.handles``) raises into the kernel: the step fails as one whose
        # function raised (a first-class one cannot raise here: ``geomint._user_errors`` counts it in RAISED)
        raised = True
        status, culprit, err, rises, fired = USER_RAISED, 0, np.nan, 0, 0
        x_new, comp_new, H_new, S_new, it, ev = x, comp, np.nan, np.nan, 0, 0
        # (each ``try`` holds one call: numba splits a try region at every statement that can raise, and the
        # compile time of the loop grows faster than its blocks)
        try:
            H_x, H_target, it, ev, residual, status, culprit, x_new, comp_new, H_new, S_new, err, rises, fired = (
                _attempted(
                    control,
                    method,
                    model,
                    eps,
                    hamiltonian,
                    buf,
                    x,
                    comp,
                    anchor,
                    H_x,
                    S_x,
                    S_kept,
                    h,
                    work,
                    clock,
                    saving,
                )
            )
            raised = False
        except Exception:  # noqa: BLE001 - numba catches no narrower class from compiled code
            pass
        iterations += it
        evaluations += ev
        if raised or counters[RAISED] != 0:  # a user function raised inside the step: its values were garbage
            status, culprit = USER_RAISED, 0
        if status == OK and (saving or not lazy) and not (np.isfinite(H_new) and np.isfinite(S_new)):
            status = NON_FINITE
        if adaptive:
            resolution = 16.0 * EPS * max(abs(t_now), abs(target))
            if status == OK and not err <= 1.0:  # rejected (a NaN estimate too)
                streak_h, streak_err = on_rejection(clock, h, err, exponent, streak_h, streak_err)
                rejected += 1
                after_rejection = True
                if streak_h == 0.0 or abs(clock[C_H]) > resolution:
                    continue
                status = STEP_TOO_SMALL
            if (
                status in (NEWTON_FAILED, NOT_ACCEPTED, PROJECTION_FAILED, NON_FINITE)
                and abs(h) * FAILED_FACTOR > resolution
            ):
                clock[C_H] = h * FAILED_FACTOR
                rejected += 1
                after_rejection = True
                continue
        if status == OK and adaptive and H_target != anchor:  # kept (nearly) its own energy: back onto the anchor's
            x_new, H_new, S_new, ev, raised = onto_anchor(
                control, model, buf, x_new, H_new, S_new, anchor, max(S_x, S_new), work
            )
            evaluations += ev
            if raised:
                status, culprit = USER_RAISED, 0
        if status != OK:
            if status == NON_FINITE and culprit == 0:
                culprit = _culprit(model, buf, x_new if finite(x_new) else x, hamiltonian)
            counters[STATUS] = status
            counters[FAILED_STEP] = counters[STEPS] + steps + 1
            counters[CULPRIT] = culprit
            if out.t[counters[ROWS] - 1] != t_now:  # the last good state was not saved yet
                H_last, S_last = _values(model, buf, x, lazy, S_x)
                if np.isfinite(H_last) and np.isfinite(S_last):
                    _save(out, t_now, x, H_last, S_last)
                else:  # lazy: H and S were last checked at the last saved row, and they went non-finite since
                    # (an explicit step never calls them); that row is the last good state: the run is cut back
                    # to it and the failure reported at the step after it, never a saved NaN
                    back = period - countdown  # accepted steps since that row
                    steps -= back
                    counters[FAILED_STEP] -= back
            break
        if rise >= 0.0:
            counters[SUB_STEP_RISES] += rises
            counters[SAFEGUARD_FIRED] += fired
            counters[FULL_STEP_RISES] += S_new - S_x > rise * EPS * max(abs(S_x), abs(S_new))
        t_new = accept(control, clock, t_now, h, err, landing, target, exponent, after_rejection)
        after_rejection = False
        streak_h = 0.0
        x, comp, S_x, H_x = keep(x, x_new), keep(comp, comp_new), S_new, H_new
        steps += 1
        countdown = period if saving else countdown - 1
        if saving:
            _save(out, t_new, x, H_new, S_new)
    counters[STEPS] += steps
    counters[NEWTON_ITERATIONS] += iterations
    counters[FIELD_EVALUATIONS] += evaluations
    counters[REJECTED] += rejected
    out.residual[0] = residual
    pack(state, x, comp)
    state[S_AT] = S_x
    owner[0] = 0.0  # the buffer borrowed above is held until here
