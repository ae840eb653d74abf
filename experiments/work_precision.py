"""Work-precision: what accuracy costs in time ("cost to reach error 1e-4, 1e-8, 1e-12").

For each problem, every geomint method runs over a sweep of step sizes and
every scipy method over a sweep of tolerances (rtol, atol = 1e-3 rtol); the
global error is ``|x(T) - x_ref(T)|_2``, the cost the median wall time of
repeated runs after a warm-up (compilation excluded) and the field
evaluations.  References: the closed form for the oscillator (checked against
a tight DOP853), DOP853 at rtol = 2.5e-14 elsewhere, whose uncertainty is
estimated by its distance to DOP853 at rtol = 1e-13 and printed; errors below
it are not trusted.
"""

from dataclasses import dataclass

import numpy as np

from geomint import plotting
from geomint.diagnostics import Curve, cost_to_reach, work_precision

from . import problems
from .compiled import scipy_rhs
from .methods import BASELINE_RK4, BASELINE_SCIPY, SCIPY_SWEEP, geomint_methods
from .report import figure, markdown_table, save
from .runs import median_time, not_applicable, scipy_solution

TARGETS = (1e-4, 1e-8, 1e-12)
TIGHTEST_RTOL = 2.5e-14


@dataclass(frozen=True)
class SweepSettings:
    t_end: float
    steps: tuple
    exponents: tuple
    repeats: int
    point_budget: float
    scipy_cutoff: float
    sweep_budget: float


FULL = SweepSettings(20.0, tuple(int(n) for n in np.geomspace(20, 2e5, 17).round()), tuple(range(3, 14)), 5, 2.0, 8.0, 15.0)
QUICK = SweepSettings(20.0, tuple(int(n) for n in np.geomspace(20, 2e4, 7).round()), tuple(range(3, 14, 2)), 3, 0.5, 1.0, 3.0)


def wp_problems():
    return [problems.relaxing_rigid_body(eps=0.1), problems.oscillator(eps=1.0), problems.quartic_rigid_body(eps=0.1)]


def reference(problem, t_end):
    """``(x_ref(T), uncertainty, note)``."""
    tight = scipy_solution(problem.system, problem.x0, (0.0, t_end), "DOP853", TIGHTEST_RTOL).x_final
    looser = scipy_solution(problem.system, problem.x0, (0.0, t_end), "DOP853", 1e-13).x_final
    if problem.exact is not None:
        exact = problem.exact(t_end)
        return exact, float(np.linalg.norm(looser - tight)), (
            f"closed form; |closed form - DOP853(rtol={TIGHTEST_RTOL:g})| = {np.linalg.norm(exact - tight):.2g}")
    spread = float(np.linalg.norm(looser - tight))
    return tight, spread, f"DOP853 rtol={TIGHTEST_RTOL:g}; |ref - DOP853(rtol=1e-13)| = {spread:.2g}"


def geomint_curve(problem, method, settings, x_ref):
    return work_precision(problem.system, problem.x0, settings.t_end, method.integrator, settings.steps, x_ref,
                          settings.repeats, settings.point_budget, settings.sweep_budget, label=method.label)


def scipy_curve(problem, name, settings, x_ref, rhs):
    curve = Curve(name, "scipy")
    t_span = (0.0, settings.t_end)
    for exponent in settings.exponents:
        rtol = 10.0 ** -exponent
        seconds, solution = median_time(
            lambda: scipy_solution(problem.system, problem.x0, t_span, name, rtol, rhs=rhs),
            settings.repeats, settings.point_budget)
        curve.wall.append(seconds)
        curve.nfev.append(solution.nfev)
        curve.error.append(float(np.linalg.norm(solution.x_final - x_ref)))
        curve.setting.append(rtol)
        if seconds > settings.scipy_cutoff:
            break
    return curve


def cost_table(curves):
    """Rows: method, then per target: wall ms, x DOP853, x RK4, field evals."""
    by_label = {c.label: c for c in curves}
    rows = []
    for curve in curves:
        row = [curve.label, "yes" if curve.structure_preserving else "no"]
        for target in TARGETS:
            wall = cost_to_reach(curve.wall, curve.error, target)
            ratios = [wall / cost_to_reach(by_label[b].wall, by_label[b].error, target) if b in by_label else np.nan
                      for b in (BASELINE_SCIPY, BASELINE_RK4)]
            row += [1e3 * wall, *ratios, cost_to_reach(curve.nfev, curve.error, target)]
        rows.append(row)
    return rows


COST_HEADERS = ["method", "H exact & S monotone"] + [
    f"{label} @{target:g}" for target in TARGETS for label in ("ms", "/DOP853", "/RK4", "field evals")]


def fastest_structure_preserving(curves, target=1e-8):
    """``(label, wall s, speed-up over DOP853, ratio to RK4)`` of the fastest H-exact, S-monotone method."""
    costs = {c.label: cost_to_reach(c.wall, c.error, target) for c in curves}
    candidates = [c.label for c in curves if c.structure_preserving and np.isfinite(costs[c.label])]
    if not candidates:
        return None
    best = min(candidates, key=costs.get)
    return best, costs[best], costs.get(BASELINE_SCIPY, np.nan) / costs[best], costs[best] / costs.get(BASELINE_RK4, np.nan)


def plot(problem, curves, uncertainty, axes):
    for ax, cost in zip(axes, ("wall", "nfev")):
        plotting.work_precision(curves, ax, cost=cost, legend=False)
        ax.axhline(max(uncertainty, 1e-16), color="grey", lw=0.8, ls=":")
        ax.set_title(f"{problem.title} (solid: exact H and monotone S)", fontsize=9)


def run_problem(problem, settings, methods, log=print):
    x_ref, uncertainty, note = reference(problem, settings.t_end)
    curves = [geomint_curve(problem, m, settings, x_ref) for m in methods
              if not_applicable(m.integrator, problem.system, problem.x0) is None]
    log(f"  {problem.name}: geomint sweeps done")
    rhs = scipy_rhs(problem.system)
    rhs(0.0, problem.x0)
    curves += [scipy_curve(problem, name, settings, x_ref, rhs) for name in SCIPY_SWEEP]
    log(f"  {problem.name}: scipy sweeps done")
    return curves, uncertainty, note


def main(quick=False, out=None, log=print):
    """Run the work-precision sweeps; write ``work_precision_<problem>.png``; return the markdown section and targets."""
    settings = QUICK if quick else FULL
    methods = geomint_methods()
    parts = ["## Work-precision: what accuracy costs",
             f"Global error at T = {settings.t_end:g} against median wall time ({settings.repeats} repeats after a "
             "warm-up run, so compilation is excluded) and against field evaluations. geomint: fixed steps "
             f"h = T/n, n in {list(settings.steps)}; scipy: rtol = 10^-k for k in {list(settings.exponents)}, "
             f"atol = 1e-3 rtol; a geomint sweep stops refining after {settings.sweep_budget:g} s. The dotted line "
             f"is the reference's uncertainty. Ratios are to the same run's {BASELINE_SCIPY} and {BASELINE_RK4} "
             "(>1: slower)."]
    targets = {}
    out_kw = {} if out is None else {"out": out}
    for problem in wp_problems():
        curves, uncertainty, note = run_problem(problem, settings, methods, log)
        fig, axes = figure(2, 1)
        plot(problem, curves, uncertainty, axes)
        fig.legend(*axes[0].get_legend_handles_labels(), loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7)
        name = save(fig, f"work_precision_{problem.name}.png", **out_kw)
        targets[problem.name] = fastest_structure_preserving(curves)
        parts += [f"### {problem.title}", f"Reference: {note}.", f"![work-precision {problem.name}]({name})",
                  markdown_table(COST_HEADERS, cost_table(curves))]
    return "\n\n".join(parts), targets
