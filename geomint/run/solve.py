"""``solve``: check the arguments, lower the method, drive the compiled loop, build the ``Solution``."""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _user_errors, _validate
from .._kernels import layout as _layout
from .._kernels import loop as _loop
from ..integrators import DormandPrince853, Gonzalez, Projected, resolve
from ..model.system import MetriplecticSystem
from ..model.system_n import MetriplecticSystemN
from ..results.dense import Hermite
from ..results.solution import AccuracyWarning, Solution
from .arguments import (
    KEEP_FEWER,
    check_direction,
    check_memory,
    check_span,
    check_state,
    check_t_eval,
    with_args,
)
from .checkpoint import check_checkpoint, resume_checkpoint, run_id, write_checkpoint
from .chunks import FIRST_CHUNK, interrupts, new_output, new_run_state, next_chunk, run_chunk, save_interrupted
from .controller import RTOL, check_step_or_control, constant_grid, landing_control
from .events import Events, fields
from .status import BY_CODE, Status

if TYPE_CHECKING:
    import os
    from collections.abc import Callable, Iterable, Sequence

    import numpy.typing as npt

    from ..integrators import Integrator
    from .events import Event


#: a vector function returning an array of the wrong shape is read as NaNs (``vec3.as_vector``)
_SHAPE_NOTE = {
    "grad_H": " or an array of the wrong shape",
    "grad_S": " or an array of the wrong shape",
    "J/P": " or an array of the wrong shape",
}


#: adaptive steps with no method named run Gonzalez() at rtol >= LOOSE_RTOL and Projected(DormandPrince853())
#: below it, the method that meets a tight rtol with H exact and S monotone (docs/coming-from-scipy.md)
LOOSE_RTOL = 1e-3


#: a method that controls its error per step (``follows_tolerance`` False) is flagged below this rtol: its error
#: along the trajectory lags as rtol^(p/(p+1)), beyond 100 x rtol below it (docs/coming-from-scipy.md)
PER_STEP_RTOL_FLOOR = 1e-5


#: fixed steps: a run whose ``|h|`` times the field's local rate exceeds this is flagged (see ``step_ratio``)
STEP_RATIO_LIMIT = 1e3


#: the outcomes that reached the run's end (``Status.success``)
_REACHED = (Status.OK, Status.TERMINATED)


#: rows an adaptive run starts with (doubled as it needs)
FIRST_ROWS = 1024


#: ``local_rate`` from the dense Jacobian up to this n, from RATE_ITERATIONS power iterates of J v above it
DENSE_RATE_MAX_N = 64
RATE_ITERATIONS = 8


#: the relative offset of ``local_rate``'s central differences, eps^(1/3)
_CBRT_EPS = np.cbrt(np.finfo(float).eps)


def solve(
    system: MetriplecticSystem,
    x0: npt.ArrayLike,
    t_span: tuple[float, float],
    h: float | None = None,
    method: Integrator | str | None = None,
    save_every: int | None = 1,
    progress: Callable[[int], object] | None = None,
    checkpoint: tuple[str | os.PathLike[str], int] | None = None,
    resume: str | os.PathLike[str] | None = None,
    *,
    rtol: float | None = None,
    atol: float | None = None,
    first_step: float | None = None,
    max_step: float | None = None,
    t_eval: npt.ArrayLike | None = None,
    events: Event | Iterable[Event] | None = None,
    dense_output: bool = False,
    args: npt.ArrayLike | None = None,
) -> Solution:
    """Integrate ``dx/dt = xi_P + eps xi_g`` with a fixed step ``h``, or with adaptive steps (``h=None``).

    Parameters
    ----------
    system : MetriplecticSystem
    x0 : array_like, shape (3,)
        Initial state, finite, with H and S finite there.
    t_span : (t0, t_end)
        Finite real numbers, ``t_end != t0``; ``t_end < t0`` integrates backward
        (methods whose steps are sign-agnostic: RK4, the pairs, the
        discrete-gradient family; S then rises as t falls).  The last step is
        shortened to land on ``t_end``.
    h : float or None, default None
        Fixed step size, ``0 < h``, small enough to advance ``t0`` in float64
        and at most ``2**52`` steps over ``t_span``.  ``None``: adaptive steps
        with error control (``rtol``, ``atol``); every accepted step keeps H and
        S as the method does (see ``geomint._kernels.control`` for the
        estimates and the controller).  A step far beyond the dynamics
        (``|h|`` times the field's local rate above ``STEP_RATIO_LIMIT``) is
        run but flagged: ``sol.step_ratio``, ``sol.caveats``, ``message`` and
        an ``AccuracyWarning``.
    method : Integrator, str or None, default None
        An integrator object (``geomint.Gonzalez()``, ``geomint.Projected(geomint.DormandPrince54())``)
        or its short name (``geomint.integrators.INTEGRATORS``).  ``None``:
        ``Gonzalez()`` for fixed steps, backward spans and adaptive steps at
        ``rtol >= 1e-3``; ``Projected(DormandPrince853())`` for adaptive steps
        at a tighter ``rtol`` (``choose_method``).  A named method whose
        adaptive error is not expected to meet ``rtol`` is run and flagged
        (``sol.caveats``, ``message``, an ``AccuracyWarning``).
    save_every : int or None, default 1
        Fixed steps: save every ``save_every``-th state (and always the last).
        Adaptive steps: 1 saves every accepted step.  ``None`` keeps only the
        initial and final states (constant memory).
    progress : callable or None
        Called as ``progress(steps_done)`` between chunks of steps (about 0.1 s
        of work each); the steps themselves run in compiled code with no Python
        work.  Ctrl-C is answered between chunks too: the run stops with
        ``status = 2`` and every state computed so far.
    checkpoint : (path, steps) or None
        Fixed steps without ``t_eval``/``events``/``dense_output``: write the
        run's state to ``path`` (an ``.npz``, written atomically) every
        ``steps`` steps or more, and when Ctrl-C stops the run.
    resume : path or None
        Continue from a checkpoint written by ``solve`` with the same system,
        ``x0``, ``t_span``, ``h``, ``method`` and ``save_every`` (a different
        run is refused), identically, bit for bit, to the run never stopped.
    rtol, atol : float, default 1e-3 and ``1e-3 * rtol`` (adaptive steps only)
        The error of each step, ``e``, is kept to
        ``|e_i| <~ atol + rtol |x_i|`` in the root-mean-square norm, as in scipy.
        ``rtol >= 100 eps``, ``atol >= 0``, not both 0.  ``atol`` not given is
        ``rtol / 1000`` (scipy's 1e-6 at the default rtol), so that rtol alone
        sets the accuracy: with ``method=None`` the error along the
        trajectory is within ``rtol`` (docs/coming-from-scipy.md).
    first_step, max_step : float or None (adaptive steps only)
        The first step to try (default: chosen from the field, as scipy does)
        and the largest allowed (default: no bound).
    t_eval : array_like or None
        Times at which to return the state, inside ``t_span`` and sorted in the
        direction of integration.  The steps **land on them** (a step that would
        pass one is shortened), so every returned state is a state of the method,
        exact in H and monotone in S; ``sol.t`` is ``t_eval``.
    events : callable or sequence of callables
        ``g(t, x)`` with optional ``terminal`` and ``direction`` attributes, as
        in scipy (``geomint.events``; built-ins ``events.relaxed``,
        ``events.crossing``).  Zeros are located to a few ulps of t on steps of
        the method landing at the trial times, so the state there is a state of
        the method (``geomint.events``); ``sol.t_events``, ``sol.x_events``.  A terminal event stops the
        run (``status = 1``).
    dense_output : bool, default False
        ``sol.sol(t)``: the cubic Hermite interpolant through every accepted
        step (``geomint.results.dense``), shape (3,) or (3, m) as scipy's.  It is not
        on ``H = H0`` between steps.
    args : sequence of float or None
        The system's ``params`` for this run (as scipy's ``args`` reach
        ``fun``), checked as at construction.

    Returns
    -------
    Solution
        With ``success = False`` and the states up to the failure kept when a
        step fails; never a NaN.  A user function that raises inside a step
        fails that step (``status = -4``, the function named in ``message``).
        A run flagged as inaccurate (``sol.caveats``) keeps ``success = True``:
        every step did keep H and S; the caveat says why the states may not
        follow the trajectory.

    Warns
    -----
    AccuracyWarning
        With each caveat of the run (also in ``sol.caveats`` and ``message``).

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    >>> sol = geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 10.0), h=0.05)
    >>> sol.success, sol.energy_error < 1e-14, sol.S_rises
    (True, True, 0)
    >>> sol = geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 10.0), rtol=1e-8)
    >>> sol.success, sol.energy_error < 1e-14, sol.S_rises, sol.method == geomint.Projected(geomint.DormandPrince853())
    (True, True, 0, True)
    """
    if not isinstance(system, MetriplecticSystem):
        raise TypeError(f"`system` must be a geomint.MetriplecticSystem; got {type(system).__name__}.")
    if progress is not None and not callable(progress):
        raise TypeError(f"`progress` must be None or a callable taking the steps done; got {progress!r}.")
    if args is not None:
        system = with_args(system, args)
    integrator = choose_method(method, h, rtol, t_span)
    if not integrator.whole_field and system.eps != 0.0:
        raise ValueError(
            f"`method` {integrator!r} integrates the {integrator.flows[0]} flow only, so alone it needs eps = 0; got "
            f"eps = {system.eps!r}. Use it inside Strang(...) or on system.with_effects(eps=0)."
        )
    integrator.check_system(system)
    x0 = check_state(x0, system, functions=False)  # H and S at x0: from the run's first row (_check_start)
    t0, t_end = check_span(t_span)
    step_data = integrator.lower(system)
    if isinstance(system, MetriplecticSystemN):
        check_in_rn(system, integrator, step_data)
    check_direction(integrator, step_data, t_span, t0, t_end)
    dense_output = _validate.flag("dense_output", dense_output)
    events = None if events is None else Events(events)  # pyright: ignore[reportAssignmentType]  # validated
    t_eval = None if t_eval is None else check_t_eval(t_eval, t0, t_end)
    h, control = check_step_or_control(integrator, h, rtol, atol, first_step, max_step, t0, t_end)
    if h is None or t_eval is not None or events is not None or dense_output:
        if checkpoint is not None or resume is not None:
            raise ValueError(
                "`checkpoint` and `resume` serve fixed-step runs without t_eval, events or dense_output; "
                "give `h` and drop those (or drop checkpoint/resume)."
            )
        sol = _to_stops(
            system, integrator, step_data, x0, t0, t_end, h, save_every, progress, control, t_eval, events, dense_output
        )
    else:
        sol = _on_grid(system, integrator, step_data, x0, t0, t_end, h, save_every, progress, checkpoint, resume)
    if h is None:
        caveat = tolerance_caveat(integrator, RTOL if rtol is None else float(rtol), t_end < t0)
        return _flagged(sol, [caveat] if caveat else [])
    ratio, rate = step_ratios(system, integrator, h, x0[None], sol.x_final[None])
    caveat = step_caveat(integrator, h, ratio[0], rate[0])
    return _flagged(sol, [caveat] if caveat else [], step_ratio=float(ratio[0]))


def check_in_rn(system: MetriplecticSystem, integrator: Integrator, step_data: tuple) -> None:
    """Refuse, naming ``method``, what a run in R^n does not offer: the exact flows (R^3 sub-flows),
    Hairer's symmetric projection, the symmetrized Itoh-Abe gradient beyond ``MAX_SYMMETRIZED_DIM``."""
    from .._kernels.step_n import MAX_SYMMETRIZED_DIM

    n = system.dim
    rows: list[tuple[int, int]] = []  # (leaf, kind) of every leaf the method runs
    symmetric = False
    if isinstance(step_data, _layout.DiscreteGradientStep):
        rows.append((_layout.LEAF_DISCRETE_GRADIENT, step_data.kind.code))
    elif isinstance(step_data, _layout.ComposedStep):
        iopts = step_data.iopts
        symmetric = iopts[_layout.P_PROJECTION] == _layout.SYMMETRIC
        for k in range(iopts[_layout.P_STAGES] + 1):
            row = _layout.HEADER + _layout.ROW * k
            rows.append((int(iopts[row + _layout.R_LEAF]), int(iopts[row + _layout.R_KIND])))
    why = None
    if any(leaf not in (_layout.LEAF_RK4, _layout.LEAF_DISCRETE_GRADIENT) for leaf, _ in rows):
        why = "its exact flows are sub-flows of systems in R^3"
    elif symmetric:
        why = "Hairer's symmetric projection is offered in R^3 only; Projected(..., symmetric=False) runs in R^n"
    elif any(leaf == _layout.LEAF_DISCRETE_GRADIENT and kind == _layout.SYMMETRIZED_ITOH_ABE for leaf, kind in rows):
        if n > MAX_SYMMETRIZED_DIM:
            why = (
                f"the symmetrized Itoh-Abe gradient averages over the n! orders of the coordinates, offered for "
                f"n <= {MAX_SYMMETRIZED_DIM} ({math.factorial(n)} orders here); Gonzalez() or AVF() are symmetric "
                "and of order 2"
            )
    if why is not None:
        raise ValueError(f"`method` {integrator!r} does not run on this system in R^{n}: {why}.")


def _flagged(sol, caveats, **fields):
    """``sol`` with its ``caveats`` (each also appended to ``message`` and issued as an ``AccuracyWarning``)."""
    if not (caveats or fields):
        return sol
    for caveat in caveats:
        warnings.warn(caveat, AccuracyWarning, stacklevel=3)
    message = " ".join([sol.message, *caveats])
    return dataclasses.replace(sol, message=message, caveats=tuple(caveats), **fields)


def choose_method(method: Integrator | str | None, h: float | None, rtol: float | None, t_span: Any) -> Integrator:
    """The integrator of a run: ``method`` resolved or, when it is None, ``Gonzalez()`` for fixed steps,
    backward spans and adaptive steps at ``rtol >= LOOSE_RTOL`` (scipy's default), and
    ``Projected(DormandPrince853())`` for adaptive steps at a tighter ``rtol``: the method measured to meet
    it with H exact and S monotone (docs/coming-from-scipy.md).  Shared by ``solve`` and ``solve_ensemble``."""
    if method is not None:
        return resolve(method)
    try:
        tight = h is None and float(RTOL if rtol is None else rtol) < LOOSE_RTOL and float(t_span[1]) > float(t_span[0])
    except (TypeError, ValueError, LookupError, OverflowError):
        tight = False  # refused by name when validated
    return Projected(DormandPrince853()) if tight else Gonzalez()


def follows_tolerance(integrator: Integrator) -> bool:
    """Whether the error along an adaptive run of ``integrator`` follows ``rtol`` (``geomint._kernels.control``
    docstring): an embedded pair's estimate, an exact flow, or step doubling of order ``p >= 4`` (run at a
    tolerance-proportional ``rtol^((p+1)/p)``, ``control.proportional_tolerance``).  Any other estimate
    controls the error per step, and the error along the trajectory lags as ``rtol^(p/(p+1))``."""
    estimator, _ = integrator.error_estimate()
    order = integrator.order
    return estimator == _layout.EMBEDDED or not math.isfinite(order) or (estimator == _layout.DOUBLING and order >= 4)


def tolerance_caveat(integrator: Integrator, rtol: float, backward: bool = False) -> str | None:
    """Why an adaptive run of ``integrator`` is not expected to meet ``rtol`` (the error along the trajectory
    within 100 rtol), or None: a method that controls its error per step, below ``PER_STEP_RTOL_FLOOR``."""
    if rtol >= PER_STEP_RTOL_FLOOR or follows_tolerance(integrator):
        return None
    p = integrator.order
    advice = (
        "a backward span allows only methods without an S safeguard: take a fixed step h small enough for "
        "the accuracy needed"
        if backward
        else "leave `method` unset (Projected(DormandPrince853()) is chosen) or use a projected pair"
    )
    return (
        f"rtol = {rtol:g} is not expected to be met: {integrator!r} controls its error per step at order "
        f"{p:g}, so its error along the trajectory lags the tolerance as rtol^({p:g}/{p + 1:g}) (measured "
        f"beyond 100 x rtol below rtol = {PER_STEP_RTOL_FLOOR:g}; docs/coming-from-scipy.md). For this "
        f"tolerance with H exact and S monotone, {advice}."
    )


def _damped(integrator):
    """Whether ``integrator`` or any of its stages damps the dissipative mode (``DampedGonzalez``)."""
    stages = integrator.sub_methods() if hasattr(integrator, "sub_methods") else ()
    return bool(getattr(integrator, "damped", False)) or any(_damped(m) for m in stages)


def local_rate(system: MetriplecticSystem, X: npt.ArrayLike, conservative: bool = False) -> npt.NDArray[np.float64]:
    """The field's local rate at each state of ``X`` (shape (m, n)): the 2-norm of its Jacobian by central
    differences (2n field evaluations a state, at relative offsets eps^(1/3)); of the conservative part
    ``xi_P`` alone when ``conservative``.  Above n = ``DENSE_RATE_MAX_N``, where the Jacobian costs O(n^2)
    evaluations and memory and its singular values O(n^3), the largest ``|J v|`` over ``RATE_ITERATIONS`` power
    iterates ``v <- J v / |J v|`` from a fixed random unit vector (``_rate_by_products``; a lower bound of the
    2-norm, its spectral radius where J is normal).  NaN where a user function raises or a value is not finite."""
    X = np.asarray(X, dtype=np.float64)
    n, d = X.shape
    delta = _CBRT_EPS * np.max(np.abs(X), axis=1)
    delta = np.where(delta > 0.0, delta, _CBRT_EPS)
    field = system.xi_P if conservative else system.xi
    if conservative and not system.hamiltonian:
        return np.zeros(n)
    if d > DENSE_RATE_MAX_N:
        return _rate_by_products(field, X, delta)
    moves = delta[:, None, None] * np.eye(d)
    points = np.concatenate([X[:, None, :] + moves, X[:, None, :] - moves], axis=1).reshape(-1, d)
    try:
        with np.errstate(all="ignore"):
            values = np.asarray(field(points), dtype=np.float64).reshape(n, 2 * d, d)
            jacobian = ((values[:, :d] - values[:, d:]) / (2.0 * delta[:, None, None])).transpose(0, 2, 1)
            rate = np.full(n, np.nan)
            finite = np.all(np.isfinite(jacobian), axis=(1, 2))
            # the 2-norm as np.linalg.norm(..., 2, axis=(1, 2)) takes it (the largest singular value), without its
            # axis bookkeeping
            rate[finite] = np.max(np.linalg.svd(jacobian[finite], compute_uv=False), axis=-1)
    except Exception:  # noqa: BLE001 - a user function that raises here leaves the rate unknown, unflagged
        return np.full(n, np.nan)
    return rate


def _rate_by_products(field, X, delta):
    """``local_rate`` above ``DENSE_RATE_MAX_N``: per state, the largest ``|J v|`` over the power iterates, each
    ``J v`` by central differences along the unit vector v (2 field evaluations, all states at once)."""
    n, d = X.shape
    v = np.random.default_rng(0).standard_normal(d)
    V = np.tile(v / np.linalg.norm(v), (n, 1))
    rate = np.zeros(n)
    try:
        with np.errstate(all="ignore"):
            for _ in range(RATE_ITERATIONS):
                moves = delta[:, None] * V
                values = np.asarray(field(np.concatenate([X + moves, X - moves])), dtype=np.float64)
                JV = (values[:n] - values[n:]) / (2.0 * delta[:, None])
                size = np.linalg.norm(JV, axis=1)
                rate = np.fmax(rate, size)  # NaN stays NaN only where every iterate's was
                rate[~np.isfinite(size)] = np.nan
                moving = size > 0.0
                V[moving] = JV[moving] / size[moving, None]
    except Exception:  # noqa: BLE001 - as local_rate
        return np.full(n, np.nan)
    return rate


def step_ratios(
    system: MetriplecticSystem,
    integrator: Integrator,
    h: float,
    starts: npt.NDArray[np.float64],
    ends: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``(ratio, rate)`` per trajectory: ``|h|`` times the larger local rate (``local_rate``; the
    conservative part's for damped methods) at its start and its last state (NaN where neither is known)."""
    rates = local_rate(system, np.concatenate([starts, ends]), _damped(integrator)).reshape(2, -1)  # one call
    known = np.any(np.isfinite(rates), axis=0)
    rate = np.full(rates.shape[1], np.nan)
    rate[known] = np.nanmax(rates[:, known], axis=0)
    return abs(h) * rate, rate


def step_caveat(integrator: Integrator, h: float, ratio: float, rate: float) -> str | None:
    """The sentence flagging a fixed step ``h`` far beyond the dynamics (``ratio > STEP_RATIO_LIMIT``), or None."""
    if not ratio > STEP_RATIO_LIMIT:
        return None
    part = (
        "the rate of its conservative part (the damped method damps the dissipative one)"
        if _damped(integrator)
        else "the field's local rate"
    )
    kept = {(True, True): "every step keeps H and S, but ", (True, False): "every step keeps H, but "}.get(
        (integrator.energy_exact, integrator.dissipative), ""
    )
    return (
        f"The step h = {abs(h):g} is {ratio:.3g} times the time scale of the dynamics ({part}, the norm of "
        f"its Jacobian, is {rate:.3g}; flagged above {STEP_RATIO_LIMIT:g}): {kept}the "
        f"states do not follow the trajectory. Use h of order 1/{rate:.3g} = {1.0 / rate:.3g} or less, or adaptive "
        "steps (h=None)."
    )


def _on_grid(system, integrator, step_data, x0, t0, t_end, h, save_every, progress, checkpoint, resume):
    """The fixed-step run on the grid ``t0 + k h`` (a ``control.Constant`` controller)."""
    grid, n_steps = constant_grid(t0, t_end, h, save_every)
    rows = n_steps // grid.save_every + 2
    check_memory(rows)
    out = new_output(rows, len(x0))
    work, state = new_run_state(step_data, x0, isinstance(system, MetriplecticSystemN))
    counters = out.counters
    checkpoint = check_checkpoint(checkpoint)
    identity = run_id(system, x0, t0, t_end, grid.h, grid.save_every, integrator)
    k_begin = 0 if resume is None else resume_checkpoint(resume, identity, state, work, out)
    clock = _layout.new_clock(t0 + k_begin * grid.h, steps=k_begin)
    stops = np.array([t_end])
    with _user_errors.catching(counters) as raised, interrupts() as interrupted:
        chunk, checkpointed = FIRST_CHUNK, k_begin
        while k_begin < n_steps and counters[_layout.STATUS] == _layout.OK:
            k_end = min(n_steps, k_begin + chunk)
            first = counters[_layout.ROWS] == 0  # (a resumed run's start was checked by the run it resumes)
            chunk = next_chunk(
                chunk, run_chunk(system, step_data, grid, state, work, clock, stops, k_end - k_begin, out)
            )
            if first:
                _check_start(system, x0, out)
            k_begin = k_end
            if progress is not None:
                progress(int(counters[_layout.STEPS]))
            going = k_begin < n_steps and counters[_layout.STATUS] == _layout.OK
            if checkpoint and going and (interrupted or k_begin - checkpointed >= checkpoint[1]):
                write_checkpoint(checkpoint[0], identity, k_begin, state, work, out)
                checkpointed = k_begin
            if interrupted and going:
                save_interrupted(system, state, clock[_layout.C_T], out)
    failed = int(counters[_layout.FAILED_STEP])
    return _solution(system, integrator, out, raised, t_from=t0 + (failed - 1) * grid.h, h=grid.h)


def _to_stops(
    system, integrator, step_data, x0, t0, t_end, h, save_every, progress, control, t_eval, events, dense_output
):
    """Adaptive steps (``control`` given) or fixed steps landing on the stops (a ``control.Control`` controller)."""
    if save_every is not None and (isinstance(save_every, (bool, np.bool_)) or save_every != 1):
        raise ValueError(
            f"`save_every` must be 1 or None with adaptive steps (h=None), t_eval, events or dense_output "
            f"(they keep every step, or the times of t_eval); got {save_every!r}."
        )
    save_all = events is not None or dense_output or (t_eval is None and save_every is not None)
    stops, control = landing_control(integrator, h, control, t0, t_end, t_eval, save_all)
    rows = FIRST_ROWS if save_all else len(stops) + 2
    check_memory(rows)
    out = new_output(rows, len(x0))
    work, state = new_run_state(step_data, x0, isinstance(system, MetriplecticSystemN))
    counters = out.counters
    terminated = None
    scanned = 0
    with _user_errors.catching(counters) as raised, interrupts() as interrupted:
        clock = _layout.new_clock(t0, control.h)  # h = 0: the loop chooses the first step (``control.first_step``)
        budget = FIRST_CHUNK
        while clock[_layout.C_STOP] < len(stops) and counters[_layout.STATUS] == _layout.OK:
            if counters[_layout.ROWS] == len(out.t):
                out = _grown(out)
            first = counters[_layout.ROWS] == 0
            budget = next_chunk(budget, run_chunk(system, step_data, control, state, work, clock, stops, budget, out))
            if first:
                _check_start(system, x0, out)
            if progress is not None:
                progress(int(counters[_layout.STEPS]))
            rows = int(counters[_layout.ROWS])
            if events is not None and rows - scanned > 1:
                terminated = events.scan(system, step_data, out, scanned, rows, state[-2])  # the energy anchor
                scanned = rows - 1
                if terminated is not None:
                    break
            if interrupted and clock[_layout.C_STOP] < len(stops) and counters[_layout.STATUS] == _layout.OK:
                save_interrupted(system, state, clock[_layout.C_T], out)
    n = int(counters[_layout.ROWS])
    if terminated is not None:
        row, t_event, x_event = terminated
        counters[_layout.ROWS] = row + 1
        counters[_layout.STEPS] = row + 1  # (events keep every step) the steps to the event's row and onto it
        _append(system, out, t_event, x_event)
        counters[_layout.STATUS] = Status.TERMINATED
        n = row + 2
    dense = Hermite(out.t[:n].copy(), out.x[:n].copy(), fields(system, out.x[:n])) if dense_output else None
    if t_eval is not None:
        keep = np.isin(out.t[:n], t_eval)
        if counters[_layout.STATUS] != _layout.OK:
            keep[n - 1] = True  # a run ended before t_end (failed, terminated, interrupted): the last state reached
        # the six fields: t, x, H, S (unpacked, which pyright cannot count), counters and residual
        out = _loop.Output(*(a[:n][keep] for a in out[:4]), counters, out.residual)  # pyright: ignore[reportCallIssue]
        counters[_layout.ROWS] = int(np.count_nonzero(keep))
    t_events, x_events = events.arrays(len(x0)) if events is not None else (None, None)
    last_good = float(out.t[int(counters[_layout.ROWS]) - 1]) if counters[_layout.STATUS] < 0 else 0.0
    return _solution(
        system,
        integrator,
        out,
        raised,
        t_from=last_good,
        h=float(clock[_layout.C_H]),
        sol=dense,
        t_events=t_events,
        x_events=x_events,
    )


def _check_start(system, x0, out):
    """``check_state``'s test that H and S are finite at ``x0``, made after the run's first chunk on the first
    row, where the loop has evaluated them (two calls of user functions from Python cost a tenth of a short
    ``solve``): where either is not finite, or a user function raised in the chunk, the test is made again as
    before a run, and raises as it would have (the chunk's results are dropped; nothing else has seen them)."""
    if not (math.isfinite(out.H[0]) and math.isfinite(out.S[0])) or out.counters[_layout.RAISED] != 0:
        check_state(x0, system)


def _solution(system, integrator, out, raised, t_from, h, **extra):
    counters = out.counters.tolist()  # Python ints, read once
    n = counters[_layout.ROWS]
    status = BY_CODE[counters[_layout.STATUS]]
    failed = counters[_layout.FAILED_STEP] if status < 0 else None
    what = raised_message(system, out.x[n - 1], h, raised) if status == Status.USER_RAISED else None
    return Solution(
        t=out.t[:n].copy(),
        x=out.x[:n].copy(),
        H=out.H[:n].copy(),
        S=out.S[:n].copy(),
        success=status in _REACHED,
        status=status,
        message=run_message(status, failed, out.t[:n], t_from, h, counters, out.residual[0], integrator, what),
        failed_step=failed,
        n_steps=counters[_layout.STEPS],
        n_newton=counters[_layout.NEWTON_ITERATIONS],
        nfev=counters[_layout.FIELD_EVALUATIONS],
        method=integrator,
        n_rejected=counters[_layout.REJECTED],
        S_direction=float(system.direction),  # -1.0: S never rises (Fish form); +1.0: never falls (GENERIC)
        **extra,
    )


def _grown(out):
    """``out`` with twice the rows (the rows written so far copied; the same counters array)."""
    rows = len(out.t)
    check_memory(2 * rows, KEEP_FEWER)
    bigger = new_output(2 * rows, out.x.shape[1])
    for old, new in zip(out[:4], bigger[:4]):
        new[:rows] = old
    return bigger._replace(counters=out.counters, residual=out.residual)


def _append(system, out, t, x):
    row = int(out.counters[_layout.ROWS])
    if row == len(out.t):
        raise AssertionError("no row left for the event state")  # _to_stops keeps one: rows are cut first
    out.t[row], out.x[row], out.H[row], out.S[row] = t, x, system.H(x), system.S(x)
    out.counters[_layout.ROWS] = row + 1


def raised_message(
    system: MetriplecticSystem, x: npt.NDArray[np.float64], h: float, raised: list[BaseException | None]
) -> str:
    """Which user function raised during the failed step from ``x``: named from the frames numba keeps in the
    exception's traceback, else found by calling the functions again where the step evaluates them (at ``x`` and
    along the explicit Euler move ``x + s h xi(x)``)."""
    error = raised[0] if raised else None
    f = system.functions
    if not isinstance(system, MetriplecticSystemN):
        poisson = "P" if f.poisson_form == "matrix" else "J"
        functions = {"H": f.H, "grad_H": f.grad_H, "S": f.S, "grad_S": f.grad_S, poisson: f.poisson}
    else:
        poisson = "P"
        functions = {"H": f.H, "grad_H": f.grad_H, "S": f.S, "grad_S": f.grad_S, "P": getattr(f, "P")}  # noqa: B009
    name = error and _user_errors.raised_by(error, functions)
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
    return (
        f"a user function raised {error!r} at a point of the step (none of H, grad_H, S, grad_S, {poisson} raises "
        f"at the step's start x = {x.tolist()})"
    )


def run_message(
    status: int,
    failed: int | None,
    t: npt.NDArray[np.float64],
    t_from: float,
    h: float,
    counters: npt.NDArray[np.int64] | Sequence[int],
    residual: float,
    integrator: Integrator,
    what: str | None = None,
) -> str:
    """The ``message`` of a run (or of one trajectory of an ensemble) that ended with ``status``."""
    status = BY_CODE[int(status)]
    rows = len(t)
    steps = int(counters[_layout.STEPS])
    rejected = int(counters[_layout.REJECTED])
    tried = f" ({rejected} rejected)" if rejected else ""
    if status == Status.OK:
        return f"The integration reached t_end in {steps} steps{tried}."
    if status == Status.TERMINATED:
        return f"A termination event occurred at t = {float(t[-1])!r}, after {steps} steps{tried}."
    if status == Status.INTERRUPTED:
        return (
            f"Interrupted (SIGINT) after {steps} steps, at t = {t[-1]:.6g}; the {rows} states saved "
            "so far are kept, the last one is the state reached."
        )
    what = what or status.message
    culprit = _layout.FUNCTION_NAMES[int(counters[_layout.CULPRIT])]
    if status == Status.NON_FINITE and culprit:
        what += f" (the user function `{culprit}` returned a non-finite value{_SHAPE_NOTE.get(culprit, '')})"
    elif status == Status.NEWTON_FAILED:
        what += f" (last Newton correction {residual:.3g})"
    return (
        f"Step {failed} (t = {t_from:.6g} -> {t_from + h:.6g}) failed: {what} with {integrator!r}. "
        f"{rows} saved state{'s' if rows != 1 else ''} up to t = {t_from:.6g} are kept. {status.advice}"
    )
