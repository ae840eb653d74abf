"""Runs about runs: a reference solution, the measured order of a method, work-precision sweeps, S-rise counts.

Each function calls ``geomint.solve`` and measures what comes back with ``geomint.diagnostics``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ._kernels import control as _control
from ._kernels import layout as _layout
from ._kernels import loop as _loop
from .diagnostics import error_along, median_time, observed_order
from .integrators import resolve
from .integrators.program import program_of
from .model.system import MetriplecticSystem
from .run.arguments import check_state
from .run.chunks import new_run_state
from .run.solve import solve

if TYPE_CHECKING:
    import numpy.typing as npt

    from .integrators import Integrator
    from .model.system import MetriplecticSystem


def reference_solution(
    system: MetriplecticSystem, x0: npt.ArrayLike, t_end: float, rtol: float = 1e-13, atol: float = 1e-15
) -> npt.NDArray[np.float64]:
    """``x(t_end)`` by scipy's DOP853 at tight tolerances (structure-blind, for error measurements)."""
    from scipy.integrate import solve_ivp

    result = solve_ivp(
        lambda t, x: system.xi(x), (0.0, t_end), np.asarray(x0, dtype=float), method="DOP853", rtol=rtol, atol=atol
    )
    if not result.success:
        raise RuntimeError(f"the DOP853 reference failed: {result.message}")
    return result.y[:, -1]


def measured_order(
    system: MetriplecticSystem,
    method: Integrator | str,
    x0: npt.ArrayLike,
    t_end: float,
    step_sizes: Sequence[float],
    reference: npt.ArrayLike | None = None,
    floor: float = 1e-13,
) -> tuple[float, list[float]]:
    """Observed order of ``method`` on ``system`` from ``x0`` to ``t_end``: the slope of the
    relative final-state error against ``h`` (``observed_order``), against ``reference``
    (default: ``reference_solution``).  Returns ``(order, errors)``.
    """
    method = resolve(method)
    reference = reference_solution(system, x0, t_end) if reference is None else np.asarray(reference)
    errors = []
    for h in step_sizes:
        sol = solve(system, x0, (0.0, t_end), h, method=method, save_every=None)
        if not sol.success:
            raise RuntimeError(f"h = {h:g}: {sol.message}")
        errors.append(float(np.max(np.abs(sol.x_final - reference)) / np.max(np.abs(reference))))
    return observed_order(step_sizes, errors, floor), errors


@dataclass
class Curve:
    """One method's work-precision sweep: per run its setting (h or rtol), wall time, field evaluations, error."""

    label: str
    kind: str = "geomint"
    structure_preserving: bool = False
    wall: list = field(default_factory=list)
    nfev: list = field(default_factory=list)
    error: list = field(default_factory=list)
    setting: list = field(default_factory=list)


def work_precision(
    system: MetriplecticSystem,
    x0: npt.ArrayLike,
    t_end: float,
    method: Integrator | str,
    step_counts: Sequence[int] | None,
    reference: npt.ArrayLike | Callable[[npt.NDArray[np.float64]], Any],
    repeats: int = 3,
    point_budget: float = 2.0,
    sweep_budget: float = math.inf,
    label: str | None = None,
    *,
    tolerances: Sequence[float] | None = None,
    samples: int = 1000,
) -> Curve:
    """Error against cost over a sweep of fixed steps ``h = T / n`` or of tolerances ``rtol = atol``.

    Parameters
    ----------
    system, x0, method
        As for ``geomint.solve``.
    t_end : float
        The end time ``T``.
    step_counts : sequence of int, or None
        Numbers of fixed steps ``n``, coarse to fine; ``None`` with ``tolerances``.
    reference : (3,) array, or callable
        ``x(T)`` (e.g. ``reference_solution``): the error is ``|x(T) - reference|_2``.
        Or ``reference(t) -> (len(t), 3)`` (e.g. a dense DOP853 solution's ``sol``):
        the error is measured **along the trajectory**, ``max_k |x_k - reference(t_k)|_2``
        over the returned states (fixed steps save about ``samples`` of them, adaptive
        runs every accepted step).
    repeats, point_budget
        Median wall time over ``repeats`` runs, fewer past ``point_budget`` seconds.
    sweep_budget : float
        Stop refining after this many seconds; refining stops also once two
        consecutive errors are below 1e-13 (round-off).
    tolerances : sequence of float, optional
        Adaptive runs (``h=None``) with ``rtol = atol`` = each value, loose to tight.
    samples : int
        Saved states per fixed-step run when the error is measured along the trajectory.

    Returns a ``Curve`` whose ``setting`` holds h or rtol (failed runs are left out).
    """
    method = resolve(method)
    if (step_counts is None) == (tolerances is None):
        raise ValueError(
            "work_precision: give exactly one of `step_counts` (fixed steps) and `tolerances` "
            f"(adaptive steps); got step_counts={step_counts!r}, tolerances={tolerances!r}."
        )
    along = callable(reference)
    curve = Curve(label or method.name, "geomint", bool(method.energy_exact and method.dissipative))

    def run(setting):
        if tolerances is not None:
            return solve(
                system, x0, (0.0, t_end), rtol=setting, atol=setting, method=method, save_every=1 if along else None
            )
        n = round(t_end / setting)
        return solve(
            system, x0, (0.0, t_end), setting, method=method, save_every=max(1, n // samples) if along else None
        )

    def error(sol):
        if along:
            return error_along(sol, reference)  # pyright: ignore[reportArgumentType]  # along: callable
        return float(np.linalg.norm(sol.x_final - reference))

    settings = tolerances if tolerances is not None else [t_end / n for n in step_counts]  # pyright: ignore[reportOptionalIterable]  # one given
    run(settings[0])  # warm-up: compile
    plateau, start = 0, time.perf_counter()
    for setting in settings:
        if time.perf_counter() - start > sweep_budget:
            break
        seconds, sol = median_time(lambda: run(setting), repeats, point_budget)
        if not sol.success:
            continue
        curve.wall.append(seconds)
        curve.nfev.append(sol.nfev)
        curve.error.append(error(sol))
        curve.setting.append(setting)
        plateau = plateau + 1 if curve.error[-1] < 1e-13 else 0
        if plateau == 2:
            break
    return curve


def S_rise_statistics(system, method, x0, h, n_steps, ulps=16):
    """Count the sub-steps and full steps of ``method`` that raise S, on ``n_steps`` steps from ``x0``.

    A rise is ``S_new - S_old > ulps * eps * max(|S_old|, |S_new|)``.  Returns a
    dict: ``steps``, ``sub_steps``, ``sub_step_rises``, ``full_step_rises``
    (after the safeguard), ``safeguard_fired`` (full steps redone by the
    monotone safeguard) and ``status``.  Runs compiled, through the one step
    loop (a ``Counting`` controller), saving only the first and last states.
    Also importable as ``geomint.integrators.S_rise_statistics``.
    """
    if not isinstance(system, MetriplecticSystem):
        raise TypeError(f"`system` must be a geomint.MetriplecticSystem; got {type(system).__name__}.")
    method.check_system(system)
    x0 = check_state(x0)
    h, n_steps = float(h), int(n_steps)
    lowered = program_of(method).lower(system)
    out = _loop.Output(
        np.empty(3),
        np.empty((3, 3)),
        np.empty(3),
        np.empty(3),
        np.zeros(_layout.N_RISE_COUNTERS, dtype=np.int64),
        np.zeros(1),
    )
    work, state = new_run_state(lowered, x0)
    counting = _control.Counting(0.0, h, n_steps, h, max(n_steps, 1), float(ulps))
    if n_steps > 0:
        _loop.run(
            system.model,
            system.eps,
            system.hamiltonian,
            lowered,
            counting,
            state,
            work,
            _layout.new_clock(0.0),
            np.array([n_steps * h]),
            n_steps,
            out,
        )
    counters = out.counters
    steps = int(counters[_layout.STEPS])
    return {
        "steps": steps,
        "sub_steps": steps * int(lowered.iopts[_layout.P_GAMMAS] * lowered.iopts[_layout.P_STAGES]),
        "sub_step_rises": int(counters[_layout.SUB_STEP_RISES]),
        "full_step_rises": int(counters[_layout.FULL_STEP_RISES]),
        "safeguard_fired": int(counters[_layout.SAFEGUARD_FIRED]),
        "status": int(counters[_layout.STATUS]),
    }
