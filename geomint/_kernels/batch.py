"""Many trajectories in one compiled call: ``loop.run`` over a range of them, without the GIL.

Each trajectory runs the very step loop ``geomint.solve`` runs (same
function, same arithmetic, and for adaptive runs the same first step), with its own state, workspace, clock,
output rows and counters, and its own parameters and eps when a sweep gives them, so a
trajectory of an ensemble is bit for bit the ``solve`` of its start.  A
failure stops only its own trajectory.  The kernel releases the GIL, so
threads calling it on interleaved trajectories run on every core (numba's
``prange`` cannot take the method and model tuples the step loop needs).

The same kernel runs systems in R^3 and in R^n: each trajectory's model is a
``layout.Model`` or a ``layout.ModelN`` and its state a row of 8 or of
``2 n + 2`` floats (``geomint._kernels.state``), chosen by the model's type when
the kernel is compiled, as the loop chooses.
"""

import numpy as np
from numba import njit

from .._cache import CACHE
from .jit import typed_inline
from .layout import C_STOP, OK, STATUS, Model, ModelN
from .loop import Output, run
from .state import _is_n, _typed_n

#: a thread runs this many consecutive trajectories at a time, the threads taking groups in turn: the rows of two
#: threads' trajectories (a clock is 56 bytes, written every step) then share a cache line only where groups meet,
#: instead of at every row, and a sweep ordered by stiffness still spreads over the threads
GROUP = 8


@njit(inline="always")
def _own3(model, params, origin):
    return Model(model.H, model.grad_H, model.S, model.grad_S, model.J, params, origin)


@njit(inline="always")
def _own_n(model, params, origin):
    f = model
    return ModelN(
        f.H, f.grad_H, f.S, f.grad_S, f.P, f.M, params, f.metric, f.direction, origin, f.P_apply, f.M_apply, f.actions
    )


def own_model(model, params, origin):
    """``model`` with a trajectory's ``params`` and ``origin``: a ``layout.Model`` in R^3, a ``layout.ModelN`` (its
    metric and direction kept) in R^n."""
    return _own_n(model, params, origin) if _is_n(model) else _own3(model, params, origin)


@typed_inline(own_model)
def _own_model_typed(model, params, origin):
    if _typed_n(model):
        return lambda model, params, origin: _own_n(model, params, origin)
    return lambda model, params, origin: _own3(model, params, origin)


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
    """At most ``budget`` attempted steps (``loop.run``) of the trajectories in groups ``first, first + stride,
    ...`` (``GROUP`` consecutive trajectories a group) whose status is OK and which have stops left, each with its
    own ``params[i]``, ``origins[i]``, ``eps[i]`` and clock ``clocks[i]``.  An adaptive clock whose step
    ``clocks[i, C_H]`` is 0 starts with ``control.first_step`` (chosen by ``loop.run``, as in ``solve``).

    Caller: ``geomint.run.ensemble.solve_ensemble``, which validated everything, runs one thread per stride and
    calls again until no trajectory has stops left.
    """
    n = states.shape[0]
    for group in range(first * GROUP, n, stride * GROUP):
        for i in range(group, min(group + GROUP, n)):
            if counters[i, STATUS] != OK or clocks[i, C_STOP] >= stops.shape[0]:
                continue
            own = own_model(model, params[i], origins[i])
            out = Output(t[i], x[i], H[i], S[i], counters[i], residuals[i])
            run(own, eps[i], hamiltonian, method, control, states[i], works[i], clocks[i], stops, budget, out)


def empty_outputs(n, rows, dim=3):
    """Output arrays for ``n`` trajectories of ``rows`` saved states in R^dim (times and states NaN until written)."""
    return (
        np.full((n, rows), np.nan),
        np.full((n, rows, dim), np.nan),
        np.full((n, rows), np.nan),
        np.full((n, rows), np.nan),
    )
