"""Work-precision: what accuracy costs in time ("cost to reach error 1e-4, 1e-8, 1e-12").

For each problem, every geomint method runs over a sweep of fixed step sizes,
the adaptive geomint methods over a sweep of tolerances (rtol = atol), every
scipy method and numbalsoda's compiled LSODA (when the benchmark extra is
installed) over a sweep of tolerances (rtol, atol = 1e-3 rtol).  The error is
measured **along the trajectory**: the largest ``|x(t_k) - x_ref(t_k)|_2`` over
the returned states (every step of the adaptive and scipy runs, about 1000
states of a fixed-step run, numbalsoda's interpolant at 1001 equally spaced
times), since a relaxed final state says little.  The cost is the median wall
time of repeated runs after a warm-up (compilation excluded; the solver call
only) and the field evaluations.  References: the closed form for the
oscillator, DOP853 at rtol = 2.5e-14 (dense output) elsewhere; the spread
between DOP853 at 2.5e-14 and at 1e-13 along the trajectory is printed as the
reference's uncertainty, and errors below it are not trusted.
"""

from dataclasses import dataclass

import numpy as np

from geomint import plotting
from geomint.diagnostics import cost_to_reach, error_along
from geomint.studies import Curve, work_precision

from . import problems
from .compiled import lsoda_rhs, scipy_rhs
from .methods import BASELINE_RK4, BASELINE_SCIPY, SCIPY_SWEEP, adaptive_methods, geomint_methods
from .report import figure, markdown_table, save
from .runs import lsoda_result, lsoda_solution, median_time, not_applicable, scipy_result, scipy_solution

TARGETS = (1e-4, 1e-8, 1e-12)
TIGHTEST_RTOL = 2.5e-14
#: times at which numbalsoda's interpolant is read (and the reference spread measured)
GRID = 1001
ERROR_LABEL = "max error along the trajectory"


@dataclass(frozen=True)
class SweepSettings:
    t_end: float
    steps: tuple
    exponents: tuple
    repeats: int
    point_budget: float
    scipy_cutoff: float
    sweep_budget: float


FULL = SweepSettings(
    20.0, tuple(int(n) for n in np.geomspace(20, 2e5, 17).round()), tuple(range(3, 14)), 5, 2.0, 8.0, 15.0
)
QUICK = SweepSettings(
    20.0, tuple(int(n) for n in np.geomspace(20, 2e4, 7).round()), tuple(range(3, 14, 2)), 3, 0.5, 1.0, 3.0
)


def wp_problems():
    return [problems.relaxing_rigid_body(eps=0.1), problems.oscillator(eps=1.0), problems.quartic_rigid_body(eps=0.1)]


def reference(problem, t_end):
    """``(x_ref(t) -> (len(t), 3), uncertainty, note)``: the trajectory errors are measured against."""

    def dense(rtol):
        sol = scipy_result(problem.system, problem.x0, (0.0, t_end), "DOP853", rtol, dense_output=True).sol
        return lambda t: sol(t).T

    tight, looser = dense(TIGHTEST_RTOL), dense(1e-13)
    grid = np.linspace(0.0, t_end, GRID)
    spread = float(np.max(np.linalg.norm(looser(grid) - tight(grid), axis=1)))
    if problem.exact is not None:
        off = float(np.max(np.linalg.norm(problem.exact(grid) - tight(grid), axis=1)))
        return (
            problem.exact,
            spread,
            (f"closed form; max over t of |closed form - DOP853(rtol={TIGHTEST_RTOL:g})| = {off:.2g}"),
        )
    return (
        tight,
        spread,
        (f"DOP853 rtol={TIGHTEST_RTOL:g}, dense output; max over t of |ref - DOP853(rtol=1e-13)| = {spread:.2g}"),
    )


#: the tightest tolerance of the adaptive geomint sweeps: at 1e-12 adaptive Gonzalez on the quartic body
#: crawls near the attractor (t ~ 19.8: steps of 1e-9, ~4 rejected attempts per accepted step, minutes of
#: run time), a known defect of its Newton acceptance at tolerances near round-off
ADAPTIVE_TIGHTEST = 11


def geomint_curve(problem, method, settings, x_ref, adaptive=False):
    steps = None if adaptive else settings.steps
    tolerances = [10.0**-k for k in settings.exponents if k <= ADAPTIVE_TIGHTEST] if adaptive else None
    return work_precision(
        problem.system,
        problem.x0,
        settings.t_end,
        method.integrator,
        steps,
        x_ref,
        settings.repeats,
        settings.point_budget,
        settings.sweep_budget,
        label=method.label,
        tolerances=tolerances,
    )


def tolerance_curve(label, settings, solve_at, x_ref):
    """A sweep over rtol = 10^-k: ``solve_at(rtol) -> (timed call, wrap(result) -> Solution)``."""
    curve = Curve(label, "scipy")
    for exponent in settings.exponents:
        rtol = 10.0**-exponent
        call, wrap = solve_at(rtol)
        seconds, result = median_time(call, settings.repeats, settings.point_budget)
        solution = wrap(result)
        if solution.success:
            curve.wall.append(seconds)
            curve.nfev.append(solution.nfev if solution.nfev else np.nan)
            curve.error.append(error_along(solution, x_ref))
            curve.setting.append(rtol)
        if seconds > settings.scipy_cutoff:
            break
    return curve


def scipy_curve(problem, name, settings, x_ref, rhs):
    span = (0.0, settings.t_end)
    return tolerance_curve(
        name,
        settings,
        lambda rtol: (
            lambda: scipy_result(problem.system, problem.x0, span, name, rtol, rhs=rhs),
            lambda result: scipy_solution(problem.system, problem.x0, span, name, rtol, result=result),
        ),
        x_ref,
    )


def lsoda_curve(problem, settings, x_ref):
    """numbalsoda's LSODA, or None without the benchmark extra."""
    try:
        rhs = lsoda_rhs(problem.system)
    except ImportError:
        return None
    t_eval = np.linspace(0.0, settings.t_end, GRID)
    return tolerance_curve(
        "numbalsoda LSODA",
        settings,
        lambda rtol: (
            lambda: lsoda_result(rhs, problem.x0, t_eval, rtol),
            lambda result: lsoda_solution(problem.system, t_eval, rtol, result),
        ),
        x_ref,
    )


def cost_table(curves):
    """Rows: method, then per target: wall ms, x DOP853, x RK4, field evals."""
    by_label = {c.label: c for c in curves}
    rows = []
    for curve in curves:
        row = [curve.label, "yes" if curve.structure_preserving else "no"]
        for target in TARGETS:
            wall = cost_to_reach(curve.wall, curve.error, target)
            ratios = [
                wall / cost_to_reach(by_label[b].wall, by_label[b].error, target) if b in by_label else np.nan
                for b in (BASELINE_SCIPY, BASELINE_RK4)
            ]
            row += [1e3 * wall, *ratios, cost_to_reach(curve.nfev, curve.error, target)]
        rows.append(row)
    return rows


COST_HEADERS = ["method", "H exact & S monotone"] + [
    f"{label} @{target:g}" for target in TARGETS for label in ("ms", "/DOP853", "/RK4", "field evals")
]


def fastest_structure_preserving(curves, target=1e-8):
    """``(label, wall s, speed-up over DOP853, ratio to RK4)`` of the fastest H-exact, S-monotone method."""
    costs = {c.label: cost_to_reach(c.wall, c.error, target) for c in curves}
    candidates = [c.label for c in curves if c.structure_preserving and np.isfinite(costs[c.label])]
    if not candidates:
        return None
    best = min(candidates, key=costs.get)
    return (
        best,
        costs[best],
        costs.get(BASELINE_SCIPY, np.nan) / costs[best],
        costs[best] / costs.get(BASELINE_RK4, np.nan),
    )


def plot(problem, curves, uncertainty, axes):
    for ax, cost in zip(axes, ("wall", "nfev")):
        plotting.plot_work_precision(curves, ax, cost=cost, legend=False, error=ERROR_LABEL)
        ax.axhline(max(uncertainty, 1e-16), color="grey", lw=0.8, ls=":")
        ax.set_title(f"{problem.title} (solid: exact H and monotone S)", fontsize=9)


def run_problem(problem, settings, methods, log=print):
    x_ref, uncertainty, note = reference(problem, settings.t_end)
    curves = [
        geomint_curve(problem, m, settings, x_ref)
        for m in methods
        if not_applicable(m.integrator, problem.system, problem.x0) is None
    ]
    log(f"  {problem.name}: geomint fixed-step sweeps done")
    curves += [geomint_curve(problem, m, settings, x_ref, adaptive=True) for m in adaptive_methods()]
    log(f"  {problem.name}: geomint adaptive sweeps done")
    rhs = scipy_rhs(problem.system)
    rhs(0.0, problem.x0)
    curves += [scipy_curve(problem, name, settings, x_ref, rhs) for name in SCIPY_SWEEP]
    lsoda = lsoda_curve(problem, settings, x_ref)
    curves += [] if lsoda is None else [lsoda]
    log(f"  {problem.name}: scipy and numbalsoda sweeps done")
    return curves, uncertainty, note


def _has_numbalsoda():
    try:
        import numbalsoda  # noqa: F401
    except ImportError:
        return False
    return True


def main(quick=False, out=None, log=print):
    """Run the work-precision sweeps; write ``work_precision_<problem>.png``; return the markdown section and
    targets."""
    settings = QUICK if quick else FULL
    methods = geomint_methods()
    parts = [
        "## Work-precision: what accuracy costs",
        f"Error along the trajectory up to T = {settings.t_end:g} (the largest distance to the reference over "
        "the returned states: every step of adaptive and scipy runs, ~1000 states of a fixed-step run, "
        f"numbalsoda's interpolant at {GRID} equally spaced times) against median wall time ({settings.repeats} "
        "repeats after a warm-up run, so compilation is excluded; the solver call only) and against field "
        f"evaluations (numbalsoda does not count them). geomint: fixed steps h = T/n, n in {list(settings.steps)}, "
        f'and adaptive steps (rows "adaptive") with rtol = atol = 10^-k, k <= {ADAPTIVE_TIGHTEST}; scipy and '
        "numbalsoda: rtol = 10^-k, "
        f"atol = 1e-3 rtol; k in {list(settings.exponents)}. A geomint sweep stops refining after "
        f"{settings.sweep_budget:g} s. The dotted line is the reference's uncertainty. Ratios are to the same "
        f"run's {BASELINE_SCIPY} and {BASELINE_RK4} (>1: slower)."
        + (
            ""
            if _has_numbalsoda()
            else " numbalsoda is not installed in this run (`pip install "
            "geomint[bench]`, which needs a Fortran compiler to build), so its curves are missing."
        ),
    ]
    targets = {}
    out_kw = {} if out is None else {"out": out}
    for problem in wp_problems():
        curves, uncertainty, note = run_problem(problem, settings, methods, log)
        fig, axes = figure(2, 1)
        plot(problem, curves, uncertainty, axes)
        fig.legend(*axes[0].get_legend_handles_labels(), loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7)
        name = save(fig, f"work_precision_{problem.name}.png", **out_kw)
        targets[problem.name] = fastest_structure_preserving(curves)
        parts += [
            f"### {problem.title}",
            f"Reference: {note}.",
            f"![work-precision {problem.name}]({name})",
            markdown_table(COST_HEADERS, cost_table(curves)),
        ]
    return "\n\n".join(parts), targets
