"""Many trajectories in one compiled call: ``loop.run`` over a range of them, without the GIL.

Each trajectory runs the very step loop ``geomint.solve`` runs (same
function, same arithmetic, and for adaptive runs the same first step), with its own state, workspace, clock,
output rows and counters, and its own parameters and eps when a sweep gives them, so a
trajectory of an ensemble is bit for bit the ``solve`` of its start.  A
failure stops only its own trajectory.  The kernel releases the GIL, so
threads calling it on interleaved trajectories run on every core (numba's
``prange`` cannot take the method and model tuples the step loop needs).
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .control import start
from .layout import C_STOP, OK, STATUS, Model
from .loop import Output, run


@njit(cache=CACHE, nogil=True, error_model="numpy")
def run_batch(
    model,
    params,
    origins,
    eps,
    hamiltonian,
    method,
    control,
    states,
    works,
    clocks,
    stops,
    budget,
    t,
    x,
    H,
    S,
    counters,
    residuals,
    first,
    stride,
):
    """At most ``budget`` attempted steps (``loop.run``) of trajectories ``first, first + stride, ...`` whose
    status is OK and which have stops left, each with its own ``params[i]``, ``origins[i]``, ``eps[i]`` and
    clock ``clocks[i]``.  An adaptive clock whose step ``clocks[i, C_H]`` is 0 starts with
    ``control.first_step``.

    Caller: ``geomint.run.ensemble.solve_ensemble``, which validated everything, runs one thread per stride and
    calls again until no trajectory has stops left.
    """
    for i in range(first, states.shape[0], stride):
        if counters[i, STATUS] != OK or clocks[i, C_STOP] >= stops.shape[0]:
            continue
        own = Model(model.H, model.grad_H, model.S, model.grad_S, model.J, params[i], origins[i])
        start(control, own, eps[i], hamiltonian, states[i, :3], clocks[i], stops[-1])
        out = Output(t[i], x[i], H[i], S[i], counters[i], residuals[i])
        run(own, eps[i], hamiltonian, method, control, states[i], works[i], clocks[i], stops, budget, out)


def empty_outputs(n, rows):
    """Output arrays for ``n`` trajectories of ``rows`` saved states (times and states NaN until written)."""
    return (
        np.full((n, rows), np.nan),
        np.full((n, rows, 3), np.nan),
        np.full((n, rows), np.nan),
        np.full((n, rows), np.nan),
    )
