"""``solve``: the one place that validates input and drives the kernels."""

import contextlib
import dataclasses
import math
import os
import signal
import threading
import time
import warnings

from pathlib import Path

import numpy as np

from .._kernels import adaptive as _adaptive
from .._kernels import driver as _driver
from .. import _user_errors, _validate
from ..results.dense import Hermite
from .events import Events
from .._files import atomic
from .._kernels import layout as _layout
from ..integrators import DormandPrince853, Gonzalez, Projected, resolve
from ..results.solution import AccuracyWarning, Solution
from ..model.system import MetriplecticSystem

_FAILURES = {
    _layout.NEWTON_FAILED: "the Newton iteration did not converge",
    _layout.NON_FINITE: "a non-finite value appeared",
    _layout.PROJECTION_FAILED: "the projection found no point of H = H0 that does not raise S",
    _layout.STEP_TOO_SMALL: "the error control needed a step below the resolution of t (16 ulp)",
}
_ADVICE = {
    _layout.NEWTON_FAILED: "A smaller step `h` usually helps; DampedGonzalez() where h eps |grad H|^2 is large.",
    _layout.NON_FINITE: "Check that the system is defined along the trajectory.",
    _layout.PROJECTION_FAILED: "A smaller step `h` keeps the projection's move small.",
    _layout.STEP_TOO_SMALL: "Loosen rtol/atol; if the solution is stiff there, DampedGonzalez() takes steps "
                            "limited by accuracy only.",
    _layout.USER_RAISED: "Return NaN where a function is undefined (the step then fails as non-finite), or keep the "
                         "trajectory inside its domain.",
}
#: a vector function returning an array of the wrong shape is read as NaNs (``vec3.as_vector``)
_SHAPE_NOTE = {"grad_H": " or an array of the wrong shape", "grad_S": " or an array of the wrong shape",
               "J/P": " or an array of the wrong shape"}
#: the compiled loop runs in chunks of about CHUNK_SECONDS (between them ``solve`` reports progress and
#: answers Ctrl-C), from FIRST_CHUNK steps up to at most MAX_CHUNK
CHUNK_SECONDS = 0.1
FIRST_CHUNK = 1000
MAX_CHUNK = 10_000_000
#: the most steps one run may take (step indices and counts stay exact in float64 and int64)
MAX_STEPS = 1 << 52
#: scipy's default rtol; atol, when not given, is ``ATOL_PER_RTOL * rtol``: scipy's default 1e-6 at its
#: default rtol, and a floor that moves with rtol, so that rtol alone sets the accuracy
RTOL, ATOL_PER_RTOL = 1e-3, 1e-3
#: adaptive steps with no method named run Gonzalez() at rtol >= LOOSE_RTOL (its error along the trajectory
#: measured 1.3-11 x rtol at 1e-3) and Projected(DormandPrince853()) below it (0.0004-0.1 x rtol, rtol 1e-3 to
#: 1e-10; docs/coming-from-scipy.md)
LOOSE_RTOL = 1e-3
#: a method that controls its error per step (``follows_tolerance`` False) is flagged below this rtol: its error
#: along the trajectory lags as rtol^(p/(p+1)) and was measured beyond 100 x rtol below it
PER_STEP_RTOL_FLOOR = 1e-5
#: fixed steps: a run whose ``|h|`` times the field's local rate exceeds this is flagged (see ``step_ratio``)
STEP_RATIO_LIMIT = 1e3
#: rows an adaptive run starts with (doubled as it needs)
FIRST_ROWS = 1024
#: the statuses of a run that stopped at a terminal event
TERMINATED = 1


def solve(system, x0, t_span, h=None, method=None, save_every=1, progress=None, checkpoint=None, resume=None, *,
          rtol=None, atol=None, first_step=None, max_step=None, t_eval=None, events=None, dense_output=False,
          args=None):
    """Integrate ``dx/dt = xi_P + eps xi_g`` with a fixed step ``h``, or with adaptive steps (``h=None``).

    Parameters
    ----------
    system : MetriplecticSystem
    x0 : array_like, shape (3,)
        Initial state, finite, with H and S finite there.
    t_span : (t0, t_end)
        Finite real numbers, ``t_end != t0``; ``t_end < t0`` integrates backward
        (methods whose steps are sign-agnostic: RK4, the pairs, the
        discrete-gradient family; S then rises as t falls).  The last step is
        shortened to land on ``t_end``.
    h : float or None, default None
        Fixed step size, ``0 < h``, small enough to advance ``t0`` in float64
        and at most ``2**52`` steps over ``t_span``.  ``None``: adaptive steps
        with error control (``rtol``, ``atol``); every accepted step keeps H and
        S as the method does (see ``geomint._kernels.adaptive`` for the
        estimates and the controller).  A step far beyond the dynamics
        (``|h|`` times the field's local rate above ``STEP_RATIO_LIMIT``) is
        run but flagged: ``sol.step_ratio``, ``sol.caveats``, ``message`` and
        an ``AccuracyWarning``.
    method : Integrator, str or None, default None
        An integrator object (``geomint.Gonzalez()``, ``geomint.Projected(geomint.DormandPrince54())``)
        or its short name (``geomint.integrators.INTEGRATORS``).  ``None``:
        ``Gonzalez()`` for fixed steps, backward spans and adaptive steps at
        ``rtol >= 1e-3``; ``Projected(DormandPrince853())`` for adaptive steps
        at a tighter ``rtol`` (``choose_method``).  A named method whose
        adaptive error is not expected to meet ``rtol`` is run and flagged
        (``sol.caveats``, ``message``, an ``AccuracyWarning``).
    save_every : int or None, default 1
        Fixed steps: save every ``save_every``-th state (and always the last).
        Adaptive steps: 1 saves every accepted step.  ``None`` keeps only the
        initial and final states (constant memory).
    progress : callable or None
        Called as ``progress(steps_done)`` between chunks of steps (about 0.1 s
        of work each); the steps themselves run in compiled code with no Python
        work.  Ctrl-C is answered between chunks too: the run stops with
        ``status = 2`` and every state computed so far.
    checkpoint : (path, steps) or None
        Fixed steps without ``t_eval``/``events``/``dense_output``: write the
        run's state to ``path`` (an ``.npz``, written atomically) every
        ``steps`` steps or more, and when Ctrl-C stops the run.
    resume : path or None
        Continue from a checkpoint written by ``solve`` with the same system,
        ``x0``, ``t_span``, ``h``, ``method`` and ``save_every`` (a different
        run is refused), identically, bit for bit, to the run never stopped.
    rtol, atol : float, default 1e-3 and ``1e-3 * rtol`` (adaptive steps only)
        The error of each step, ``e``, is kept to
        ``|e_i| <~ atol + rtol |x_i|`` in the root-mean-square norm, as in scipy.
        ``rtol >= 100 eps``, ``atol >= 0``, not both 0.  ``atol`` not given is
        ``rtol / 1000`` (scipy's 1e-6 at the default rtol), so that rtol alone
        sets the accuracy: with ``method=None`` the error along the
        trajectory is within ``rtol`` (measured 0.0004-0.1 x rtol, rtol 1e-4 to
        1e-10, docs/coming-from-scipy.md).
    first_step, max_step : float or None (adaptive steps only)
        The first step to try (default: chosen from the field, as scipy does)
        and the largest allowed (default: no bound).
    t_eval : array_like or None
        Times at which to return the state, inside ``t_span`` and sorted in the
        direction of integration.  The steps **land on them** (a step that would
        pass one is shortened), so every returned state is a state of the method,
        exact in H and monotone in S; ``sol.t`` is ``t_eval``.
    events : callable or sequence of callables
        ``g(t, x)`` with optional ``terminal`` and ``direction`` attributes, as
        in scipy (``geomint.events``; built-ins ``events.relaxed``,
        ``events.crossing``).  Zeros are located to a few ulps of t on steps of
        the method landing at the trial times, so the state there is a state of
        the method (``geomint.events``); ``sol.t_events``, ``sol.x_events``.  A terminal event stops the
        run (``status = 1``).
    dense_output : bool, default False
        ``sol.sol(t)``: the cubic Hermite interpolant through every accepted
        step (``geomint.dense``), shape (3,) or (3, m) as scipy's.  It is not
        on ``H = H0`` between steps.
    args : sequence of float or None
        The system's ``params`` for this run (as scipy's ``args`` reach
        ``fun``), checked as at construction.

    Returns
    -------
    Solution
        With ``success = False`` and the states up to the failure kept when a
        step fails; never a NaN.  A user function that raises inside a step
        fails that step (``status = -4``, the function named in ``message``).
        A run flagged as inaccurate (``sol.caveats``) keeps ``success = True``:
        every step did keep H and S; the caveat says why the states may not
        follow the trajectory.

    Warns
    -----
    AccuracyWarning
        With each caveat of the run (also in ``sol.caveats`` and ``message``).

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    >>> sol = geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 10.0), h=0.05)
    >>> sol.success, sol.energy_error < 1e-14, sol.S_rises
    (True, True, 0)
    >>> sol = geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 10.0), rtol=1e-8)
    >>> sol.success, sol.energy_error < 1e-14, sol.S_rises, sol.method == geomint.Projected(geomint.DormandPrince853())
    (True, True, 0, True)
    """
    if not isinstance(system, MetriplecticSystem):
        raise TypeError(f"`system` must be a geomint.MetriplecticSystem; got {type(system).__name__}.")
    if progress is not None and not callable(progress):
        raise TypeError(f"`progress` must be None or a callable taking the steps done; got {progress!r}.")
    if args is not None:
        system = _with_args(system, args)
    integrator = choose_method(method, h, rtol, t_span)
    if not integrator.whole_field and system.eps != 0.0:
        raise ValueError(
            f"`method` {integrator!r} integrates the {integrator.flows[0]} flow only, so alone it needs eps = 0; got "
            f"eps = {system.eps!r}. Use it inside Strang(...) or on system.with_effects(eps=0)."
        )
    integrator.check_system(system)
    x0 = _check_state(system, x0)
    t0, t_end = _check_span(t_span)
    method_data = integrator.lower(system)
    check_direction(integrator, method_data, t_span, t0, t_end)
    if not isinstance(dense_output, (bool, np.bool_)):
        raise TypeError(f"`dense_output` must be True or False; got {dense_output!r}.")
    events = None if events is None else Events(events)
    t_eval = None if t_eval is None else _check_t_eval(t_eval, t0, t_end)
    h, control = check_step_or_control(integrator, h, rtol, atol, first_step, max_step, t0, t_end)
    if h is None or t_eval is not None or events is not None or dense_output:
        if checkpoint is not None or resume is not None:
            raise ValueError("`checkpoint` and `resume` serve fixed-step runs without t_eval, events or dense_output; "
                             "give `h` and drop those (or drop checkpoint/resume).")
        sol = _marching(system, integrator, method_data, x0, t0, t_end, h, save_every, progress, control,
                        t_eval, events, dense_output)
    else:
        sol = _fixed(system, integrator, method_data, x0, t0, t_end, h, save_every, progress, checkpoint, resume)
    if h is None:
        caveat = tolerance_caveat(integrator, RTOL if rtol is None else float(rtol), t_end < t0)
        return _flagged(sol, [caveat] if caveat else [])
    ratio, rate = step_ratios(system, integrator, h, x0[None], sol.x_final[None])
    caveat = step_caveat(integrator, h, ratio[0], rate[0])
    return _flagged(sol, [caveat] if caveat else [], step_ratio=float(ratio[0]))


def _flagged(sol, caveats, **fields):
    """``sol`` with its ``caveats`` (each also appended to ``message`` and issued as an ``AccuracyWarning``)."""
    for caveat in caveats:
        warnings.warn(caveat, AccuracyWarning, stacklevel=3)
    message = " ".join([sol.message, *caveats])
    return dataclasses.replace(sol, message=message, caveats=tuple(caveats), **fields)


def choose_method(method, h, rtol, t_span):
    """The integrator of a run: ``method`` resolved or, when it is None, ``Gonzalez()`` for fixed steps,
    backward spans and adaptive steps at ``rtol >= LOOSE_RTOL`` (scipy's default), and
    ``Projected(DormandPrince853())`` for adaptive steps at a tighter ``rtol``: the method measured to meet
    it with H exact and S monotone (docs/coming-from-scipy.md).  Shared by ``solve`` and ``solve_ensemble``."""
    if method is not None:
        return resolve(method)
    try:
        tight = h is None and float(RTOL if rtol is None else rtol) < LOOSE_RTOL and float(t_span[1]) > float(t_span[0])
    except (TypeError, ValueError, LookupError, OverflowError):
        tight = False  # refused by name when validated
    return Projected(DormandPrince853()) if tight else Gonzalez()


def follows_tolerance(integrator):
    """Whether the error along an adaptive run of ``integrator`` follows ``rtol`` (``adaptive`` module
    docstring): an embedded pair's estimate, an exact flow, or step doubling of order ``p >= 4`` (run at a
    tolerance-proportional ``rtol^((p+1)/p)``, ``adaptive.proportional_tolerance``).  Any other estimate
    controls the error per step, and the error along the trajectory lags as ``rtol^(p/(p+1))``."""
    estimator, _ = integrator.error_estimate()
    order = integrator.order
    return estimator == _layout.EMBEDDED or not math.isfinite(order) or (
        estimator == _layout.DOUBLING and order >= 4)


def tolerance_caveat(integrator, rtol, backward=False):
    """Why an adaptive run of ``integrator`` is not expected to meet ``rtol`` (the error along the trajectory
    within 100 rtol), or None: a method that controls its error per step, below ``PER_STEP_RTOL_FLOOR``."""
    if rtol >= PER_STEP_RTOL_FLOOR or follows_tolerance(integrator):
        return None
    p = integrator.order
    advice = ("a backward span allows only methods without an S safeguard: take a fixed step h small enough for "
              "the accuracy needed" if backward else
              "leave `method` unset (Projected(DormandPrince853()) is chosen) or use a projected pair")
    return (f"rtol = {rtol:g} is not expected to be met: {integrator!r} controls its error per step at order "
            f"{p:g}, so its error along the trajectory lags the tolerance as rtol^({p:g}/{p + 1:g}) (measured "
            f"beyond 100 x rtol below rtol = {PER_STEP_RTOL_FLOOR:g}; docs/coming-from-scipy.md). For this "
            f"tolerance with H exact and S monotone, {advice}.")


def _damped(integrator):
    """Whether ``integrator`` or any of its stages damps the dissipative mode (``DampedGonzalez``)."""
    stages = integrator.sub_methods() if hasattr(integrator, "sub_methods") else ()
    return bool(getattr(integrator, "damped", False)) or any(_damped(m) for m in stages)


def local_rate(system, X, conservative=False):
    """The field's local rate at each state of ``X`` (shape (n, 3)): the 2-norm of its Jacobian by central
    differences (6 field evaluations a state, at relative offsets eps^(1/3)); of the conservative part
    ``xi_P`` alone when ``conservative``.  NaN where a user function raises or a value is not finite."""
    X = np.asarray(X, dtype=np.float64)
    n = len(X)
    delta = np.cbrt(np.finfo(float).eps) * np.max(np.abs(X), axis=1)
    delta = np.where(delta > 0.0, delta, np.cbrt(np.finfo(float).eps))
    moves = delta[:, None, None] * np.eye(3)
    points = np.concatenate([X[:, None, :] + moves, X[:, None, :] - moves], axis=1).reshape(-1, 3)
    field = system.xi_P if conservative else system.xi
    try:
        with np.errstate(all="ignore"):
            values = np.asarray(field(points), dtype=np.float64).reshape(n, 6, 3)
            if conservative and not system.hamiltonian:
                values = np.zeros_like(values)
            jacobian = ((values[:, :3] - values[:, 3:]) / (2.0 * delta[:, None, None])).transpose(0, 2, 1)
            rate = np.full(n, np.nan)
            finite = np.all(np.isfinite(jacobian), axis=(1, 2))
            rate[finite] = np.linalg.norm(jacobian[finite], 2, axis=(1, 2))
    except Exception:  # noqa: BLE001 - a user function that raises here leaves the rate unknown, unflagged
        return np.full(n, np.nan)
    return rate


def step_ratios(system, integrator, h, starts, ends):
    """``(ratio, rate)`` per trajectory: ``|h|`` times the larger local rate (``local_rate``; the
    conservative part's for damped methods) at its start and its last state (NaN where neither is known)."""
    rates = local_rate(system, np.concatenate([starts, ends]), _damped(integrator)).reshape(2, -1)  # one call
    known = np.any(np.isfinite(rates), axis=0)
    rate = np.full(rates.shape[1], np.nan)
    rate[known] = np.nanmax(rates[:, known], axis=0)
    return abs(h) * rate, rate


def step_caveat(integrator, h, ratio, rate):
    """The sentence flagging a fixed step ``h`` far beyond the dynamics (``ratio > STEP_RATIO_LIMIT``), or None."""
    if not ratio > STEP_RATIO_LIMIT:
        return None
    part = ("the rate of its conservative part (the damped method damps the dissipative one)" if _damped(integrator)
            else "the field's local rate")
    return (f"The step h = {abs(h):g} is {ratio:.3g} times the time scale of the dynamics ({part}, the norm of "
            f"its Jacobian, is {rate:.3g}; flagged above {STEP_RATIO_LIMIT:g}): every step keeps H and S, but the "
            f"states do not follow the trajectory. Use h of order 1/{rate:.3g} = {1.0 / rate:.3g} or less, or adaptive "
            "steps (h=None).")


def _fixed(system, integrator, method_data, x0, t0, t_end, h, save_every, progress, checkpoint, resume):
    """The fixed-step run on the grid ``t0 + k h`` (``driver.integrate``)."""
    n_steps = step_count(t0, t_end, h)
    h = math.copysign(h, t_end - t0)
    h_last = (t_end - t0) - (n_steps - 1) * h
    save_every = _check_save_every(save_every, n_steps)
    rows = n_steps // save_every + 2
    _check_memory(rows)
    out = _output(rows)
    work = np.zeros(getattr(method_data, "slots", 1) * _layout.WORK)
    state = np.concatenate([x0, np.zeros(_layout.N_STATE - 3)])
    grid = _driver.Grid(t0, h, n_steps, h_last, save_every)
    counters = out.counters
    checkpoint = _check_checkpoint(checkpoint)
    run_id = _run_id(system, x0, t0, t_end, h, save_every, integrator)
    k_begin = 0 if resume is None else _resume(resume, run_id, state, work, out)
    with _user_errors.catching(counters) as raised, _interrupts() as interrupted:
        chunk, checkpointed = FIRST_CHUNK, k_begin
        while k_begin < n_steps and counters[_layout.STATUS] == _layout.OK:
            k_end = min(n_steps, k_begin + chunk)
            started = time.perf_counter()
            _driver.integrate(system.model, system.eps, system.hamiltonian, method_data, state, work, k_begin, k_end,
                              grid, out)
            chunk = _next_chunk(chunk, time.perf_counter() - started)
            k_begin = k_end
            if progress is not None:
                progress(int(counters[_layout.STEPS]))
            going = k_begin < n_steps and counters[_layout.STATUS] == _layout.OK
            if checkpoint and going and (interrupted or k_begin - checkpointed >= checkpoint[1]):
                _write_checkpoint(checkpoint[0], run_id, k_begin, state, work, out)
                checkpointed = k_begin
            if interrupted and going:
                _save_interrupted(system, state, grid.t0 + k_begin * grid.h, out)
    failed = int(counters[_layout.FAILED_STEP])
    return _solution(system, integrator, out, raised, t_from=t0 + (failed - 1) * h, h=h)


def _marching(system, integrator, method_data, x0, t0, t_end, h, save_every, progress, control, t_eval, events,
              dense_output):
    """Adaptive steps (``control`` given) or fixed steps landing on stops (``adaptive.march``)."""
    if save_every is not None and (isinstance(save_every, (bool, np.bool_)) or save_every != 1):
        raise ValueError(f"`save_every` must be 1 or None with adaptive steps (h=None), t_eval, events or dense_output "
                         f"(they keep every step, or the times of t_eval); got {save_every!r}.")
    save_all = events is not None or dense_output or (t_eval is None and save_every is not None)
    stops, control = marching(integrator, h, control, t0, t_end, t_eval, save_all)
    chosen = control.adaptive and control.h == 0.0
    rows = FIRST_ROWS if save_all else len(stops) + 2
    _check_memory(rows)
    out = _output(rows)
    work = np.zeros(getattr(method_data, "slots", 1) * _layout.WORK)
    state = np.concatenate([x0, np.zeros(3), [np.nan, 0.0]])
    counters = out.counters
    terminated = None
    scanned = 0
    model = system.model
    with _user_errors.catching(counters) as raised, _interrupts() as interrupted:
        if chosen:  # a user function raising here fails the first step, as in the loop
            control = control._replace(h=_adaptive.first_step(model, system.eps, system.hamiltonian, x0, t0, t_end,
                                                              control))
        clock = _layout.new_clock(t0, control.h)
        budget = FIRST_CHUNK
        while clock[_layout.C_STOP] < len(stops) and counters[_layout.STATUS] == _layout.OK:
            if counters[_layout.ROWS] == len(out.t):
                out = _grown(out)
            started = time.perf_counter()
            _adaptive.march(model, system.eps, system.hamiltonian, method_data, control, state, work, clock, stops,
                            budget, out)
            budget = _next_chunk(budget, time.perf_counter() - started)
            if progress is not None:
                progress(int(counters[_layout.STEPS]))
            rows = int(counters[_layout.ROWS])
            if events is not None and rows - scanned > 1:
                terminated = events.scan(out.t, out.x, scanned, rows, lambda n: _step_interpolant(system, out, n),
                                         lambda n, t: _land(system, method_data, out, n, t, state))
                scanned = rows - 1
                if terminated is not None:
                    break
            if interrupted and clock[_layout.C_STOP] < len(stops) and counters[_layout.STATUS] == _layout.OK:
                _save_interrupted(system, state, clock[_layout.C_T], out)
    n = int(counters[_layout.ROWS])
    if terminated is not None:
        row, t_event, x_event = terminated
        counters[_layout.ROWS] = row + 1
        _append(system, out, t_event, x_event)
        counters[_layout.STATUS] = TERMINATED
        n = row + 2
    dense = Hermite(out.t[:n].copy(), out.x[:n].copy(), _fields(system, out.x[:n])) if dense_output else None
    if t_eval is not None:
        keep = np.isin(out.t[:n], t_eval)
        if counters[_layout.STATUS] not in (_layout.OK, TERMINATED):
            keep[n - 1] = True  # the last state reached
        out = _driver.Output(*(a[:n][keep] for a in out[:4]), counters, out.residual)
        counters[_layout.ROWS] = int(np.count_nonzero(keep))
    t_events, x_events = events.arrays() if events is not None else (None, None)
    last_good = float(out.t[int(counters[_layout.ROWS]) - 1]) if counters[_layout.STATUS] < 0 else 0.0
    return _solution(system, integrator, out, raised, t_from=last_good, h=float(clock[_layout.C_H]),
                     sol=dense, t_events=t_events, x_events=x_events)


def _solution(system, integrator, out, raised, t_from, h, **extra):
    counters = out.counters
    n = int(counters[_layout.ROWS])
    status = int(counters[_layout.STATUS])
    failed = int(counters[_layout.FAILED_STEP]) if status < 0 else None
    what = _raised_message(system, out.x[n - 1], h, raised) if status == _layout.USER_RAISED else None
    return Solution(
        t=out.t[:n].copy(), x=out.x[:n].copy(), H=out.H[:n].copy(), S=out.S[:n].copy(),
        success=status in (0, TERMINATED), status=status,
        message=_message(status, failed, out.t[:n], t_from, h, counters, out.residual[0], integrator, what),
        failed_step=failed, n_steps=int(counters[_layout.STEPS]),
        n_newton=int(counters[_layout.NEWTON_ITERATIONS]), nfev=int(counters[_layout.FIELD_EVALUATIONS]),
        method=integrator, n_rejected=int(counters[_layout.REJECTED]), **extra,
    )


def _output(rows):
    return _driver.Output(np.empty(rows), np.empty((rows, 3)), np.empty(rows), np.empty(rows),
                          np.zeros(_layout.N_COUNTERS, dtype=np.int64), np.zeros(1))


def _grown(out):
    """``out`` with twice the rows (the rows written so far copied; the same counters array)."""
    rows = len(out.t)
    _check_memory(2 * rows)
    bigger = _output(2 * rows)
    for old, new in zip(out[:4], bigger[:4]):
        new[:rows] = old
    return bigger._replace(counters=out.counters, residual=out.residual)


def _append(system, out, t, x):
    row = int(out.counters[_layout.ROWS])
    if row == len(out.t):
        raise AssertionError("no row left for the event state")  # _marching keeps one: rows are cut first
    out.t[row], out.x[row], out.H[row], out.S[row] = t, x, system.H(x), system.S(x)
    out.counters[_layout.ROWS] = row + 1


def _fields(system, x):
    return np.asarray(system.xi(x), dtype=np.float64).reshape(-1, 3)


def _step_interpolant(system, out, n):
    """The cubic Hermite interpolant on the step from row ``n`` to row ``n + 1``."""
    x = out.x[n:n + 2]
    return Hermite(out.t[n:n + 2], x, _fields(system, x)).step(0)


def _land(system, method_data, out, n, t, run_state):
    """The state one step of the method from row ``n`` lands on at ``t`` (None if that step fails)."""
    if t == out.t[n]:
        return out.x[n].copy()
    one = _output(2)
    state = np.concatenate([out.x[n], np.zeros(3), [run_state[_layout.STATE_ANCHOR], 0.0]])
    control = _adaptive.Control(False, t - out.t[n], 1.0, 1.0, math.inf, _layout.NO_ESTIMATE, 1.0, 1.0, False)
    clock = _layout.new_clock(out.t[n])
    work = np.zeros(getattr(method_data, "slots", 1) * _layout.WORK)
    _adaptive.march(system.model, system.eps, system.hamiltonian, method_data, control, state, work, clock,
                    np.array([t]), 4, one)
    if one.counters[_layout.STATUS] != _layout.OK or one.counters[_layout.ROWS] != 2:
        return None
    return one.x[1].copy()


def _reversible(method_data):
    """Backward steps are the same formulas with ``h < 0``: RK4, the pairs, the discrete-gradient family.
    Projections and the compositions' S safeguard assume S falls along the step."""
    if isinstance(method_data, _layout.EmbeddedPairStep):
        return method_data.projection == _layout.NO_PROJECTION
    return isinstance(method_data, (_layout.RungeKutta4, _layout.DiscreteGradientStep))


def _with_args(system, args):
    values = _validate.reals("args", args)
    if values.shape != system.params.shape:
        raise ValueError(f"`args` must have {system.params.size} values, as the system's params; got {values.size}: "
                         f"{values.tolist()}.")
    return system.with_effects(params=values)


def _check_t_eval(t_eval, t0, t_end):
    values = _validate.reals("t_eval", t_eval)
    if values.size == 0:
        raise ValueError("`t_eval` must hold at least one time; got an empty sequence.")
    lo, hi = min(t0, t_end), max(t0, t_end)
    outside = values[(values < lo) | (values > hi)]
    if outside.size:
        raise ValueError(f"`t_eval` must lie within t_span = ({t0!r}, {t_end!r}); got {float(outside[0])!r}.")
    steps = np.diff(values) * math.copysign(1.0, t_end - t0)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        order = "increasing" if t_end > t0 else "decreasing (t_span runs backward)"
        raise ValueError(f"`t_eval` must be strictly {order}; got {float(values[k])!r} then {float(values[k + 1])!r} at index {k}.")
    _check_memory(values.size + 2)
    return values


def check_direction(integrator, method_data, t_span, t0, t_end):
    """Refuse a backward ``t_span`` for a method that cannot step backward (``_reversible``)."""
    if t_end < t0 and not _reversible(method_data):
        raise ValueError(f"`t_span` = {t_span!r} runs backward, which {integrator!r} cannot: its S safeguard or "
                         "projection keeps S from rising, as S must backward. Use Gonzalez(), another discrete "
                         "gradient, RK4() or a Runge-Kutta pair.")


def marching(integrator, h, control, t0, t_end, t_eval, save_all):
    """``(stops, Control)`` of a run by ``adaptive.march``: it lands on the times of ``t_eval`` after ``t0``
    and on ``t_end``; fixed steps ``h`` from each stop on (``control`` None), or adaptive ones whose first
    step, when not given, is 0 here: chosen by ``adaptive.first_step`` when the run starts."""
    stops = np.array([t for t in (t_eval if t_eval is not None else []) if t != t0] or [t_end], dtype=np.float64)
    if stops[-1] != t_end:
        stops = np.append(stops, t_end)
    if control is None:
        return stops, _adaptive.Control(False, math.copysign(h, t_end - t0), 1.0, 1.0, math.inf, _layout.NO_ESTIMATE,
                                         1.0, float(integrator.order), save_all)
    first = 0.0 if control.h is None else math.copysign(control.h, t_end - t0)
    return stops, control._replace(h=first, save_all=save_all)


def check_step_or_control(integrator, h, rtol, atol, first_step, max_step, t0, t_end):
    """``(h, None)``: a fixed step, validated (no controller setting may come with it); or ``(None, Control)``
    for adaptive steps (``h`` None).  Shared by ``solve`` and ``solve_ensemble``."""
    if h is None:
        return None, _check_control(integrator, rtol, atol, first_step, max_step, t0, t_end)
    given = [name for name, v in (("rtol", rtol), ("atol", atol), ("first_step", first_step),
                                  ("max_step", max_step)) if v is not None]
    if given:
        raise ValueError(f"`h` = {h!r} fixes the step, so `{given[0]}` cannot be given too; pass h=None for "
                         "adaptive steps with rtol/atol.")
    return _check_step(h, t0, t_end), None


def _check_control(integrator, rtol, atol, first_step, max_step, t0, t_end):
    """The controller's settings, validated; the first step is chosen by ``adaptive.first_step`` when not given."""
    rtol = RTOL if rtol is None else _validate.real("rtol", rtol)
    if not (math.isfinite(rtol) and rtol >= 100 * np.finfo(float).eps):
        raise ValueError(f"`rtol` must be finite and >= 100 eps = {100 * np.finfo(float).eps:.3g}; got {rtol!r}.")
    atol = ATOL_PER_RTOL * rtol if atol is None else _validate.real("atol", atol)
    if not (math.isfinite(atol) and atol >= 0.0):
        raise ValueError(f"`atol` must be finite and >= 0; got {atol!r}.")
    span = abs(t_end - t0)
    max_step = math.inf if max_step is None else _validate.real("max_step", max_step)
    if not max_step > 0.0 or math.isnan(max_step):
        raise ValueError(f"`max_step` must be > 0; got {max_step!r}.")
    if first_step is not None:
        first_step = _validate.real("first_step", first_step)
        if not (math.isfinite(first_step) and 0.0 < first_step <= span):
            raise ValueError(f"`first_step` must be > 0 and at most |t_end - t0| = {span!r}; got {first_step!r}.")
        _check_step(first_step, t0, t_end)
    estimator, error_order = integrator.error_estimate()
    scale = _adaptive.proportional_tolerance(estimator, integrator.order, rtol)
    return _adaptive.Control(True, first_step, rtol * scale, atol * scale, max_step, estimator, float(error_order),
                             float(integrator.order), True)


def _check_checkpoint(checkpoint):
    if checkpoint is None:
        return None
    if not (isinstance(checkpoint, (tuple, list)) and len(checkpoint) == 2):
        raise TypeError(f"`checkpoint` must be None or a pair (path, steps); got {checkpoint!r}.")
    path, steps = checkpoint
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"`checkpoint` path must be a str or a path; got {path!r}.")
    if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"`checkpoint` steps must be an integer >= 1; got {steps!r}.")
    return Path(path), int(steps)


def _run_id(system, x0, t0, t_end, h, save_every, integrator):
    """What a checkpoint must match to be resumed: every argument that shapes the run, floats in hex."""
    numbers = [*x0.tolist(), t0, t_end, h, system.eps, *system.params.tolist()]
    return (f"{system!r} hamiltonian={system.hamiltonian} {integrator!r} save_every={save_every} "
            + " ".join(float(v).hex() for v in numbers))


_CHECKPOINT_ARRAYS = ("state", "work", "counters", "residual")


def _write_checkpoint(path, run_id, k_begin, state, work, out):
    rows = int(out.counters[_layout.ROWS])
    with atomic(path) as temporary:
        np.savez(temporary, run_id=np.array(run_id), k_begin=np.array(k_begin), state=state, work=work,
                 counters=out.counters, residual=out.residual, t=out.t[:rows], x=out.x[:rows], H=out.H[:rows],
                 S=out.S[:rows])


def _resume(path, run_id, state, work, out):
    """Load a checkpoint into the run's arrays; returns the step to continue from."""
    try:
        with np.load(path, allow_pickle=False) as data:
            saved = {key: data[key] for key in data.files}
    except (OSError, ValueError) as exc:
        raise ValueError(f"`resume` {str(path)!r}: not a readable checkpoint ({exc}).") from None
    if "run_id" not in saved or str(saved["run_id"]) != run_id:
        raise ValueError(f"`resume` {str(path)!r} was written by another run; resume with the same system, x0, "
                         "t_span, h, method and save_every.")
    rows = int(saved["counters"][_layout.ROWS])
    for name, array in (("state", state), ("work", work), ("counters", out.counters), ("residual", out.residual)):
        array[:] = saved[name]
    for name in ("t", "x", "H", "S"):
        getattr(out, name)[:rows] = saved[name]
    return int(saved["k_begin"])


def _next_chunk(chunk, seconds):
    """Steps for the next call of the compiled loop: about ``CHUNK_SECONDS`` of work, so progress reports and
    Ctrl-C are answered within that time whatever a step costs."""
    if seconds <= 0.0:
        return min(MAX_CHUNK, 4 * chunk)
    return int(min(MAX_CHUNK, 4 * chunk, max(FIRST_CHUNK, chunk * CHUNK_SECONDS / seconds)))


@contextlib.contextmanager
def _interrupts():
    """Ctrl-C (SIGINT) sets a flag read between chunks instead of raising in the middle of the run.

    Only in the main thread and only where Python's own handler is installed (a caller that
    handles SIGINT itself keeps it); the previous handler is restored on exit.
    """
    flag = []
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield flag
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: flag.append(signum))
    try:
        yield flag
    finally:
        signal.signal(signal.SIGINT, previous)


def _save_interrupted(system, state, t, out):
    """Stop at time ``t``: the state reached is saved as the last row and the run marked interrupted."""
    counters = out.counters
    row = int(counters[_layout.ROWS])
    if out.t[row - 1] != t:
        x = state[_layout.STATE_X:_layout.STATE_X + 3].copy()
        out.t[row], out.x[row], out.H[row], out.S[row] = t, x, system.H(x), state[_layout.STATE_S]
        counters[_layout.ROWS] = row + 1
    counters[_layout.STATUS] = _layout.INTERRUPTED


def _raised_message(system, x, h, raised):
    """Which user function raised during the failed step from ``x``: named from the frames numba keeps in the
    exception's traceback, else found by calling the functions again where the step evaluates them (at ``x`` and
    along the explicit Euler move ``x + s h xi(x)``)."""
    error = raised[0] if raised else None
    f = system.functions
    poisson = "P" if f.poisson_form == "matrix" else "J"
    name = error and _user_errors.raised_by(
        error, {"H": f.H, "grad_H": f.grad_H, "S": f.S, "grad_S": f.grad_S, poisson: f.poisson})
    if name:
        return f"the user function `{name}` raised {error!r}"
    points = [x]
    try:
        move = h * system.xi(x)
        points += [x + 0.5 * move, x + move]
    except Exception:  # noqa: BLE001 - the search below reports x itself
        pass
    for point in points:
        found = system.raising_function(point)
        if found is not None:
            return f"the user function `{found[0]}` raised {found[1]!r} (at x = {point.tolist()})"
    return (f"a user function raised {error!r} at a point of the step (none of H, grad_H, S, grad_S, {poisson} raises "
            f"at the step's start x = {x.tolist()})")


def step_count(t0, t_end, h):
    """Number of fixed steps ``solve`` takes from ``t0`` to ``t_end`` (the last one shortened to land on it)."""
    return max(1, math.ceil(abs((t_end - t0) / h) * (1.0 - 4.0 * np.finfo(float).eps)))


def _message(status, failed, t, t_from, h, counters, residual, integrator, what=None):
    rows = len(t)
    steps = int(counters[_layout.STEPS])
    rejected = int(counters[_layout.REJECTED])
    tried = f" ({rejected} rejected)" if rejected else ""
    if status == _layout.OK:
        return f"The integration reached t_end in {steps} steps{tried}."
    if status == TERMINATED:
        return f"A termination event occurred at t = {float(t[-1])!r}, after {steps} steps{tried}."
    if status == _layout.INTERRUPTED:
        return (f"Interrupted (SIGINT) after {steps} steps, at t = {t[-1]:.6g}; the {rows} states saved "
                "so far are kept, the last one is the state reached.")
    what = what or _FAILURES[status]
    culprit = _layout.FUNCTION_NAMES[int(counters[_layout.CULPRIT])]
    if status == _layout.NON_FINITE and culprit:
        what += f" (the user function `{culprit}` returned a non-finite value{_SHAPE_NOTE.get(culprit, '')})"
    elif status == _layout.NEWTON_FAILED:
        what += f" (last Newton correction {residual:.3g})"
    return (
        f"Step {failed} (t = {t_from:.6g} -> {t_from + h:.6g}) failed: {what} with {integrator!r}. "
        f"{rows} saved state{'s' if rows != 1 else ''} up to t = {t_from:.6g} are kept. {_ADVICE[status]}"
    )


def _check_state(system, x0):
    if isinstance(x0, (str, bytes)):
        raise TypeError(f"`x0` must be a sequence of 3 real numbers; got {x0!r}.")
    try:
        x = np.array(x0, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"`x0` must be a sequence of 3 real numbers; got {x0!r}.") from None
    if np.asarray(x0).dtype.kind not in "iuf":
        raise TypeError(f"`x0` must be a sequence of 3 real numbers; got {x0!r}.")
    if x.shape != (3,):
        raise ValueError(f"`x0` must have shape (3,); got shape {x.shape}.")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"`x0` must be finite; got {x.tolist()}.")
    H0, S0 = system.H(x), system.S(x)
    if not (np.isfinite(H0) and np.isfinite(S0)):
        raise ValueError(f"H and S must be finite at `x0`; at x0 = {x.tolist()} H = {H0!r}, S = {S0!r}.")
    return x


def _check_span(t_span):
    if isinstance(t_span, (str, bytes)) or np.ndim(t_span) != 1 or len(t_span) != 2:
        raise ValueError(f"`t_span` must be a pair (t0, t_end) of real numbers; got {t_span!r}.")
    t0, t_end = (_validate.real("t_span", t) for t in t_span)
    if not (math.isfinite(t0) and math.isfinite(t_end)):
        raise ValueError(f"`t_span` must be finite; got {t_span!r}.")
    if t_end == t0:
        raise ValueError(f"`t_span` must satisfy t_end != t0; got {t_span!r}.")
    return t0, t_end


def _check_step(h, t0, t_end):
    h = _validate.real("h", h)
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"`h` must be finite and > 0; got {h!r}.")
    steps = abs(t_end - t0) / h
    if not steps <= MAX_STEPS:
        raise ValueError(f"`h` = {h!r} needs {steps:.3g} steps over t_span = ({t0!r}, {t_end!r}); at most 2**52 are "
                         "allowed. Use a larger `h` or a shorter span.")
    if t0 + h == t0 or t_end - h == t_end:
        raise ValueError(f"`h` = {h!r} cannot advance the time {max(abs(t0), abs(t_end))!r} in float64; use a larger `h` "
                         "or shift t_span towards 0.")
    return h


def _check_save_every(save_every, n_steps):
    if save_every is None:
        return n_steps
    if isinstance(save_every, (bool, np.bool_)) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise ValueError(f"`save_every` must be an integer >= 1 or None; got {save_every!r}.")
    return int(min(save_every, n_steps))


def _check_memory(rows):
    """Refuse up front a run whose saved states would not fit in memory."""
    problem = _validate.memory_problem(rows * 6 * 8)
    if problem:
        raise ValueError(f"saving {rows} states {problem}; use a larger `save_every` (or None).")
