"""The step loop with a moving step: error control, and steps that land on given times.

``march`` advances from the clock's time towards each of the ``stops`` in turn
(the times of ``t_eval``, event landings and ``t_end``), landing on each
exactly: a step that would pass a stop is shortened to end on it.  Between
stops the step is

* **adaptive** (``control.adaptive``): an error estimate ``e`` of the step
  (``control.estimator``, below) is measured in the norm

      err = sqrt(mean_i (e_i / (atol + rtol max(|x_i|, |x'_i|)))^2)

  (as ``scipy.integrate.solve_ivp``; Dormand-Prince 8(5,3) blends its two
  estimates as Hairer's DOP853 does).  A step with ``err <= 1`` is accepted;
  the next is ``h err^(-0.7/k) err_prev^(0.4/k)``, ``k`` the order of the
  estimate plus one (the PI controller of Hairer & Wanner, *Solving ODEs II*,
  section IV.2, and Gustafsson, ACM TOMS 20 (1994) 496), times 0.9, within a
  factor 0.2..10 (never growing right after a rejection).  A rejected step,
  or an attempt whose Newton iteration or projection failed, is retried
  shorter; every attempt rejected is counted (``layout.REJECTED``).  Only
  accepted steps are kept, so each keeps H and S as the method does.
* **fixed** (``control.adaptive`` False): ``h`` from the last stop on, the
  step before a stop shortened to land on it.

**Tolerance proportionality.**  Control of the error per step makes the
global error of a method of order ``p`` grow like ``tol^(p/(p+1))``, so it
lags the tolerance as the tolerance tightens.  Step doubling of a method of
order ``p >= 4`` is therefore run with ``rtol' = rtol^((p+1)/p)`` and ``atol'``
scaled alike (``proportional_tolerance``; Hairer and Wanner's RADAU5 code
transforms its tolerances the same way, with ``p = 2``), which makes the global
error proportional to the tolerance (measured on the relaxing body for
Yoshida4(Gonzalez), rtol from 1e-4 to 1e-10: 0.4-0.7x rtol over T = 10 and
100).  Orders 2 and below keep the given tolerance: their transformed local
tolerance (``rtol^1.5``) would sit at round-off.

**Energy anchor near equilibria.**  A discrete-gradient step keeps the
energy of the run's first state, H(x0) (``steps.discrete_gradient_step``):
it removes the few ulps by which H(x_n) has strayed.  Its discrete gradient
does so through a correction along the increment, which moves the state
*along* the level set by about ``|H(x_n) - H(x0)| |J| / |xi|``, whatever the
step: near an equilibrium (``|xi|`` small) at a tight tolerance this exceeds
the tolerance, every attempt is rejected however short, and the run crawls.
The controller recognises it: a streak of rejections in which the step has
halved but the error norm has not (a local error of order ``q`` would have
fallen by ``2^q``).  It then shortens the anchor's *reach* (``C_REACH``): the
step keeps ``H(x_n) + reach (H(x0) - H(x_n))``, reach divided by 4 (0 below
``4 REACH_MIN``: the step keeps its own energy), and is retried at the
streak's first step.  An accepted step with reach below 1 is pulled back
along grad H onto H(x0) (``composition.pull_back``, S kept from rising): a
displacement of ``|H - H(x0)| / |grad H|``, the smallest there is.  The reach
doubles back after each step with error norm at most 0.5.  Measured (quartic
body k = 0.5, eps = 0.1, rtol = atol = 1e-12, T = 20): the run had crawled
for minutes near t = 19.82 with 18 million rejections in 0.005 time units;
it now takes 0.05 s, energy to 2e-15.

Estimators (``layout``): ``EMBEDDED``, the method's own pair
(``pairs.pair_step``); ``RK4_REFERENCE``, a discrete-gradient step of order
``p`` against the explicit RK4 step from the same state (order 4, so the
difference is the discrete-gradient step's local error to leading order; its
increment also starts the Newton iteration); ``DOUBLING``, one step of ``h``
against two of ``h/2`` (``e = (x_2 - x_1) / (2^p - 1)``, Richardson; the two
half steps are kept), which any method can do, and which stays valid where an
explicit reference would be unstable (stiff relaxation with DampedGonzalez).

The first step, when not given, is ``first_step``: scipy's rule, compiled, so
that ``solve`` and each trajectory of an ensemble choose the same one.

Callers: ``geomint.solve`` (chunks of at most ``budget`` attempts, between which
it grows the output, reports progress and answers Ctrl-C) and the ensemble's
batch kernel; they have validated every argument.
"""

from collections import namedtuple

import numpy as np
from numba import njit
from numba.extending import overload

from .._cache import CACHE
from .composition import pull_back
from .driver import _save, step
from .field import field, non_finite_culprit
from .jit import inner
from .layout import (
    C_BASE, C_COUNT, C_ERROR, C_H, C_REACH, C_STOP, C_T, CULPRIT, DOUBLING, FAILED_STEP, FIELD_EVALUATIONS, NEWTON_FAILED,
    NEWTON_ITERATIONS, NON_FINITE, OK, PROJECTION_FAILED, RAISED, REJECTED, ROWS, RK4_REFERENCE, STATE_ANCHOR,
    STATE_COMP, STATE_S, STATE_X, STATUS, STEP_TOO_SMALL, STEPS, UNKNOWN, USER_RAISED, ComposedStep, DiscreteGradientStep,
    EmbeddedPairStep, RungeKutta4, StepResult,
)
from .pairs import pair_step
from .steps import rk4_increment, seed_predictor
from .vec3 import ZERO, flush_tiny, is_finite, load, scale, sub

EPS = np.finfo(np.float64).eps
SAFETY = 0.9
FAC_MIN = 0.2
FAC_MAX = 10.0
#: a failed Newton iteration or projection retries the step this much shorter
FAILED_FACTOR = 0.25
#: the anchor's reach below which steps keep their own energy (reach 0), and from which it grows back
REACH_MIN = 2.0**-10
#: Newton iterations of the pull back onto the anchor's level set (it stops once the residual stops shrinking)
PULL_BACK_ITER = 50

#: ``adaptive``: error control on; ``h``: the fixed step (signed) when it is off, else unused;
#: ``rtol``, ``atol``, ``h_max`` (> 0); ``estimator`` (``layout``) and the order of the estimate
#: ``error_order``; ``order``: the method's order (Richardson's ``2^p - 1``); ``save_all``: every
#: accepted step is a row (else only the stops)
Control = namedtuple("Control", "adaptive h rtol atol h_max estimator error_order order save_all")


def proportional_tolerance(estimator, order, rtol):
    """The factor the tolerances are scaled by (see the module docstring): ``rtol^(1/p)`` for step doubling of
    order ``p >= 4``, else 1."""
    return rtol ** (1.0 / order) if estimator == DOUBLING and order >= 4 else 1.0


@inner
def error_norm(e, e_low, x, x_new, rtol, atol, blended):
    """The controller's norm of the estimate ``e`` (and DOP853's ``e_low`` where ``blended``).

    Each component is first reduced by the round-off of the two states whose
    difference it is (``4 eps max(|x_i|, |x'_i|)``): below that an estimate is
    noise, and a noise-driven estimate (divided by a small ``h`` per unit step)
    would shrink the step without end.
    """
    m, m_low = 0.0, 0.0
    for i in range(3):
        size = max(abs(x[i]), abs(x_new[i]))
        weight = atol + rtol * size
        floor = 4.0 * EPS * size
        m += (max(abs(e[i]) - floor, 0.0) / weight) ** 2
        m_low += (max(abs(e_low[i]) - floor, 0.0) / weight) ** 2
    m /= 3.0
    m_low /= 3.0
    if not blended:
        return np.sqrt(m)
    if m == 0.0 and m_low == 0.0:
        return 0.0
    return m / np.sqrt((m + 0.01 * m_low) * 3.0)


@inner
def _invariants_if_unknown(model, buf, r):
    if np.isnan(r.H) or np.isnan(r.S):
        load(buf, r.x)
        return model.H(buf, model.params), model.S(buf, model.params)
    return r.H, r.S


@inner
def _steps(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work, doubling):
    """One step of ``h``; with ``doubling`` also two of ``h/2`` (kept), and ``e = (x_2 - x_1) / (2^p - 1)``.
    Returns ``(StepResult, e)``.  One call site of the step, so it is compiled (inlined) once."""
    full = StepResult(x, comp, np.nan, np.nan, OK, 0, 0, 0.0, UNKNOWN)
    r = full
    iterations, evaluations = 0, 0
    start, start_comp, S_start, size = x, comp, S_x, h
    for k in range(3 if doubling else 1):
        if k == 1:
            size = 0.5 * h
        elif k == 2:
            start, start_comp = r.x, r.comp
            S_start = _invariants_if_unknown(model, buf, r)[1]
        r = step(method, model, eps, hamiltonian, buf, start, start_comp, anchor, S_start, size, work)
        iterations += r.iterations
        evaluations += r.evaluations
        if r.status != OK:
            break
        if k == 0:
            full = r
    e = scale(1.0 / (2.0 ** control.order - 1.0), sub(r.x, full.x)) if doubling else ZERO
    return StepResult(r.x, r.comp, r.H, r.S, r.status, iterations, evaluations, r.residual, r.culprit), e


@inner
def _estimated_pair(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    r, e, e_low = pair_step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work, control.adaptive)
    return r, error_norm(e, e_low, x, r.x, control.rtol, control.atol, method.e_low.shape[0] > 0)


@inner
def _estimated_discrete_gradient(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    against_rk4 = control.adaptive and control.estimator == RK4_REFERENCE
    reference = ZERO
    if against_rk4:
        reference = rk4_increment(model, eps, hamiltonian, buf, x, h)
        seed_predictor(work, reference, h)
    r, e = _steps(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work,
                  control.adaptive and not against_rk4)
    if against_rk4:
        e = sub(sub(r.x, x), reference)
        r = StepResult(r.x, r.comp, r.H, r.S, r.status, r.iterations, r.evaluations + 4, r.residual, r.culprit)
    return r, error_norm(e, ZERO, x, r.x, control.rtol, control.atol, False) if control.adaptive else 0.0


@inner
def _estimated_by_doubling(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    r, e = _steps(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work, control.adaptive)
    return r, error_norm(e, ZERO, x, r.x, control.rtol, control.atol, False) if control.adaptive else 0.0


_ESTIMATED = {EmbeddedPairStep: _estimated_pair, DiscreteGradientStep: _estimated_discrete_gradient,
              RungeKutta4: _estimated_by_doubling, ComposedStep: _estimated_by_doubling}


def estimated_step(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    """One attempt of ``method`` with its error norm (0 without error control): ``(StepResult, err)``."""
    return _ESTIMATED[type(method)](method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work)


@overload(estimated_step, inline="always")
def _estimated_step_typed(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    impl = _ESTIMATED[method.instance_class]
    return lambda method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work: impl(
        method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work
    )


@inner
def _next_factor(err, previous, exponent, after_rejection):
    """The PI controller's factor for the next step after an accepted one with norm ``err``."""
    if err == 0.0:
        factor = FAC_MAX
    else:
        factor = SAFETY * err ** (-0.7 * exponent) * max(previous, 1e-4) ** (0.4 * exponent)
    factor = min(FAC_MAX, max(FAC_MIN, factor))
    return min(1.0, factor) if after_rejection else factor


@njit(cache=CACHE, error_model="numpy")
def first_step(model, eps, hamiltonian, x0, t0, t_end, control):
    """The first step of an adaptive run (signed towards ``t_end``) by scipy's rule (Hairer, Norsett &
    Wanner, *Solving ODEs I*, section II.4): from the sizes of ``x0``, ``xi(x0)`` and a difference
    quotient of ``xi``, a step whose Euler error is about the tolerance (in the controller's RMS norm,
    weights ``atol + rtol |x0_i|``), at most ``100 h0``, the span and ``control.h_max``, at least 16 ulp
    of the times.  Where the field is not finite at ``x0`` the span is tried (the step will fail and
    report it)."""
    buf = np.empty(3)
    span = abs(t_end - t0)
    direction = 1.0 if t_end >= t0 else -1.0
    x = (x0[0], x0[1], x0[2])
    f0 = field(model, eps, hamiltonian, buf, x)
    d0, d1 = 0.0, 0.0
    for i in range(3):
        weight = control.atol + control.rtol * abs(x[i])
        d0 += (x[i] / weight) ** 2
        d1 += (f0[i] / weight) ** 2
    d0, d1 = np.sqrt(d0 / 3.0), np.sqrt(d1 / 3.0)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    f1 = field(model, eps, hamiltonian, buf, (x[0] + direction * h0 * f0[0], x[1] + direction * h0 * f0[1],
                                              x[2] + direction * h0 * f0[2]))
    d2 = np.inf
    if is_finite(f1):
        d2 = 0.0
        for i in range(3):
            d2 += ((f1[i] - f0[i]) / (control.atol + control.rtol * abs(x[i]))) ** 2
        d2 = np.sqrt(d2 / 3.0) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (control.error_order + 1.0))
    h = min(100.0 * h0, h1, span, control.h_max)
    if not np.isfinite(h):
        h = min(span, control.h_max)
    return direction * max(h, 16.0 * EPS * max(abs(t0), abs(t_end)))


@njit(cache=CACHE, error_model="numpy")
def march(model, eps, hamiltonian, method, control, state, work, clock, stops, budget, out):
    """At most ``budget`` attempted steps towards ``stops[clock[C_STOP]:]`` (see the module docstring).

    ``state`` (``layout.STATE_*``) holds the state, its compensation, the
    energy anchor (NaN: take H at the first state) and S at the state;
    ``clock`` (``layout.C_*``) the time, the next step to try, the last error
    norm and the fixed grid's origin.  Rows go to ``out`` (``driver.Output``;
    the first call saves the initial state) until it is full; its counters as
    in ``driver.integrate``, with ``REJECTED``.  A failure saves the last good
    state (if not saved) and stops, with ``STATUS``, ``FAILED_STEP`` (accepted
    steps + 1) and ``CULPRIT`` set.
    """
    counters, residual = out.counters, out.residual
    buf = np.empty(3)
    p = model.params
    x = (state[STATE_X], state[STATE_X + 1], state[STATE_X + 2])
    comp = (state[STATE_COMP], state[STATE_COMP + 1], state[STATE_COMP + 2])
    if counters[ROWS] == 0:
        load(buf, x)
        H0 = model.H(buf, p)
        if np.isnan(state[STATE_ANCHOR]):
            state[STATE_ANCHOR] = H0
        state[STATE_S] = model.S(buf, p)
        _save(out, clock[C_T], x, H0, state[STATE_S])
    anchor = state[STATE_ANCHOR]
    S_x = state[STATE_S]
    H_x = np.nan  # H at x, evaluated when the anchor's reach is short of 1
    exponent = 1.0 / (control.error_order + 1.0)
    after_rejection = False
    streak_h, streak_err = 0.0, 0.0  # the first rejected attempt of the current streak
    attempts = 0
    while clock[C_STOP] < stops.shape[0] and counters[ROWS] < out.t.shape[0] and attempts < budget:
        attempts += 1
        t_now = clock[C_T]
        target = stops[int(clock[C_STOP])]
        remaining = target - t_now
        proposal = clock[C_H]
        if control.adaptive:
            h = proposal
            if abs(h) > control.h_max:
                h = np.sign(h) * control.h_max
        else:
            h = clock[C_BASE] + (clock[C_COUNT] + 1.0) * control.h - t_now
        landing = abs(h) >= abs(remaining) * (1.0 - 4.0 * EPS)
        if landing:
            h = remaining
        H_target = anchor
        if clock[C_REACH] < 1.0:
            if np.isnan(H_x):
                H_x = model.H(load(buf, x), p)
            H_target = H_x + clock[C_REACH] * (anchor - H_x)
        r, err = estimated_step(method, control, model, eps, hamiltonian, buf, x, comp, H_target, S_x, h, work)
        counters[NEWTON_ITERATIONS] += r.iterations
        counters[FIELD_EVALUATIONS] += r.evaluations
        residual[0] = r.residual
        status, culprit = r.status, r.culprit
        if counters[RAISED] != 0:
            status = USER_RAISED
        x_new, comp_new = flush_tiny(r.x, r.comp)
        H_new, S_new = r.H, r.S
        if status == OK and not is_finite(x_new):
            status = NON_FINITE
        if status == OK and (np.isnan(H_new) or np.isnan(S_new) or x_new[0] != r.x[0] or x_new[1] != r.x[1]
                             or x_new[2] != r.x[2]):
            load(buf, x_new)
            H_new, S_new = model.H(buf, p), model.S(buf, p)
        if status == OK and not (np.isfinite(H_new) and np.isfinite(S_new)):
            status = NON_FINITE
        resolution = 16.0 * EPS * max(abs(t_now), abs(target))
        if control.adaptive and status == OK and not err <= 1.0:  # rejected (a NaN estimate too)
            if streak_h == 0.0:
                streak_h, streak_err = h, err
            elif clock[C_REACH] > 0.0 and abs(h) <= 0.5 * abs(streak_h) and err >= 0.5 * streak_err:
                # the estimate does not fall with the step: the anchor's pull (module docstring)
                clock[C_REACH] = 0.0 if clock[C_REACH] < 4.0 * REACH_MIN else 0.25 * clock[C_REACH]
                clock[C_H] = streak_h
                streak_h = 0.0
                counters[REJECTED] += 1
                after_rejection = True
                continue
            factor = SAFETY * err ** -exponent if np.isfinite(err) else FAC_MIN
            clock[C_H] = h * max(FAC_MIN, min(1.0, factor))
            counters[REJECTED] += 1
            after_rejection = True
            if abs(clock[C_H]) > resolution:
                continue
            status = STEP_TOO_SMALL
        if control.adaptive and status in (NEWTON_FAILED, PROJECTION_FAILED, NON_FINITE) \
                and abs(h) * FAILED_FACTOR > resolution:
            clock[C_H] = h * FAILED_FACTOR
            counters[REJECTED] += 1
            after_rejection = True
            continue
        if status != OK:
            if status == NON_FINITE and culprit == 0:
                culprit = non_finite_culprit(model, buf, x_new if is_finite(x_new) else x, hamiltonian)
            counters[STATUS] = status
            counters[FAILED_STEP] = counters[STEPS] + 1
            counters[CULPRIT] = culprit
            if out.t[counters[ROWS] - 1] != t_now:  # the last good state was not saved yet
                load(buf, x)
                _save(out, t_now, x, model.H(buf, p), S_x)
            break
        if H_target != anchor:  # the step kept (nearly) its own energy: back along grad H onto the anchor's
            x_new, H_new, S_new, ev = pull_back(model, buf, x_new, H_new, S_new, anchor, max(S_x, S_new),
                                                PULL_BACK_ITER)
            counters[FIELD_EVALUATIONS] += ev
        if control.adaptive:
            clock[C_H] = h * _next_factor(err, clock[C_ERROR], exponent, after_rejection)
            if landing and abs(clock[C_H]) < abs(proposal):  # a step shortened to land says little of the next
                clock[C_H] = proposal
            clock[C_ERROR] = err
        elif landing:
            clock[C_BASE] = target
            clock[C_COUNT] = 0.0
        else:
            clock[C_COUNT] += 1.0
        if clock[C_REACH] < 1.0 and err <= 0.5:  # the anchor's reach grows back while the steps are well inside
            clock[C_REACH] = min(1.0, 2.0 * clock[C_REACH]) if clock[C_REACH] > 0.0 else REACH_MIN
        after_rejection = False
        streak_h = 0.0
        x, comp, S_x, H_x = x_new, comp_new, S_new, H_new
        counters[STEPS] += 1
        clock[C_T] = target if landing else t_now + h
        if landing:
            clock[C_STOP] += 1.0
        if landing or control.save_all:
            _save(out, clock[C_T], x, H_new, S_new)
    state[STATE_X], state[STATE_X + 1], state[STATE_X + 2] = x
    state[STATE_COMP], state[STATE_COMP + 1], state[STATE_COMP + 2] = comp
    state[STATE_S] = S_x

