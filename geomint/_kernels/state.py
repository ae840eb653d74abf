"""The state as the loop holds it: a 3-tuple in R^3 (the fast path), a view of the run state in R^n.

``loop.run`` is written once for both; what it does with a state goes
through the functions here, each chosen by the type of the state (or of the
model) when the loop is compiled, and by the same test in Python under
``NUMBA_DISABLE_JIT=1``.  In R^3 the state lives in registers as a 3-tuple
(``vec3``); in R^n it is ``state[:n]``, a view of the run state, and a step
writes its result into its workspace (``step_n``), from which ``keep`` copies
it: no allocation per step in either.

The run state is ``x, comp, anchor, S`` (``layout.STATE_*`` in R^3; lengths
n, n, 1, 1 in R^n), so the anchor and S are its last two entries in both.
"""

import numpy as np
from numba import njit, types

from .composition import pull_back
from .field import non_finite_culprit
from .field_n import non_finite_culprit_n
from .jit import inner, typed_inline
from .layout import ModelN
from .step_n import V_C, V_R, to_level, vector
from .vec3 import flush_tiny, is_finite, load, same
from .vecn import all_finite, copy_into

#: the energy anchor and S(x) in the run state: its last two entries
ANCHOR = -2
S_AT = -1


def _is_n(value):
    """A state or model of the R^n path (Python, ``NUMBA_DISABLE_JIT=1``)."""
    return isinstance(value, (np.ndarray, ModelN))


def _typed_n(value):
    """A state or model type of the R^n path (typing)."""
    if isinstance(value, types.Array):
        return True
    return isinstance(value, types.BaseNamedTuple) and getattr(value, "instance_class", None) is ModelN


@njit(inline="always")
def _unpack3(state):
    return (state[0], state[1], state[2]), (state[3], state[4], state[5])


@njit(inline="always")
def _unpack_n(state):
    n = (state.shape[0] - 2) // 2
    return state[:n], state[n : 2 * n]


def start_point(model, state):
    """The state's x in a run state (``state``'s layout): ``state[:3]`` in R^3, ``state[:n]`` in R^n."""
    return state[: (state.shape[0] - 2) // 2] if _is_n(model) else state[:3]


@typed_inline(start_point)
def _start_point_typed(model, state):
    if _typed_n(model):
        return lambda model, state: state[: (state.shape[0] - 2) // 2]
    return lambda model, state: state[:3]


def unpack(model, state):
    """``(x, comp)`` from the run state."""
    return _unpack_n(state) if _is_n(model) else _unpack3(state)


@typed_inline(unpack)
def _unpack_typed(model, state):
    return (lambda model, state: _unpack_n(state)) if _typed_n(model) else (lambda model, state: _unpack3(state))


@njit(inline="always")
def _pack3(state, x, comp):
    state[0], state[1], state[2] = x
    state[3], state[4], state[5] = comp


@njit(inline="always")
def _pack_n(state, x, comp):
    return None  # x and comp are views of the run state, kept in place


def pack(state, x, comp):
    """Write ``x`` and ``comp`` back into the run state."""
    return _pack_n(state, x, comp) if _is_n(x) else _pack3(state, x, comp)


@typed_inline(pack)
def _pack_typed(state, x, comp):
    return (lambda state, x, comp: None) if _typed_n(x) else (lambda state, x, comp: _pack3(state, x, comp))


def point(buf, x):
    """``x`` as the array the user functions take: ``buf`` loaded with it in R^3, ``x`` itself in R^n."""
    return x if _is_n(x) else load(buf, x)


@typed_inline(point)
def _point_typed(buf, x):
    return (lambda buf, x: x) if _typed_n(x) else (lambda buf, x: load(buf, x))


def flushed(x, comp):
    """``vec3.flush_tiny`` in R^3; R^n states are kept as they are."""
    return (x, comp) if _is_n(x) else flush_tiny(x, comp)


@typed_inline(flushed)
def _flushed_typed(x, comp):
    return (lambda x, comp: (x, comp)) if _typed_n(x) else (lambda x, comp: flush_tiny(x, comp))


def finite(x):
    return all_finite(x) if _is_n(x) else is_finite(x)


@typed_inline(finite)
def _finite_typed(x):
    return (lambda x: all_finite(x)) if _typed_n(x) else (lambda x: is_finite(x))


def unchanged(x, y):
    """Whether ``flushed`` left the state as the step gave it."""
    return True if _is_n(x) else same(x, y)


@typed_inline(unchanged)
def _unchanged_typed(x, y):
    return (lambda x, y: True) if _typed_n(x) else (lambda x, y: same(x, y))


def keep(x, x_new):
    """The accepted state: ``x_new`` in R^3; in R^n ``x_new`` (the step's workspace) copied into ``x``."""
    return copy_into(x, x_new) if _is_n(x) else x_new


@typed_inline(keep)
def _keep_typed(x, x_new):
    return (lambda x, x_new: copy_into(x, x_new)) if _typed_n(x) else (lambda x, x_new: x_new)


def save_row(rows, row, x):
    """``rows[row] = x``."""
    for i in range(len(x)):
        rows[row, i] = x[i]


@typed_inline(save_row)
def _save_row_typed(rows, row, x):
    if _typed_n(x):

        def impl(rows, row, x):
            for i in range(x.shape[0]):
                rows[row, i] = x[i]

        return impl

    def impl3(rows, row, x):
        rows[row, 0], rows[row, 1], rows[row, 2] = x

    return impl3


def culprit_of(model, buf, x, hamiltonian):
    """The first user function not finite at ``x`` (``layout.FN_*``), 0 if none is."""
    if _is_n(model):
        return non_finite_culprit_n(model, x, hamiltonian)
    return non_finite_culprit(model, buf, x, hamiltonian)


@typed_inline(culprit_of)
def _culprit_typed(model, buf, x, hamiltonian):
    if _typed_n(model):
        return lambda model, buf, x, hamiltonian: non_finite_culprit_n(model, x, hamiltonian)
    return lambda model, buf, x, hamiltonian: non_finite_culprit(model, buf, x, hamiltonian)


@inner
def _pull_back_n(model, y, H_y, S_y, anchor, S_limit, work):
    """R^n: ``y`` moved back onto ``H = anchor`` along ``Pi_S grad H`` (``step_n.to_level``), in place."""
    n = y.shape[0]
    H_y, ev = to_level(model, y, H_y, anchor, True, vector(work, V_R, n), vector(work, V_C, n), 0.0)
    return y, H_y, model.S(y, model.params), ev + 1


def pulled_back(model, buf, y, H_y, S_y, anchor, S_limit, max_iter, work):
    """``composition.pull_back`` in R^3; ``_pull_back_n`` in R^n (its scratch from the workspace ``work``)."""
    if _is_n(model):
        return _pull_back_n(model, y, H_y, S_y, anchor, S_limit, work)
    return pull_back(model, buf, y, H_y, S_y, anchor, S_limit, max_iter)


@typed_inline(pulled_back)
def _pulled_back_typed(model, buf, y, H_y, S_y, anchor, S_limit, max_iter, work):
    if _typed_n(model):
        return lambda model, buf, y, H_y, S_y, anchor, S_limit, max_iter, work: _pull_back_n(
            model, y, H_y, S_y, anchor, S_limit, work
        )
    return lambda model, buf, y, H_y, S_y, anchor, S_limit, max_iter, work: pull_back(
        model, buf, y, H_y, S_y, anchor, S_limit, max_iter
    )
