"""Events: functions ``g(t, x)`` whose zeros ``geomint.solve(..., events=...)`` locates, as in scipy.

An event is any callable ``g(t, x) -> float`` with two optional attributes,
read as ``scipy.integrate.solve_ivp`` reads them:

* ``terminal``: ``True`` (or a positive integer ``n``) stops the run at the
  first (``n``-th) zero; default ``False``;
* ``direction``: ``> 0`` only zeros where g rises, ``< 0`` where it falls,
  ``0`` (default) both.

After every accepted step ``solve`` evaluates each event at the new state; a
sign change over the step ``[t_n, t_{n+1}]`` is located by Brent's method, to
a few ulps of ``t``, on ``g(s, y(s))`` with ``y(s)`` *a step of the method*
from ``x_n`` landing on ``s``: the zero of the computed solution, as accurate
as the method.  The state recorded at the event, ``x_events``, is that step's
state, so it keeps H and S exactly as every step does.  (Where such a step
fails, or does not show the sign change the accepted step showed, the cubic
Hermite interpolant of the step, ``geomint.results.dense``, is used instead.)  A terminal event ends the run there, with
``status = 1``.

Built-ins: ``relaxed`` (the field has become small: the state has relaxed
onto an equilibrium of H = H0) and ``crossing`` (a function of the state
crosses a value).
"""

from __future__ import annotations

import math
import numbers
from typing import TYPE_CHECKING, cast

import numpy as np

from .._kernels import control as _control
from .._kernels import layout as _layout
from .._user_errors import UserFunctionError
from ..model.system_n import MetriplecticSystemN
from ..results.dense import Hermite
from .chunks import new_output, new_run_state, run_chunk

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable

    import numpy.typing as npt

    from .._kernels.loop import Output
    from ..model.system import MetriplecticSystem

    #: an event: ``g(t, x) -> float``, with optional ``terminal`` and ``direction`` attributes
    Event = Callable[[float, npt.NDArray[np.float64]], float]


def relaxed(system: MetriplecticSystem, tol: float, *, terminal: bool | int = True) -> Event:
    """The event ``|xi(x)|_2 - tol`` falling through zero: the state has relaxed to within ``tol`` (in field
    speed) of an equilibrium.  Terminal by default: ``solve(..., events=relaxed(system, 1e-10))`` stops there.

    Near a hyperbolic equilibrium ``|xi(x)|`` is proportional to the distance to it, so the event time
    grows like ``log(1 / tol) / rate``.
    """
    tol = _positive("tol", tol)

    def event(t: float, x: npt.NDArray[np.float64]) -> float:
        return float(np.linalg.norm(system.xi(x))) - tol

    event.terminal = terminal
    event.direction = -1.0
    event.__name__ = f"relaxed(tol={tol:g})"
    return event


def crossing(
    function: Callable[[npt.NDArray[np.float64]], float],
    value: float = 0.0,
    *,
    direction: float = 0.0,
    terminal: bool | int = False,
) -> Event:
    """The event ``function(x) - value``: a function of the state (``system.S``, ``lambda x: x[2]`` ...)
    crossing ``value``; ``direction`` and ``terminal`` as above."""
    if not callable(function):
        raise TypeError(f"`function` must be callable as function(x); got {function!r}.")
    value = _real("value", value)

    def event(t: float, x: npt.NDArray[np.float64]) -> float:
        return float(function(x)) - value

    event.terminal = terminal
    event.direction = _real("direction", direction)
    event.__name__ = f"crossing({getattr(function, '__name__', 'function')}, {value!r})"
    return event


def _real(name, value):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"`{name}` must be a finite real number; got {value!r}.")
    return float(value)


def _positive(name, value):
    value = _real(name, value)
    if not value > 0.0:
        raise ValueError(f"`{name}` must be > 0; got {value!r}.")
    return value


class Events:
    """The events of one run, validated, with what has been found so far (``geomint.solve``'s helper).

    ``events``: a callable or a sequence of callables (the ``events`` argument of ``solve``).
    """

    def __init__(self, events: Event | Iterable[Event]) -> None:
        functions = [events] if callable(events) else events
        if isinstance(functions, (str, bytes)) or not hasattr(functions, "__iter__"):
            raise TypeError(f"`events` must be a callable g(t, x) or a sequence of them; got {events!r}.")
        functions = list(functions)
        self.functions, self.limits, self.directions = [], [], []
        for k, g in enumerate(functions):
            if not callable(g):
                raise TypeError(f"`events` must be callables g(t, x); item {k} is {g!r}.")
            terminal = getattr(g, "terminal", False)
            if isinstance(terminal, (bool, np.bool_)):
                limit = 1 if terminal else 0
            # (typeshed's numbers.Integral declares only < and <=; an Integral compares with an int at run time)
            elif isinstance(terminal, numbers.Integral) and terminal >= 1:  # pyright: ignore[reportOperatorIssue]
                limit = int(terminal)
            else:
                raise ValueError(f"`events[{k}].terminal` must be True, False or an integer >= 1; got {terminal!r}.")
            direction = getattr(g, "direction", 0.0)
            if (
                isinstance(direction, (bool, np.bool_))
                or not isinstance(direction, numbers.Real)
                or not math.isfinite(direction)
            ):
                raise ValueError(f"`events[{k}].direction` must be a finite real number; got {direction!r}.")
            self.functions.append(g)
            self.limits.append(limit)
            self.directions.append(float(direction))
        self.t_events = [[] for _ in self.functions]
        self.x_events = [[] for _ in self.functions]
        self._counts = [0] * len(self.functions)
        self._last = None
        self._ended_at_zero: set[int] = set()  # events recorded at the last step's end, where g was exactly 0

    def _values(self, t, x):
        values = np.empty(len(self.functions))
        for k, g in enumerate(self.functions):
            try:
                value = g(t, x)
            except Exception as exc:
                raise UserFunctionError(
                    f"events[{k}] ({_name(g)})", np.asarray(x).tolist(), exc, f"(t = {float(t)!r})"
                ) from exc
            try:
                values[k] = value
            except (TypeError, ValueError):
                values[k] = math.nan  # not a number: refused below, by what it is
            if not math.isfinite(values[k]) or isinstance(value, (bool, np.bool_)) or value is None:
                raise ValueError(
                    f"`events[{k}]` ({_name(g)}) returned {value!r} at t = {float(t)!r}, "
                    f"x = {np.asarray(x).tolist()}; it must return a finite real number."
                )
        return values

    def scan(
        self, system: MetriplecticSystem, step_data: tuple, out: Output, start: int, stop: int, anchor: float
    ) -> tuple[int, float, npt.NDArray[np.float64]] | None:
        """Look for zeros over the steps ending at rows ``start + 1 .. stop - 1`` of the run's output ``out``
        (``loop.Output``) of ``step_data`` on ``system``, whose steps keep the energy ``anchor``.

        Zeros are located on steps of the method from the step's start (``land``), else on the step's
        cubic Hermite interpolant (``step_interpolant``).  Records every zero found; returns
        ``(n, t_event, x_event)`` of the zero that ends the run (a terminal event's last allowed
        occurrence), or None.
        """
        if not self.functions:
            return None
        t, x = out.t, out.x

        def interpolant(n):
            return step_interpolant(system, out, n)

        def landed(n, s):
            return land(system, step_data, out, n, s, anchor)

        if self._last is None:
            self._last = self._values(t[start], x[start])
        for n in range(start, stop - 1):
            new = self._values(t[n + 1], x[n + 1])
            old, self._last = self._last, new
            up = (old <= 0) & (new >= 0)
            down = (old >= 0) & (new <= 0)
            hits = []
            # a zero exactly at a step's end is the next step's start too: found on the first of the two only
            counted, self._ended_at_zero = self._ended_at_zero, set()
            for k, direction in enumerate(self.directions):
                wanted = (
                    (up[k] and direction > 0) or (down[k] and direction < 0) or ((up[k] or down[k]) and direction == 0)
                )
                if wanted and not (old[k] == 0 and (new[k] == 0 or k in counted)):
                    hits.append(
                        (self._root(k, t[n], t[n + 1], old[k], new[k], interpolant(n), lambda s, n=n: landed(n, s)), k)
                    )
                    if new[k] == 0:
                        self._ended_at_zero.add(k)
            hits.sort(reverse=bool(t[n + 1] < t[n]))
            for t_event, k in hits:
                state = landed(n, t_event)
                if state is None:
                    state = interpolant(n)(t_event)
                self.t_events[k].append(t_event)
                self.x_events[k].append(np.asarray(state, dtype=np.float64))
                self._counts[k] += 1
                if self.limits[k] and self._counts[k] >= self.limits[k]:
                    return n, t_event, self.x_events[k][-1]
        return None

    def _root(self, k, t0, t1, g0, g1, u, land):
        """The zero of event ``k`` on the step ``[t0, t1]`` (values ``g0``, ``g1`` at its ends).

        Brent's method on ``g(s, y(s))``, ``y(s)`` one step of the method from the step's start landing
        on ``s``: the zero of the computed solution, as accurate as the method (a cubic interpolant
        would limit a high-order method).  Where such a step fails or the sign change is not seen
        through it, on the interpolant ``u``."""
        if g0 == 0.0:
            return float(t0)
        if g1 == 0.0:
            return float(t1)
        from scipy.optimize import brentq  # here: importing it costs ~0.5 s at ``import geomint``

        g = self.functions[k]
        lo, hi = min(t0, t1), max(t0, t1)
        tolerances = {"xtol": 4 * np.finfo(float).eps * max(abs(lo), abs(hi)), "rtol": 4 * np.finfo(float).eps}

        def stepped(s):
            y = land(s)
            if y is None:
                raise ArithmeticError
            return float(g(s, y))

        try:
            return float(cast(float, brentq(stepped, lo, hi, **tolerances)))  # a float without full_output
        except (ValueError, ArithmeticError):
            return float(cast(float, brentq(lambda s: float(g(s, u(s))), lo, hi, **tolerances)))

    def arrays(self, dim: int) -> tuple[list[npt.NDArray[np.float64]], list[npt.NDArray[np.float64]]]:
        """``(t_events, x_events)``: per event, an array of times and an ``(m, dim)`` array of states (m = 0
        for an event that never occurred, as scipy's)."""
        return (
            [np.array(ts, dtype=np.float64) for ts in self.t_events],
            [np.array(xs, dtype=np.float64).reshape(len(xs), dim) for xs in self.x_events],
        )


def _name(g):
    return getattr(g, "__name__", type(g).__name__)


def fields(system: MetriplecticSystem, x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The field at each state of ``x``, shape (m, n)."""
    x = np.asarray(x, dtype=np.float64)
    return np.asarray(system.xi(x), dtype=np.float64).reshape(-1, x.shape[-1])


def step_interpolant(system: MetriplecticSystem, out: Output, n: int) -> Callable[[float], npt.NDArray[np.float64]]:
    """The cubic Hermite interpolant on the step from row ``n`` to row ``n + 1``."""
    x = out.x[n : n + 2]
    return Hermite(out.t[n : n + 2], x, fields(system, x)).step(0)


def land(
    system: MetriplecticSystem, step_data: tuple, out: Output, n: int, t: float, anchor: float
) -> npt.NDArray[np.float64] | None:
    """The state one step of the method from row ``n`` of ``out`` lands on at ``t``, the step keeping the energy
    ``anchor`` (None if that step fails): a fixed step landing on the stop ``t``, through the run's loop."""
    if t == out.t[n]:
        return out.x[n].copy()
    one = new_output(2, out.x.shape[1])
    work, state = new_run_state(step_data, out.x[n], isinstance(system, MetriplecticSystemN))
    state[-2] = anchor  # the energy anchor: the run state's last but one entry (``geomint._kernels.state``)
    control = _control.Control(False, t - out.t[n], 1.0, 1.0, math.inf, _layout.NO_ESTIMATE, 1.0, 1.0, False)
    clock = _layout.new_clock(out.t[n])
    run_chunk(system, step_data, control, state, work, clock, np.array([t]), 4, one)
    if one.counters[_layout.STATUS] != _layout.OK or one.counters[_layout.ROWS] != 2:
        return None
    return one.x[1].copy()
