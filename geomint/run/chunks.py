"""The compiled loop called in timed chunks: between chunks ``solve`` reports progress and answers Ctrl-C.

``run_chunk`` is the one call of ``geomint._kernels.loop.run`` from Python for a single trajectory (``solve``'s
runs and the landing steps of ``events``); ``next_chunk`` sizes the next chunk to about ``CHUNK_SECONDS``.
"""

from __future__ import annotations

import _signal  # pyright: ignore[reportMissingImports]  # the C module under signal (no stub)
import threading
import time
from typing import TYPE_CHECKING

import numpy as np

from .._kernels import control_n as _control_n
from .._kernels import layout as _layout
from .._kernels import loop as _loop
from .._kernels import step_n as _step_n

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

#: the compiled loop runs in chunks of about CHUNK_SECONDS (between them ``solve`` reports progress and
#: answers Ctrl-C), from FIRST_CHUNK steps up to at most MAX_CHUNK
CHUNK_SECONDS = 0.1


FIRST_CHUNK = 1000


MAX_CHUNK = 10_000_000


def new_output(rows: int, dim: int = 3) -> _loop.Output:
    return _loop.Output(
        np.empty(rows),
        np.empty((rows, dim)),
        np.empty(rows),
        np.empty(rows),
        np.zeros(_layout.N_COUNTERS, dtype=np.int64),
        np.zeros(1),
    )


def next_chunk(chunk: int, seconds: float) -> int:
    """Steps for the next call of the compiled loop: about ``CHUNK_SECONDS`` of work, so progress reports and
    Ctrl-C are answered within that time whatever a step costs."""
    if seconds <= 0.0:
        return min(MAX_CHUNK, 4 * chunk)
    return int(min(MAX_CHUNK, 4 * chunk, max(FIRST_CHUNK, chunk * CHUNK_SECONDS / seconds)))


def interrupts() -> _Interrupts:
    """Ctrl-C (SIGINT) sets a flag read between chunks instead of raising in the middle of the run: the block's
    value, a list that holds the signal once it came.

    Only in the main thread and only where Python's own handler is installed (a caller that
    handles SIGINT itself keeps it); the previous handler is restored on exit.
    """
    return _Interrupts()


class _Interrupts:
    """``interrupts``'s block (a class: entered and left at every ``solve``, where a generator costs more)."""

    __slots__ = ("flag", "previous")

    def __enter__(self) -> list[int]:
        self.flag: list[int] = []
        self.previous = None
        # ``_signal``, the C module under ``signal``: the same handlers, without the wrapper's conversion of each to
        # an enum (a third of a short run's fixed cost went there)
        if (
            threading.current_thread() is threading.main_thread()
            and _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler
        ):
            self.previous = _signal.signal(_signal.SIGINT, self._received)
        return self.flag

    def _received(self, signum: int, frame: object) -> None:
        self.flag.append(signum)

    def __exit__(self, *exc_info: object) -> None:
        if self.previous is not None:
            _signal.signal(_signal.SIGINT, self.previous)


def save_interrupted(system: MetriplecticSystem, state: npt.NDArray[np.float64], t: float, out: _loop.Output) -> None:
    """Stop at time ``t``: the state reached is saved as the last row and the run marked interrupted."""
    counters = out.counters
    row = int(counters[_layout.ROWS])
    if out.t[row - 1] != t:
        x = state[: out.x.shape[1]].copy()
        out.t[row], out.x[row], out.H[row], out.S[row] = t, x, system.H(x), state[_layout.STATE_S]
        counters[_layout.ROWS] = row + 1
    counters[_layout.STATUS] = _layout.INTERRUPTED


def new_run_state(
    step_data: tuple, x0: npt.NDArray[np.float64], rn: bool = False
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``(work, state)`` of a run from ``x0``: the method's workspace, and the state with no compensation yet, the
    energy anchor to be taken at ``x0`` (NaN) and S unknown (``geomint._kernels.state``); ``rn``: a system of
    the R^n engine (``MetriplecticSystemN``, n = 3 too), whose workspace is ``step_n``'s."""
    n = len(x0)
    work = np.zeros(workspace_size(step_data, n, rn))
    state = np.zeros(2 * n + 2)
    state[:n] = x0
    state[2 * n] = np.nan
    return work, state


def workspace_size(step_data: tuple, n: int, rn: bool) -> int:
    """Floats of a run's workspace: in R^3 ``slots`` of ``layout.WORK``; in R^n (``rn``) a ``step_n`` slot per
    sub-step position of a composition (one otherwise) and the adaptive controller's vectors (``control_n``)."""
    if not rn:
        return getattr(step_data, "slots", 1) * _layout.WORK
    slots = step_data.slots if isinstance(step_data, _layout.ComposedStep) else 1
    # the kernels' jitted function run as the Python it is written in: no compilation in a process that asks
    size = getattr(_step_n.work_size, "py_func", _step_n.work_size)
    return int(slots * size(n) + _control_n.CONTROL_VECTORS * n)


def run_chunk(
    system: MetriplecticSystem,
    step_data: tuple,
    control: tuple,
    state: npt.NDArray[np.float64],
    work: npt.NDArray[np.float64],
    clock: npt.NDArray[np.float64],
    stops: npt.NDArray[np.float64],
    budget: int,
    out: _loop.Output,
) -> float:
    """At most ``budget`` attempted steps of the compiled loop (arrays updated in place); returns the seconds
    it took."""
    started = time.perf_counter()
    model = system.inlined_model  # the user's functions inlined where they can be (``geomint.model.handles``)
    _loop.run(model, system.eps, system.hamiltonian, step_data, control, state, work, clock, stops, budget, out)
    return time.perf_counter() - started
