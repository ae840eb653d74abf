"""Many trajectories in one compiled call: ``driver.integrate`` (fixed steps) or ``adaptive.march``
(adaptive steps, or fixed steps landing on given times) over a range of them, without the GIL.

Each trajectory runs the very step loop ``geomint.solve`` runs (same
function, same arithmetic, and for adaptive runs the same first step), with its own state, workspace, output rows and
counters, and its own parameters and eps when a sweep gives them, so a
trajectory of an ensemble is bit for bit the ``solve`` of its start.  A
failure stops only its own trajectory.  The kernel releases the GIL, so
threads calling it on interleaved trajectories run on every core (numba's
``prange`` cannot take the method and model tuples the step loop needs).
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .adaptive import first_step, march
from .driver import Output, integrate
from .layout import C_H, C_STOP, C_T, OK, STATUS, Model


@njit(cache=CACHE, nogil=True, error_model="numpy")
def integrate_batch(model, params, origins, eps, hamiltonian, method, states, works, k_end, grid, t, x, H, S,
                    counters, residuals, first, stride):
    """Steps ``0 .. k_end - 1`` of trajectories ``first, first + stride, ...`` (rows of ``states``, ``works``,
    the outputs, ``params``, ``origins`` and ``eps``) whose status is still OK, each with ``model`` given its
    own ``params[i]``.

    Caller: ``geomint.ensemble.solve_ensemble``, which validated everything and runs one thread per stride.
    """
    for i in range(first, states.shape[0], stride):
        if counters[i, STATUS] != OK:
            continue
        own = Model(model.H, model.grad_H, model.S, model.grad_S, model.J, params[i], origins[i])
        out = Output(t[i], x[i], H[i], S[i], counters[i], residuals[i])
        integrate(own, eps[i], hamiltonian, method, states[i], works[i], 0, k_end, grid, out)


@njit(cache=CACHE, nogil=True, error_model="numpy")
def march_batch(model, params, origins, eps, hamiltonian, method, control, states, works, clocks, stops, budget, t, x,
                H, S, counters, residuals, first, stride):
    """At most ``budget`` attempted steps (``adaptive.march``) of trajectories ``first, first + stride, ...``
    whose status is OK and which have stops left, each with its own ``params[i]``, ``eps[i]`` and clock
    ``clocks[i]``.  A clock whose step ``clocks[i, C_H]`` is 0 starts with ``adaptive.first_step``.

    Caller: ``geomint.ensemble.solve_ensemble``, which validated everything, runs one thread per stride and
    calls again until no trajectory has stops left.
    """
    for i in range(first, states.shape[0], stride):
        if counters[i, STATUS] != OK or clocks[i, C_STOP] >= stops.shape[0]:
            continue
        own = Model(model.H, model.grad_H, model.S, model.grad_S, model.J, params[i], origins[i])
        if clocks[i, C_H] == 0.0:
            clocks[i, C_H] = first_step(own, eps[i], hamiltonian, states[i, :3], clocks[i, C_T], stops[-1], control)
        out = Output(t[i], x[i], H[i], S[i], counters[i], residuals[i])
        march(own, eps[i], hamiltonian, method, control, states[i], works[i], clocks[i], stops, budget, out)


def empty_outputs(n, rows):
    """Output arrays for ``n`` trajectories of ``rows`` saved states (times and states NaN until written)."""
    return (np.full((n, rows), np.nan), np.full((n, rows, 3), np.nan), np.full((n, rows), np.nan),
            np.full((n, rows), np.nan))
