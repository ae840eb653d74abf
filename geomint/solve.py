"""``solve``: the one place that validates input and drives the kernels."""

import math

import numpy as np

from ._kernels import driver as _driver
from ._kernels import steps as _steps
from .integrators import resolve
from .solution import Solution
from .system import MetriplecticSystem

_FAILURES = {
    _steps.NEWTON_FAILED: "the Newton iteration did not converge",
    _steps.NON_FINITE: "the state became non-finite",
}
_ADVICE = {
    _steps.NEWTON_FAILED: "Try a smaller step `h` or a larger `max_newton_iter`.",
    _steps.NON_FINITE: "Try a smaller step `h`; check that the system is defined along the trajectory.",
}


def solve(system, x0, t_span, h, method="gonzalez", save_every=1, progress=None):
    """Integrate ``dx/dt = xi_P + eps xi_g`` with a fixed step.

    Parameters
    ----------
    system : MetriplecticSystem
    x0 : array_like, shape (3,)
        Initial state, finite.
    t_span : (t0, t_end)
        Finite, ``t_end > t0``.  The last step is shortened to land on ``t_end``.
    h : float
        Step size, ``0 < h``.
    method : Integrator or str, default "gonzalez"
        An integrator object (``geomint.Gonzalez()``, ``geomint.RK4()``) or its
        short name.
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
    integrator = resolve(method)
    x0 = _check_state(x0)
    t0, t_end = _check_span(t_span)
    h = _check_step(h)
    n_steps = step_count(t0, t_end, h)
    h_last = (t_end - t0) - (n_steps - 1) * h
    save_every = _check_save_every(save_every, n_steps)
    rows = n_steps // save_every + 2
    out_t, out_x, out_H, out_S = np.empty(rows), np.empty((rows, 3)), np.empty(rows), np.empty(rows)
    counters = np.zeros(_driver.N_COUNTERS, dtype=np.int64)
    residual = np.zeros(1)
    code, coeffs, iopts = integrator.bind(system, x0)
    state = np.concatenate([x0, np.zeros(3), [np.nan]])  # state, its compensation, the energy anchor
    chunk = n_steps if progress is None else max(1, min(n_steps, 100_000))
    integrate = _driver.integrate[system.form]
    for k_begin in range(0, n_steps, chunk):
        k_end = min(n_steps, k_begin + chunk)
        integrate(
            *system.model, system.eps, system.hamiltonian, code, coeffs, iopts, state, k_begin, k_end, t0, h, n_steps, h_last,
            save_every, out_t, out_x, out_H, out_S, counters, residual,
        )
        if progress is not None:
            progress(int(counters[_driver.STEPS]))
        if counters[_driver.STATUS] != 0:
            break
    n = int(counters[_driver.ROWS])
    status = int(counters[_driver.STATUS])
    failed = int(counters[_driver.FAILED_STEP]) if status else None
    return Solution(
        t=out_t[:n].copy(), x=out_x[:n].copy(), H=out_H[:n].copy(), S=out_S[:n].copy(),
        success=status == 0, status=status,
        message=_message(status, failed, t0, h, counters, residual[0], integrator),
        failed_step=failed, n_steps=int(counters[_driver.STEPS]),
        n_newton=int(counters[_driver.NEWTON_ITERATIONS]), nfev=int(counters[_driver.FIELD_EVALUATIONS]),
        method=integrator,
    )


def step_count(t0, t_end, h):
    """Number of fixed steps ``solve`` takes from ``t0`` to ``t_end`` (the last one shortened to land on it)."""
    return max(1, math.ceil((t_end - t0) / h * (1.0 - 4.0 * np.finfo(float).eps)))


def _message(status, failed, t0, h, counters, residual, integrator):
    if status == 0:
        return f"The integration reached t_end in {int(counters[_driver.STEPS])} steps."
    t_from = t0 + (failed - 1) * h
    return (
        f"Step {failed} (t = {t_from:.6g} -> {t_from + h:.6g}) failed: {_FAILURES[status]} "
        f"(last Newton correction {residual:.3g}) with {integrator!r}. The {failed} states up to "
        f"t = {t_from:.6g} are kept. {_ADVICE[status]}"
    )


def _check_state(x0):
    try:
        x = np.array(x0, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"`x0` must be a sequence of 3 real numbers; got {x0!r}.") from None
    if x.shape != (3,):
        raise ValueError(f"`x0` must have shape (3,); got shape {x.shape}.")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"`x0` must be finite; got {x.tolist()}.")
    return x


def _check_span(t_span):
    try:
        t0, t_end = (float(t) for t in t_span)
    except (TypeError, ValueError):
        raise ValueError(f"`t_span` must be a pair (t0, t_end) of real numbers; got {t_span!r}.") from None
    if not (math.isfinite(t0) and math.isfinite(t_end)):
        raise ValueError(f"`t_span` must be finite; got {t_span!r}.")
    if not t_end > t0:
        raise ValueError(f"`t_span` must satisfy t_end > t0 (fixed forward steps); got {t_span!r}.")
    return t0, t_end


def _check_step(h):
    try:
        h = float(h)
    except (TypeError, ValueError):
        raise TypeError(f"`h` must be a real number; got {h!r}.") from None
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"`h` must be finite and > 0; got {h!r}.")
    return h


def _check_save_every(save_every, n_steps):
    if save_every is None:
        return n_steps
    if isinstance(save_every, bool) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise ValueError(f"`save_every` must be an integer >= 1 or None; got {save_every!r}.")
    return int(save_every)
