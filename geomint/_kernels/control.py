"""Where the next step goes: the step-size controllers of the loop, error estimates, error norm, first step.

The controllers (``loop.run`` is compiled once per controller type, so each
compiles only what it uses):

* ``Constant`` (diffrax's ``ConstantStepSize``): fixed steps ``h`` on the grid
  ``t0 + k h``, the last step ``h_last`` landing on ``t_end``; H and S are
  evaluated only at the states saved (and where the step computes them).
* ``Counting``: ``Constant`` steps of a composition whose S rises are counted
  (``geomint.studies.S_rise_statistics``).
* ``Control``: steps that land on each of the ``stops`` in turn (the times of
  ``t_eval``, event landings and ``t_end``): a step that would pass a stop is
  shortened to end on it.  Between stops the step is

  - **adaptive** (``Control.adaptive``): an error estimate ``e`` of the step
    (``Control.estimator``, below) is measured in the norm

        err = sqrt(mean_i (e_i / (atol + rtol max(|x_i|, |x'_i|)))^2)

    (as ``scipy.integrate.solve_ivp``; Dormand-Prince 8(5,3) blends its two
    estimates as Hairer's DOP853 does).  A step with ``err <= 1`` is accepted;
    the next is ``h err^(-0.7/k) err_prev^(0.4/k)``, ``k`` the order of the
    estimate plus one (the PI controller of Hairer & Wanner, *Solving ODEs II*,
    section IV.2, and Gustafsson, ACM TOMS 20 (1994) 496), times ``SAFETY``,
    within a factor ``FAC_MIN..FAC_MAX`` (never growing right after a
    rejection).  A rejected step, or an attempt whose Newton iteration or
    projection failed, is retried shorter; every attempt rejected is counted
    (``layout.REJECTED``).  Only accepted steps are kept, so each keeps H and S
    as the method does.
  - **fixed** (``Control.adaptive`` False): ``h`` from the last stop on, the
    step before a stop shortened to land on it.

**Tolerance proportionality.**  Step doubling of a method of order ``p >= 4``
runs with ``rtol' = rtol^((p+1)/p)`` and ``atol'`` scaled alike
(``proportional_tolerance``), so that the global error follows the tolerance
(docs/design.md, "Step-size control").

**Energy anchor near equilibria.**  A streak of rejections in which the step
has halved but the error norm has not is the anchor's pull (the step keeps
H(x0), which near an equilibrium moves the state along the level set by more
than the tolerance): the controller shortens the anchor's reach
(``layout.C_REACH``, ``on_rejection``) and the loop pulls accepted steps back
onto H(x0) (``composition.pull_back``); the reach grows back after steps with
error norm at most 0.5 (docs/design.md, "Energy anchor near equilibria").

Estimators (``layout``): ``EMBEDDED``, the method's own pair
(``runge_kutta.pair_step``); ``RK4_REFERENCE``, a discrete-gradient step of
order ``p`` against the explicit RK4 step from the same state (its increment
also starts the Newton iteration); ``DOUBLING``, one step of ``h`` against two
of ``h/2`` (``e = (x_2 - x_1) / (2^p - 1)``, Richardson; the two half steps
are kept), which any method can do.

The first step, when not given, is ``first_step``: scipy's rule, compiled, so
that ``solve`` and each trajectory of an ensemble choose the same one.
"""

from collections import namedtuple

import numpy as np
from numba import njit

from .._cache import CACHE
from .composition import composed_step
from .control_n import estimated_by_doubling_n, estimated_discrete_gradient_n, estimated_pair_n, first_step_n
from .field import field
from .jit import hot, inner, typed_inline
from .layout import (
    C_BASE,
    C_COUNT,
    C_ERROR,
    C_H,
    C_REACH,
    C_STOP,
    C_T,
    DOUBLING,
    EPS,
    OK,
    RK4_REFERENCE,
    UNKNOWN,
    ComposedStep,
    DiscreteGradientStep,
    EmbeddedPairStep,
    ModelN,
    RungeKutta4,
    StepResult,
)
from .newton import seed_predictor
from .runge_kutta import pair_step, rk4_increment
from .step import step
from .vec3 import ZERO, is_finite, load, scale, sub

#: fixed steps on the grid ``t0 + k h`` (``h`` signed), ``n_steps`` of them, the last of length ``h_last``;
#: states ``k`` with ``k % save_every == 0`` and the last are saved
Constant = namedtuple("Constant", "t0 h n_steps h_last save_every")
#: ``Constant`` steps of a ``layout.ComposedStep`` whose S rises beyond ``rise_ulps`` ulp are counted
#: (``layout.SUB_STEP_RISES`` ...; the counters array then has ``layout.N_RISE_COUNTERS`` entries)
Counting = namedtuple("Counting", "t0 h n_steps h_last save_every rise_ulps")


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


@hot
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
    e = scale(1.0 / (2.0**control.order - 1.0), sub(r.x, full.x)) if doubling else ZERO
    return StepResult(r.x, r.comp, r.H, r.S, r.status, iterations, evaluations, r.residual, r.culprit), e


@hot
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
    r, e = _steps(
        method,
        control,
        model,
        eps,
        hamiltonian,
        buf,
        x,
        comp,
        anchor,
        S_x,
        h,
        work,
        control.adaptive and not against_rk4,
    )
    if against_rk4:
        e = sub(sub(r.x, x), reference)
        r = StepResult(r.x, r.comp, r.H, r.S, r.status, r.iterations, r.evaluations + 4, r.residual, r.culprit)
    return r, error_norm(e, ZERO, x, r.x, control.rtol, control.atol, False) if control.adaptive else 0.0


@inner
def _estimated_by_doubling(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    r, e = _steps(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work, control.adaptive)
    return r, error_norm(e, ZERO, x, r.x, control.rtol, control.atol, False) if control.adaptive else 0.0


_ESTIMATED = {
    EmbeddedPairStep: _estimated_pair,
    DiscreteGradientStep: _estimated_discrete_gradient,
    RungeKutta4: _estimated_by_doubling,
    ComposedStep: _estimated_by_doubling,
}


#: the estimates in R^n (``control_n``), chosen where the model is a ``layout.ModelN``
_ESTIMATED_N = {
    EmbeddedPairStep: estimated_pair_n,
    DiscreteGradientStep: estimated_discrete_gradient_n,
    RungeKutta4: estimated_by_doubling_n,
    ComposedStep: estimated_by_doubling_n,
}


def estimated_step(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    """One attempt of ``method`` with its error norm (0 without error control): ``(StepResult, err)``."""
    estimates = _ESTIMATED_N if isinstance(model, ModelN) else _ESTIMATED
    return estimates[type(method)](method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work)


@typed_inline(estimated_step)
def _estimated_step_typed(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    impl = (_ESTIMATED_N if model.instance_class is ModelN else _ESTIMATED)[method.instance_class]
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
    f1 = field(
        model,
        eps,
        hamiltonian,
        buf,
        (x[0] + direction * h0 * f0[0], x[1] + direction * h0 * f0[1], x[2] + direction * h0 * f0[2]),
    )
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


# -- the controllers: what the loop asks of each (``loop.run``), chosen by the controller's type -------------------
@njit(inline="always")
def _constant_traits(control):
    return False, True, control.save_every, 1.0, -1.0


@njit(inline="always")
def _counting_traits(control):
    return False, True, control.save_every, 1.0, control.rise_ulps


@njit(inline="always")
def _control_traits(control):
    return control.adaptive, False, 1 if control.save_all else 0, 1.0 / (control.error_order + 1.0), -1.0


@njit(inline="always")
def _constant_now(control, clock):
    return control.t0 + clock[C_COUNT] * control.h


@njit(inline="always")
def _control_now(control, clock):
    return clock[C_T]


@njit(inline="always")
def _constant_propose(control, clock, t_now, target):
    last = clock[C_COUNT] == control.n_steps - 1
    return (control.h_last if last else control.h), last


@njit(inline="always")
def _control_propose(control, clock, t_now, target):
    remaining = target - t_now
    if control.adaptive:
        h = clock[C_H]
        if abs(h) > control.h_max:
            h = np.sign(h) * control.h_max
    else:
        h = clock[C_BASE] + (clock[C_COUNT] + 1.0) * control.h - t_now
    landing = abs(h) >= abs(remaining) * (1.0 - 4.0 * EPS)
    return (remaining if landing else h), landing


@njit(inline="always")
def _constant_attempt(control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    return step(method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work), 0.0, 0, 0


@njit(inline="always")
def _counting_attempt(control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    r, rises, fired = composed_step(
        method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work, control.rise_ulps
    )
    return r, 0.0, rises, fired


@njit(inline="always")
def _control_attempt(control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    r, err = estimated_step(method, control, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work)
    return r, err, 0, 0


@njit(inline="always")
def _constant_accept(control, clock, t_now, h, err, landing, target, exponent, after_rejection):
    k = clock[C_COUNT]
    clock[C_COUNT] = k + 1.0
    if landing:
        clock[C_STOP] += 1.0
        clock[C_T] = control.t0 + (control.n_steps - 1) * control.h + control.h_last
    else:
        clock[C_T] = control.t0 + (k + 1.0) * control.h
    return clock[C_T]


@njit(inline="always")
def _control_accept(control, clock, t_now, h, err, landing, target, exponent, after_rejection):
    if control.adaptive:
        proposal = clock[C_H]
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
    clock[C_T] = target if landing else t_now + h
    if landing:
        clock[C_STOP] += 1.0
    return clock[C_T]


@njit(inline="always")
def _constant_start(control, model, eps, hamiltonian, x0, clock, t_end):
    return False


def any_first_step(model, eps, hamiltonian, x0, t0, t_end, control):
    """``first_step`` in R^3, ``control_n.first_step_n`` in R^n (chosen by the model's type)."""
    chosen = first_step_n if isinstance(model, ModelN) else first_step
    return chosen(model, eps, hamiltonian, x0, t0, t_end, control)


@typed_inline(any_first_step)
def _any_first_step_typed(model, eps, hamiltonian, x0, t0, t_end, control):
    chosen = first_step_n if model.instance_class is ModelN else first_step
    return lambda model, eps, hamiltonian, x0, t0, t_end, control: chosen(
        model, eps, hamiltonian, x0, t0, t_end, control
    )


@inner
def _control_start(control, model, eps, hamiltonian, x0, clock, t_end):
    if control.adaptive and clock[C_H] == 0.0:
        try:
            clock[C_H] = any_first_step(model, eps, hamiltonian, x0, clock[C_T], t_end, control)
        except Exception:  # noqa: BLE001 - an inlined user function raised
            return True
    return False


_CONSTANT = dict(
    traits=_constant_traits,
    now=_constant_now,
    propose=_constant_propose,
    attempt=_constant_attempt,
    accept=_constant_accept,
    start=_constant_start,
)
_CONTROLLERS = {
    Constant: _CONSTANT,
    Counting: dict(_CONSTANT, traits=_counting_traits, attempt=_counting_attempt),
    Control: dict(
        traits=_control_traits,
        now=_control_now,
        propose=_control_propose,
        attempt=_control_attempt,
        accept=_control_accept,
        start=_control_start,
    ),
}


def traits(control):
    """``(adaptive, lazy, save period, PI exponent, rise ulps)``, each a compile-time constant where the
    controller's type decides it: whether the steps are error-controlled; whether H and S are evaluated only at
    the states saved (``Constant``) rather than at every step; accepted steps between saved states besides the
    landings (0: the landings only); ``1 / (order of the estimate + 1)``; the ulps beyond which an S rise is
    counted (``Counting``; -1: not counted)."""
    return _CONTROLLERS[type(control)]["traits"](control)


def now(control, clock):
    """The time of the state (``Constant``: ``t0 + k h``, never accumulated)."""
    return _CONTROLLERS[type(control)]["now"](control, clock)


def propose(control, clock, t_now, target):
    """``(h, landing)``: the step to attempt next, and whether it lands on the stop ``target``."""
    return _CONTROLLERS[type(control)]["propose"](control, clock, t_now, target)


def attempt(control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    """One attempt of ``method``: ``(StepResult, err, sub-steps raising S, safeguard fired)``, ``err`` the error
    norm (0 without error control), the counts 0 but for ``Counting``."""
    return _CONTROLLERS[type(control)]["attempt"](
        control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work
    )


def accept(control, clock, t_now, h, err, landing, target, exponent, after_rejection):
    """Advance ``clock`` past an accepted step of ``h`` and choose the next; returns the new time."""
    return _CONTROLLERS[type(control)]["accept"](
        control, clock, t_now, h, err, landing, target, exponent, after_rejection
    )


def start(control, model, eps, hamiltonian, x0, clock, t_end):
    """Choose the first step (``first_step``) of an adaptive clock that has none (``clock[C_H] == 0``); True where
    an inlined user function raised there (``loop.run`` then fails the first step as one raising in it).  Only the
    ``Control`` controller compiles the choice (and its ``try``)."""
    return _CONTROLLERS[type(control)]["start"](control, model, eps, hamiltonian, x0, clock, t_end)


@typed_inline(traits)
def _traits_typed(control):
    impl = _CONTROLLERS[control.instance_class]["traits"]
    return lambda control: impl(control)


@typed_inline(now)
def _now_typed(control, clock):
    impl = _CONTROLLERS[control.instance_class]["now"]
    return lambda control, clock: impl(control, clock)


@typed_inline(propose)
def _propose_typed(control, clock, t_now, target):
    impl = _CONTROLLERS[control.instance_class]["propose"]
    return lambda control, clock, t_now, target: impl(control, clock, t_now, target)


@typed_inline(attempt)
def _attempt_typed(control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work):
    impl = _CONTROLLERS[control.instance_class]["attempt"]
    return lambda control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work: impl(
        control, method, model, eps, hamiltonian, buf, x, comp, anchor, S_x, h, work
    )


@typed_inline(accept)
def _accept_typed(control, clock, t_now, h, err, landing, target, exponent, after_rejection):
    impl = _CONTROLLERS[control.instance_class]["accept"]
    return lambda control, clock, t_now, h, err, landing, target, exponent, after_rejection: impl(
        control, clock, t_now, h, err, landing, target, exponent, after_rejection
    )


@typed_inline(start)
def _start_typed(control, model, eps, hamiltonian, x0, clock, t_end):
    impl = _CONTROLLERS[control.instance_class]["start"]
    return lambda control, model, eps, hamiltonian, x0, clock, t_end: impl(
        control, model, eps, hamiltonian, x0, clock, t_end
    )


@inner
def on_rejection(clock, h, err, exponent, streak_h, streak_err):
    """An adaptive attempt with ``err > 1`` (or NaN): the next attempt's step in ``clock[C_H]``.  Returns
    ``(streak_h, streak_err)``, the first rejected attempt of the current streak; where the estimate has not
    fallen with the step over the streak (the anchor's pull, module docstring), the anchor's reach is
    shortened and the streak's first step retried."""
    if streak_h == 0.0:
        streak_h, streak_err = h, err
    elif clock[C_REACH] > 0.0 and abs(h) <= 0.5 * abs(streak_h) and err >= 0.5 * streak_err:
        clock[C_REACH] = 0.0 if clock[C_REACH] < 4.0 * REACH_MIN else 0.25 * clock[C_REACH]
        clock[C_H] = streak_h
        return 0.0, streak_err
    factor = SAFETY * err**-exponent if np.isfinite(err) else FAC_MIN
    clock[C_H] = h * max(FAC_MIN, min(1.0, factor))
    return streak_h, streak_err
