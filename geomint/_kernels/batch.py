"""Many trajectories in one compiled call: ``driver.integrate`` over a range of them, without the GIL.

Each trajectory runs the very step loop ``geomint.solve`` runs (same
function, same arithmetic), with its own state, workspace, output rows and
counters, and its own parameters and eps when a sweep gives them, so a
trajectory of an ensemble is bit for bit the ``solve`` of its start.  A
failure stops only its own trajectory.  The kernel releases the GIL, so
threads calling it on interleaved trajectories run on every core (numba's
``prange`` cannot take the method and model tuples the step loop needs).
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .driver import Output, integrate
from .layout import OK, STATUS, Model


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


def empty_outputs(n, rows):
    """Output arrays for ``n`` trajectories of ``rows`` saved states (times and states NaN until written)."""
    return (np.full((n, rows), np.nan), np.full((n, rows, 3), np.nan), np.full((n, rows), np.nan),
            np.full((n, rows), np.nan))
