"""``solve``: the one place that validates input and drives the kernels."""

import contextlib
import math
import os
import signal
import threading
import time

from pathlib import Path

import numpy as np

from ._kernels import driver as _driver
from . import _user_errors, _validate
from .io import atomic
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


def solve(system, x0, t_span, h, method="gonzalez", save_every=1, progress=None, checkpoint=None, resume=None):
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
        Called as ``progress(steps_done)`` between chunks of steps (about 0.1 s
        of work each); the steps themselves run in compiled code with no Python
        work.  Ctrl-C is answered between chunks too: the run stops with
        ``status = 2`` and every state computed so far.
    checkpoint : (path, steps) or None
        Write the run's state to ``path`` (an ``.npz``, written atomically)
        every ``steps`` steps or more (between chunks), and when Ctrl-C stops
        the run.
    resume : path or None
        Continue from a checkpoint written by ``solve`` with the same system,
        ``x0``, ``t_span``, ``h``, ``method`` and ``save_every`` (a different
        run is refused).  The result is identical, bit for bit, to the run
        that was never stopped: the checkpoint holds the state, its
        compensation, the Newton history and every saved row.

    Returns
    -------
    Solution
        With ``success = False`` and the states up to the failure kept when a
        step fails; never a NaN.  A user function that raises inside a step
        fails that step (``status = -4``, the function named in ``message``).

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
                _save_interrupted(system, state, grid, out, k_begin)
    n = int(counters[_layout.ROWS])
    status = int(counters[_layout.STATUS])
    failed = int(counters[_layout.FAILED_STEP]) if status < 0 else None
    what = _raised_message(system, out.x[n - 1], h, raised) if status == _layout.USER_RAISED else None
    return Solution(
        t=out.t[:n].copy(), x=out.x[:n].copy(), H=out.H[:n].copy(), S=out.S[:n].copy(),
        success=status == 0, status=status,
        message=_message(status, failed, n, t0, h, counters, out.residual[0], integrator, what),
        failed_step=failed, n_steps=int(counters[_layout.STEPS]),
        n_newton=int(counters[_layout.NEWTON_ITERATIONS]), nfev=int(counters[_layout.FIELD_EVALUATIONS]),
        method=integrator,
    )


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


def _save_interrupted(system, state, grid, out, k_done):
    """Stop after ``k_done`` steps: the state reached is saved as the last row and the run marked interrupted."""
    counters = out.counters
    row = int(counters[_layout.ROWS])
    t = grid.t0 + k_done * grid.h
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
    return max(1, math.ceil((t_end - t0) / h * (1.0 - 4.0 * np.finfo(float).eps)))


def _message(status, failed, rows, t0, h, counters, residual, integrator, what=None):
    if status == _layout.OK:
        return f"The integration reached t_end in {int(counters[_layout.STEPS])} steps."
    if status == _layout.INTERRUPTED:
        steps = int(counters[_layout.STEPS])
        return (f"Interrupted (SIGINT) after {steps} steps, at t = {t0 + steps * h:.6g}; the {rows} states saved "
                "so far are kept, the last one is the state reached.")
    t_from = t0 + (failed - 1) * h
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
    if not t_end > t0:
        raise ValueError(f"`t_span` must satisfy t_end > t0 (fixed forward steps); got {t_span!r}.")
    return t0, t_end


def _check_step(h, t0, t_end):
    h = _validate.real("h", h)
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
    problem = _validate.memory_problem(rows * 6 * 8)
    if problem:
        raise ValueError(f"saving {rows} states {problem}; use a larger `save_every` (or None).")
