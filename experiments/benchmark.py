"""Per-step cost of every geomint method on every catalogue system, as a ratio to compiled RK4.

    PYTHONPATH=. python -m experiments.benchmark [--quick]

A plain script rather than pytest-benchmark/asv: the quantity reported is a
*ratio measured in one run* (method / RK4 on the same system, same process,
interleaved), which neither tool reports directly, and the script adds no
dependency.  Each entry is the median over repeats of ``geomint.solve`` with
``save_every=None`` (n steps, compiled code only; one warm-up run first).  The
profile columns count field evaluations and Newton iterations per step and
time a bare field evaluation of the same system in a compiled loop
(``compiled.bare_field_loop``).
"""

import argparse
import inspect
import statistics
import time

import numpy as np

import geomint
from geomint import systems

from .compiled import bare_field_loop, field_loop_through_pointers
from .methods import BASELINE_RK4, geomint_methods
from .report import markdown_table
from .runs import median_time, not_applicable

#: a generic unit state (no coordinate zero: keeps off the invariant planes of the catalogue)
X0 = np.array([0.6, 0.48, 0.64])
H_STEP = 1e-3
SMALLEST_NORMAL = np.finfo(np.float64).tiny
#: target seconds of one timed run (expensive methods take fewer steps)
RUN_SECONDS = 0.15


def catalogue():
    """Every catalogue system built with its default arguments."""
    built = []
    for name, build in systems.CATALOGUE.items():
        if all(p.default is not inspect.Parameter.empty for p in inspect.signature(build).parameters.values()):
            built.append((name, build()))
    return built


def field_ns(system, n):
    """ns per field evaluation: inlined (closure) and through first-class function pointers (NaN if not tuple form)."""
    loop = bare_field_loop(system)
    loop(X0, 10)
    inlined, _ = median_time(lambda: loop(X0, n), 5)
    model = system.model
    args = (model.grad_H, model.grad_S, model.J, model.params, float(system.eps), bool(system.hamiltonian), X0)
    try:
        field_loop_through_pointers(*args, 10)
    except TypeError:
        return 1e9 * inlined / n, np.nan
    pointers, _ = median_time(lambda: field_loop_through_pointers(*args, n), 5)
    return 1e9 * inlined / n, 1e9 * pointers / n


def per_step(system, methods, n, repeats, run_seconds=None):
    """``{label: (ns/step, field evals/step, Newton iterations/step, note)}``.

    The note flags a final state with subnormal components (slow arithmetic) or
    a run that failed before its last step.

    Each method takes ``n`` steps, or fewer (down to n/20) where a calibration
    run shows that n would take more than ``run_seconds`` (a 15-stage composition
    costs 15 steps of its base method), so the benchmark's time stays bounded as
    methods are added.  Repeats are interleaved across methods (round robin) so
    that load changes on a shared machine hit every method alike; each entry is
    the median.
    """
    run_seconds = RUN_SECONDS if run_seconds is None else run_seconds
    methods = [m for m in methods if not_applicable(m.integrator, system, X0) is None]
    times = {m.label: [] for m in methods}
    solutions, steps = {}, {}
    for method in methods:
        geomint.solve(system, X0, (0.0, 4 * H_STEP), H_STEP, method=method.integrator, save_every=None)
        start = time.perf_counter()
        geomint.solve(system, X0, (0.0, n // 20 * H_STEP), H_STEP, method=method.integrator, save_every=None)
        per_run = max(20 * (time.perf_counter() - start), 1e-9)
        steps[method.label] = max(n // 20, min(n, int(n * run_seconds / per_run)))
    for _ in range(repeats):
        for method in methods:
            t_span = (0.0, steps[method.label] * H_STEP)
            start = time.perf_counter()
            solutions[method.label] = geomint.solve(
                system, X0, t_span, H_STEP, method=method.integrator, save_every=None
            )
            times[method.label].append(time.perf_counter() - start)
    results = {}
    for label, solution in solutions.items():
        if solution.n_steps == 0:
            continue
        x = np.abs(solution.x_final)
        note = " (subnormal state!)" if np.any((x > 0) & (x < SMALLEST_NORMAL)) else ""
        note += "" if solution.success else f" (failed at step {solution.failed_step})"
        results[label] = (
            1e9 * statistics.median(times[label]) / solution.n_steps,
            solution.nfev / solution.n_steps,
            solution.n_newton / solution.n_steps,
            note,
        )
    return results


def solve_overhead_ms(system, method):
    """Median wall time of a one-step ``geomint.solve``: the fixed cost of a call (validation, H(x0), S(x0),
    dispatch)."""
    geomint.solve(system, X0, (0.0, H_STEP), H_STEP, method=method.integrator, save_every=None)
    seconds, _ = median_time(
        lambda: geomint.solve(system, X0, (0.0, H_STEP), H_STEP, method=method.integrator, save_every=None), 21
    )
    return 1e3 * seconds


#: user-function calls per RK4 step: 4 fields (grad H, J if the Hamiltonian part is on, grad S if eps != 0) + H + S
EFFECTS = {"full field": {}, "eps = 0 (no grad S)": {"eps": 0.0}, "gradient part only (no J)": {"hamiltonian": False}}


def pointer_call_profile(system, methods, n, repeats):
    """Per-step cost with parts of the field switched off (``system.with_effects``).

    Returns rows ``(variant, user-function calls per RK4 step, {label: ns/step})``
    and the least-squares slope and intercept of RK4's ns/step against its calls:
    the marginal cost of one call through a function pointer and the rest of a step.
    """
    rows = []
    for variant, switches in EFFECTS.items():
        reduced = system.with_effects(**switches)
        calls = 4 * (1 + (reduced.eps != 0.0) + reduced.hamiltonian) + 2
        rows.append((variant, calls, {k: v[0] for k, v in per_step(reduced, methods, n, repeats).items()}))
    calls = np.array([r[1] for r in rows], dtype=float)
    rk4 = np.array([r[2].get(BASELINE_RK4, np.nan) for r in rows])
    slope, intercept = np.polyfit(calls, rk4, 1) if np.all(np.isfinite(rk4)) else (np.nan, np.nan)
    return rows, slope, intercept


HEADERS = [
    "system",
    "method",
    "ns/step",
    "x RK4",
    "field evals/step",
    "Newton its/step",
    "field ns inlined",
    "field ns via pointers",
    "ns/step / (evals x field ns via pointers)",
]


def run(quick=False, log=print):
    """The benchmark text (markdown), ``{system: {label: (ns/step, ratio to RK4)}}`` and ``{label: ms per solve
    call}``."""
    n, repeats = (20_000, 3) if quick else (200_000, 7)
    methods = geomint_methods()
    rows, ratios = [], {}
    for name, system in catalogue():
        inlined_ns, pointer_ns = field_ns(system, 10 * n)
        results = per_step(system, methods, n, repeats)
        base = results.get(BASELINE_RK4, (np.nan,))[0]
        ratios[name] = {}
        for label, (ns, evals, newton, note) in results.items():
            ratios[name][label] = (ns, ns / base)
            rows.append(
                [name, label + note, ns, ns / base, evals, newton, inlined_ns, pointer_ns, ns / (evals * pointer_ns)]
            )
        log(f"  benchmark {name} done")
    name, system = catalogue()[0]
    overhead = {m.label: solve_overhead_ms(system, m) for m in methods}
    profile, slope, intercept = pointer_call_profile(system, methods, n, repeats)
    labels = [m.label for m in methods]
    profile_table = markdown_table(
        ["field on " + name, "user-function calls per RK4 step"] + [f"{label} ns/step" for label in labels],
        [[variant, calls] + [ns.get(label) for label in labels] for variant, calls, ns in profile],
    )
    text = "\n\n".join(
        [
            "## Per-step cost (benchmark)",
            f"`PYTHONPATH=. python -m experiments.benchmark{' --quick' if quick else ''}`: median of {repeats} "
            "interleaved runs of "
            f"up to {n} steps of h = {H_STEP:g} (fewer where that would take over {RUN_SECONDS:g} s) from x0 = "
            f"{X0.tolist()}, every catalogue system with its default arguments, "
            "ratios to compiled RK4 on the same system in the same run. Profile: a field evaluation timed in a "
            "compiled "
            "loop with the user functions inlined, and reached through typed first-class function pointers as the "
            "library's kernels reach them; the last column is the step cost over the cost of its field evaluations "
            "through pointers (1 = a step is nothing but field evaluations).",
            markdown_table(HEADERS, rows),
            f"Fixed cost of one `geomint.solve` call (one step, {name}), ms: "
            + ", ".join(f"{label} {ms:.3g}" for label, ms in overhead.items())
            + ".",
            "Where a step's time goes: the same system with parts of the field switched off "
            "(`system.with_effects`), so that an RK4 step makes fewer calls of user functions through function "
            "pointers. "
            + (
                f"Fitted over the RK4 column: {slope:.3g} ns per call, {intercept:.3g} ns per step besides the calls."
                if slope > 0
                else "In this run the timing noise exceeded the effect (fitted slope <= 0); rerun on a quiet machine."
            ),
            profile_table,
        ]
    )
    return text, ratios, overhead


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps and repeats")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    text = run(args.quick)[0]
    print(text)
    print(f"\n({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
