"""Running geomint and scipy alike, and the statistics every experiment reports.

Long runs go in chunks of time, each a ``geomint.Solution`` (scipy results are
wrapped in one too), so memory stays bounded, every step is seen, and a wall
time budget can stop a run early (its reached time is reported).
"""

import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

import geomint
from geomint.diagnostics import Windows, growth_law, median_time  # noqa: F401 (used by drift, work_precision)

from .compiled import scipy_rhs

#: solve_ivp's absolute tolerance as a fraction of its relative tolerance (states are O(1))
ATOL_FRACTION = 1e-3
#: steps per geomint chunk in long runs (48 bytes a saved step)
CHUNK_STEPS = 250_000


def not_applicable(method, system, x0, h=1e-3):
    """Why ``method`` cannot run on ``system`` (the error of a one-step solve), or None when it can.

    Methods may support only some systems (a splitting may need an exact
    sub-flow); experiments skip those and say so instead of stopping.
    """
    try:
        geomint.solve(system, x0, (0.0, h), h, method=method, save_every=None)
    except (ValueError, TypeError, NotImplementedError) as error:
        return f"{type(error).__name__}: {error}"
    return None


def scipy_result(system, x0, t_span, method, rtol, rhs=None, **options):
    """``solve_ivp`` on the system's field (rtol, atol = ``ATOL_FRACTION`` rtol): the raw ``OdeResult``."""
    rhs = scipy_rhs(system) if rhs is None else rhs
    return solve_ivp(
        rhs, t_span, np.asarray(x0, dtype=np.float64), method=method, rtol=rtol, atol=ATOL_FRACTION * rtol, **options
    )


def scipy_solution(system, x0, t_span, method, rtol, rhs=None, result=None, **options):
    """``solve_ivp`` on the system's field, returned as a ``geomint.Solution`` (all steps saved).

    ``result``: an ``OdeResult`` already computed (by ``scipy_result``, e.g. timed alone) to wrap.
    """
    result = scipy_result(system, x0, t_span, method, rtol, rhs, **options) if result is None else result
    X = np.ascontiguousarray(result.y.T)
    return geomint.Solution(
        t=result.t,
        x=X,
        H=system.H(X),
        S=system.S(X),
        success=bool(result.success),
        status=int(result.status),
        message=result.message,
        failed_step=None,
        n_steps=int(result.t.size - 1),
        n_newton=int(getattr(result, "nlu", 0)),
        nfev=int(result.nfev),
        method=f"{method} rtol={rtol:g}",
    )


def lsoda_result(rhs, x0, t_eval, rtol, atol=None):
    """numbalsoda's compiled LSODA (``rhs`` from ``compiled.lsoda_rhs``) at the times ``t_eval``, by its own
    interpolant: ``(states (n, 3), success)``; ``atol`` defaults to ``ATOL_FRACTION`` rtol.  Needs the
    benchmark extra (``pip install geomint[bench]``)."""
    import numbalsoda

    return numbalsoda.lsoda(
        rhs.address,
        np.asarray(x0, dtype=np.float64),
        np.asarray(t_eval, dtype=np.float64),
        rtol=rtol,
        atol=ATOL_FRACTION * rtol if atol is None else atol,
    )


def lsoda_solution(system, t_eval, rtol, result):
    """``lsoda_result``'s ``result`` as a ``geomint.Solution`` (numbalsoda does not count field evaluations: 0)."""
    X, success = result
    return geomint.Solution(
        t=np.asarray(t_eval, dtype=np.float64),
        x=X,
        H=system.H(X),
        S=system.S(X),
        success=bool(success),
        status=0 if success else -1,
        message="" if success else "numbalsoda reported failure",
        failed_step=None,
        n_steps=len(t_eval) - 1,
        n_newton=0,
        nfev=0,
        method=f"numbalsoda LSODA rtol={rtol:g}",
    )


@dataclass
class LongRun:
    """Summary of a long run: windowed |H - H0| / |H0|, S rises, work, time and final state."""

    label: str
    kind: str
    windows: Windows
    t_end: float
    t_reached: float = 0.0
    n_steps: int = 0
    nfev: int = 0
    S_rises: int = 0
    wall: float = 0.0
    x_final: np.ndarray | None = None
    success: bool = True
    note: str = ""

    @property
    def complete(self):
        return self.success and self.t_reached >= self.t_end * (1 - 1e-12)


def long_run(label, kind, problem, t_end, chunks, windows, budget):
    """Consume ``chunks`` (an iterator of ``(Solution, seconds)`` covering ``[0, t_end]``) into a ``LongRun``.

    Stops after the chunk that takes the wall time over ``budget`` seconds.
    """
    H0 = float(problem.system.H(problem.x0))
    scale = abs(H0) if H0 != 0 else 1.0
    summary = LongRun(label, kind, windows, t_end)
    for solution, seconds in chunks:
        summary.wall += seconds
        summary.windows.add(solution.t, np.abs(solution.H - H0) / scale)
        summary.n_steps += solution.n_steps
        summary.nfev += solution.nfev
        summary.S_rises += solution.count_S_rises()
        summary.t_reached = solution.t_final
        summary.x_final = solution.x_final.copy()
        if not solution.success:
            summary.success, summary.note = False, solution.message
            break
        if summary.wall > budget and summary.t_reached < t_end:
            summary.note = f"stopped by the {budget:g} s budget at t = {summary.t_reached:.3g}"
            break
    return summary


def geomint_chunks(problem, method, t_end, h):
    """``(Solution, seconds)`` for consecutive chunks of ``CHUNK_STEPS`` steps of size h, every step saved."""
    x, t = problem.x0, 0.0
    span = CHUNK_STEPS * h
    while t < t_end:
        t_next = min(t_end, t + span)
        start = time.perf_counter()
        solution = geomint.solve(problem.system, x, (t, t_next), h, method=method)
        yield solution, time.perf_counter() - start
        x, t = solution.x_final, t_next
        if not solution.success:
            return


def scipy_chunks(problem, method, rtol, t_end, segments=50):
    """``(Solution, seconds)`` for ``segments`` consecutive solve_ivp runs covering ``[0, t_end]``."""
    rhs = scipy_rhs(problem.system)
    rhs(0.0, problem.x0)
    x = problem.x0
    bounds = np.linspace(0.0, t_end, segments + 1)
    for t, t_next in zip(bounds[:-1], bounds[1:]):
        start = time.perf_counter()
        solution = scipy_solution(problem.system, x, (t, t_next), method, rtol, rhs=rhs)
        yield solution, time.perf_counter() - start
        x = solution.x_final
        if not solution.success:
            return
