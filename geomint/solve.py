"""``solve``: the one place that validates input and drives the kernels."""

import math
import numbers
import os

import numpy as np

from ._kernels import driver as _driver
from ._kernels import layout as _layout
from .integrators import resolve
from .solution import Solution
from .system import MetriplecticSystem

_FAILURES = {
    _layout.NEWTON_FAILED: "the Newton iteration did not converge",
    _layout.NON_FINITE: "a non-finite value appeared",
    _layout.PROJECTION_FAILED: "the projection found no point of H = H0 that does not raise S",
}
_ADVICE = {
    _layout.NEWTON_FAILED: "A smaller step `h` usually helps; DampedGonzalez() where h eps |grad H|^2 is large.",
    _layout.NON_FINITE: "Check that the system is defined along the trajectory.",
    _layout.PROJECTION_FAILED: "A smaller step `h` keeps the projection's move small.",
}
#: steps per call of the compiled loop: between chunks ``solve`` reports progress
CHUNK = 100_000
#: the most steps one run may take (step indices and counts stay exact in float64 and int64)
MAX_STEPS = 1 << 52


def solve(system, x0, t_span, h, method="gonzalez", save_every=1, progress=None):
    """Integrate ``dx/dt = xi_P + eps xi_g`` with a fixed step.

    Parameters
    ----------
    system : MetriplecticSystem
    x0 : array_like, shape (3,)
        Initial state, finite, with H and S finite there.
    t_span : (t0, t_end)
        Finite real numbers, ``t_end > t0``.  The last step is shortened to land on ``t_end``.
    h : float
        Step size, ``0 < h``, small enough to advance ``t0`` in float64 and at most
        ``2**52`` steps over ``t_span``.
    method : Integrator or str, default "gonzalez"
        An integrator object (``geomint.Gonzalez()``, ``geomint.RK4()``) or its
        short name (``geomint.integrators.INTEGRATORS``).
    save_every : int or None, default 1
        Save every ``save_every``-th state (and always the last); ``None`` keeps
        only the initial and final states (constant memory).
    progress : callable or None
        Called as ``progress(steps_done)`` between chunks of steps; the steps
        themselves run in compiled code with no Python work.

    Returns
    -------
    Solution
        With ``success = False`` and the states up to the failure kept when a
        step fails; never a NaN.

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    >>> sol = geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 10.0), h=0.05)
    >>> sol.success, sol.energy_error < 1e-14, sol.S_rises
    (True, True, 0)
    """
    if not isinstance(system, MetriplecticSystem):
        raise TypeError(f"`system` must be a geomint.MetriplecticSystem; got {type(system).__name__}.")
    if progress is not None and not callable(progress):
        raise TypeError(f"`progress` must be None or a callable taking the steps done; got {progress!r}.")
    integrator = resolve(method)
    if not integrator.whole_field and system.eps != 0.0:
        raise ValueError(
            f"`method` {integrator!r} integrates the {integrator.flows[0]} flow only, so alone it needs eps = 0; got "
            f"eps = {system.eps!r}. Use it inside Strang(...) or on system.with_effects(eps=0)."
        )
    integrator.check_system(system)
    x0 = _check_state(system, x0)
    t0, t_end = _check_span(t_span)
    h = _check_step(h, t0, t_end)
    n_steps = step_count(t0, t_end, h)
    h_last = (t_end - t0) - (n_steps - 1) * h
    save_every = _check_save_every(save_every, n_steps)
    rows = n_steps // save_every + 2
    _check_memory(rows)
    out = _driver.Output(np.empty(rows), np.empty((rows, 3)), np.empty(rows), np.empty(rows),
                         np.zeros(_layout.N_COUNTERS, dtype=np.int64), np.zeros(1))
    method_data = integrator.lower(system)
    work = np.zeros(getattr(method_data, "slots", 1) * _layout.WORK)
    state = np.concatenate([x0, np.zeros(_layout.N_STATE - 3)])
    grid = _driver.Grid(t0, h, n_steps, h_last, save_every)
    counters = out.counters
    for k_begin in range(0, n_steps, CHUNK):
        _driver.integrate(system.model, system.eps, system.hamiltonian, method_data, state, work, k_begin,
                          min(n_steps, k_begin + CHUNK), grid, out)
        if progress is not None:
            progress(int(counters[_layout.STEPS]))
        if counters[_layout.STATUS] != _layout.OK:
            break
    n = int(counters[_layout.ROWS])
    status = int(counters[_layout.STATUS])
    failed = int(counters[_layout.FAILED_STEP]) if status else None
    return Solution(
        t=out.t[:n].copy(), x=out.x[:n].copy(), H=out.H[:n].copy(), S=out.S[:n].copy(),
        success=status == 0, status=status,
        message=_message(status, failed, n, t0, h, counters, out.residual[0], integrator),
        failed_step=failed, n_steps=int(counters[_layout.STEPS]),
        n_newton=int(counters[_layout.NEWTON_ITERATIONS]), nfev=int(counters[_layout.FIELD_EVALUATIONS]),
        method=integrator,
    )


def step_count(t0, t_end, h):
    """Number of fixed steps ``solve`` takes from ``t0`` to ``t_end`` (the last one shortened to land on it)."""
    return max(1, math.ceil((t_end - t0) / h * (1.0 - 4.0 * np.finfo(float).eps)))


def _message(status, failed, rows, t0, h, counters, residual, integrator):
    if status == 0:
        return f"The integration reached t_end in {int(counters[_layout.STEPS])} steps."
    t_from = t0 + (failed - 1) * h
    what = _FAILURES[status]
    culprit = _layout.FUNCTION_NAMES[int(counters[_layout.CULPRIT])]
    if status == _layout.NON_FINITE and culprit:
        what += f" (the user function `{culprit}` returned a non-finite value)"
    elif status == _layout.NEWTON_FAILED:
        what += f" (last Newton correction {residual:.3g})"
    return (
        f"Step {failed} (t = {t_from:.6g} -> {t_from + h:.6g}) failed: {what} with {integrator!r}. "
        f"{rows} saved state{'s' if rows != 1 else ''} up to t = {t_from:.6g} are kept. {_ADVICE[status]}"
    )


def _real(name, value):
    """``value`` as a float; strings, bools and non-numbers are refused, naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"`{name}` must be a real number; got {value!r} ({type(value).__name__}).")
    return float(value)


def _check_state(system, x0):
    if isinstance(x0, (str, bytes)):
        raise TypeError(f"`x0` must be a sequence of 3 real numbers; got {x0!r}.")
    try:
        x = np.array(x0, dtype=np.float64)
    except (TypeError, ValueError):
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
    t0, t_end = (_real("t_span", t) for t in t_span)
    if not (math.isfinite(t0) and math.isfinite(t_end)):
        raise ValueError(f"`t_span` must be finite; got {t_span!r}.")
    if not t_end > t0:
        raise ValueError(f"`t_span` must satisfy t_end > t0 (fixed forward steps); got {t_span!r}.")
    return t0, t_end


def _check_step(h, t0, t_end):
    h = _real("h", h)
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"`h` must be finite and > 0; got {h!r}.")
    steps = (t_end - t0) / h
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
    needed = rows * 6 * 8
    try:
        available = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return
    if needed > available // 2:
        raise ValueError(f"saving {rows} states needs {needed / 2**30:.3g} GiB, more than half this machine's memory "
                         f"({available / 2**30:.3g} GiB); use a larger `save_every` (or None).")
