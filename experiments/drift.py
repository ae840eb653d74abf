"""Long-time drift: |H(t) - H0| of every geomint method against generic Runge-Kutta.

Problems (``drift_problems``): the free rigid body (R1, eps = 0), the dissipative
oscillator (S = z^2), the relaxing rigid body (eps = 1e-3) and the quartic
rigid body (eps = 1e-3), all from t = 0 to ``T`` (1e5; the oscillator's compiled
runs to 10 T).  Every step is seen: the table gives windowed maxima of
|H - H0| / |H0| with a fitted growth law, the steps where S rose beyond
round-off, and the final state against the predicted attractor or exact
solution.  The oscillator's eps = 1e-4 keeps z ~ exp(-2 eps t) above the
subnormal range up to t = 1e6 (subnormal arithmetic is ~10x slower).
"""

from dataclasses import dataclass

import numpy as np

from geomint import plotting

from . import problems
from .methods import SCIPY_DRIFT, geomint_methods
from .report import figure, markdown_table, save
from .runs import Windows, geomint_chunks, growth_law, long_run, not_applicable, scipy_chunks


@dataclass(frozen=True)
class DriftSettings:
    t_end: float
    compiled_factor: dict
    h: float
    windows: int
    fit_from: float
    compiled_budget: float
    scipy_budget: float
    compiled_total: float = np.inf

    def compiled_budget_for(self, n_methods, n_problems=4):
        """Per-run budget of the geomint runs: ``compiled_budget``, less when many methods share ``compiled_total``."""
        return min(self.compiled_budget, max(3.0, self.compiled_total / (n_methods * n_problems)))


FULL = DriftSettings(1e5, {"dissipative_oscillator": 10.0}, 0.1, 40, 100.0, 20.0, 10.0, 300.0)
QUICK = DriftSettings(1e3, {"dissipative_oscillator": 10.0}, 0.1, 20, 10.0, 2.0, 1.0, 30.0)


def drift_problems():
    return [
        problems.free_rigid_body(),
        problems.oscillator(eps=1e-4),
        problems.relaxing_rigid_body(eps=1e-3),
        problems.quartic_rigid_body(eps=1e-3),
    ]


def final_errors(problem, run):
    """(distance to the predicted attractor, error against the exact solution) of the final state."""
    if run.x_final is None:
        return np.nan, np.nan
    to_attractor = np.nan if problem.attractor is None else float(np.linalg.norm(run.x_final - problem.attractor))
    to_exact = np.nan
    if problem.exact is not None:
        to_exact = float(np.linalg.norm(run.x_final - problem.exact(run.t_reached)))
    if problem.name == "dissipative_oscillator":
        r = np.linalg.norm(problem.x0)
        to_attractor = float(np.hypot(run.x_final[2], np.hypot(*run.x_final[:2]) - r))
    return to_attractor, to_exact


def run_problem(problem, settings, methods, log=print):
    """Every geomint method and every scipy configuration of ``SCIPY_DRIFT`` on one problem."""
    runs = []
    compiled_end = settings.t_end * settings.compiled_factor.get(problem.name, 1.0)
    for method in methods:
        if (reason := not_applicable(method.integrator, problem.system, problem.x0)) is not None:
            log(f"  {problem.name} {method.label}: skipped ({reason})")
            continue
        windows = Windows.log_spaced(1.0, compiled_end, settings.windows)
        chunks = geomint_chunks(problem, method.integrator, compiled_end, settings.h)
        budget = settings.compiled_budget_for(len(methods))
        runs.append(long_run(method.label, "geomint", problem, compiled_end, chunks, windows, budget))
        log(f"  {problem.name} {method.label}: {runs[-1].wall:.1f} s")
    for name, tolerances in SCIPY_DRIFT:
        for rtol in tolerances:
            windows = Windows.log_spaced(1.0, settings.t_end, settings.windows)
            chunks = scipy_chunks(problem, name, rtol, settings.t_end)
            label = f"{name} rtol={rtol:g}"
            runs.append(long_run(label, "scipy", problem, settings.t_end, chunks, windows, settings.scipy_budget))
            log(f"  {problem.name} {label}: {runs[-1].wall:.1f} s")
    return runs


def table_rows(problem, runs, settings):
    rows = []
    for run in runs:
        p, law = growth_law(run.windows.centers, run.windows.maxima, settings.fit_from)
        attractor, exact = final_errors(problem, run)
        rows.append(
            [
                run.label,
                run.t_reached,
                run.n_steps,
                run.nfev,
                run.wall,
                float(np.nanmax(run.windows.maxima)),
                p,
                law,
                run.S_rises,
                attractor,
                exact,
                run.note,
            ]
        )
    return rows


HEADERS = [
    "method",
    "t reached",
    "steps",
    "field evals",
    "wall s",
    "max |H-H0|/|H0|",
    "growth p",
    "law",
    "S rises",
    "final: dist. to attractor",
    "final: error vs exact",
    "note",
]


def plot(problem, runs, ax, settings):
    series = [(run.label, run.windows.centers, run.windows.maxima, settings.fit_from) for run in runs]
    plotting.drift_windows(
        series, ax, legend=False, law_in_key=False, linestyles=["-" if run.kind == "geomint" else "--" for run in runs]
    )
    ax.set_title(problem.title)


def main(quick=False, out=None, log=print):
    """Run the drift experiment; write ``drift.png``; return the markdown section."""
    settings = QUICK if quick else FULL
    methods = geomint_methods()
    fig, axes = figure(2, 2)
    sections = []
    for ax, problem in zip(axes, drift_problems()):
        runs = run_problem(problem, settings, methods, log)
        plot(problem, runs, ax, settings)
        sections.append(
            f"**{problem.title}**, h = {settings.h:g} for geomint methods\n\n"
            + markdown_table(HEADERS, table_rows(problem, runs, settings))
        )
    fig.legend(*axes[0].get_legend_handles_labels(), loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7)
    name = save(fig, "drift.png", **({} if out is None else {"out": out}))
    return "\n\n".join(
        [
            "## Long-time drift",
            f"Windowed maxima of |H - H0|/|H0| over {settings.windows} log-spaced windows; growth law fitted for "
            f"t >= {settings.fit_from:g}. Solid: geomint (every step seen, steps of h = {settings.h:g}); dashed: "
            "scipy solve_ivp (atol = 1e-3 rtol). Wall budgets per run: geomint "
            f"{settings.compiled_budget_for(len(methods)):.3g} s, "
            f"scipy {settings.scipy_budget:g} s (a run over budget stops and says where). 'S rises': steps with "
            "S_{n+1} - S_n > 16 eps |S| (for eps = 0, S is a Casimir and any rise is drift). Wall times include "
            "saving every step (geomint) or computing H and S at every step (scipy).",
            f"![drift]({name})",
            *sections,
        ]
    )
