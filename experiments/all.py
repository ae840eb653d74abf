"""Regenerate every figure and table in ``docs/`` and write ``docs/experiments.md``.

    PYTHONPATH=. python -m experiments.all [--quick]

``--quick`` shortens every run (for iteration; about 2 minutes); the full mode
is budgeted to finish in under 15 minutes on a 2-core machine.
"""

import argparse
import time

from . import benchmark, drift, long_run, newton_tolerance, work_precision
from .methods import BASELINE_RK4, GONZALEZ, geomint_methods
from .report import DOCS, fmt, machine, markdown_table

LONG_STEPS = {True: 10**6, False: 10**8}


def targets_section(ratios, overhead, fastest, long, penalty, quick):
    """The targets the project holds the engine to, reported (never asserted): measured value, aim, verdict."""
    rows = []
    for method in geomint_methods():
        if method.structure_preserving and method.single_step and method.label in ratios.get("relaxing_rigid_body", {}):
            ns, ratio = ratios["relaxing_rigid_body"][method.label]
            rows.append(
                [
                    f"{method.label} step / RK4 step (relaxing rigid body)",
                    f"{ratio:.2f}x ({ns:.0f} ns)",
                    "<= 2x",
                    "met" if ratio <= 2 else f"missed by {ratio / 2:.2f}x",
                ]
            )
    if fastest is None:
        rows.append(
            [
                "fastest H-exact, S-monotone method at error 1e-8 (relaxing rigid body)",
                "not reached in the sweep",
                ">= 50x faster than DOP853, <= 3x RK4",
                "missed",
            ]
        )
    else:
        label, wall, speedup, to_rk4 = fastest
        rows.append(
            [
                f"fastest H-exact, S-monotone at 1e-8: {label} ({1e3 * wall:.3g} ms) vs DOP853",
                f"{speedup:.3g}x faster",
                ">= 50x",
                "met" if speedup >= 50 else f"missed by {50 / speedup:.3g}x",
            ]
        )
        rows.append(
            [
                f"{label} vs our RK4 at 1e-8",
                f"{to_rk4:.3g}x RK4's time",
                "<= 3x",
                "met" if to_rk4 <= 3 else f"missed by {to_rk4 / 3:.3g}x",
            ]
        )
        budget = 1e3 * wall * speedup / 50
        fixed = overhead.get(label)
        rows.append(
            [
                "  time a 50x speed-up over DOP853 allows vs the fixed cost of one geomint.solve call",
                f"{budget:.3g} ms vs " + ("(not measured for this method)" if fixed is None else f"{fixed:.3g} ms"),
                "—",
                "—" if fixed is None else "the fixed cost alone exceeds it" if fixed > budget else "fits",
            ]
        )
    wall = long["wall_s"] * (10**8 / long["steps"])
    how = "measured" if long["steps"] == 10**8 else f"extrapolated from {long['steps']:.0e} steps"
    rows.append(
        [
            f"10^8 {GONZALEZ} steps, final state only (eps = {long['eps']:g}, h = {long['h']:g})",
            f"{wall:.1f} s ({how}; {long['ns_per_step']:.0f} ns/step)",
            "< 30 s",
            "met" if wall < 30 else f"missed by {wall / 30:.2f}x",
        ]
    )
    rows.append(
        [
            "  peak memory of that process",
            f"{long['peak_rss_mb']:.0f} MB (after import+compile: {long['baseline_rss_mb']:.0f} MB)",
            "< 200 MB",
            "met" if long["peak_rss_mb"] < 200 else "missed",
        ]
    )
    notes = (
        f"Final state of the long run: {long['x_final']} ({long['subnormal_components']} subnormal components; "
        f"distance to the attractor {long['distance_to_attractor']:.3g}; energy error {long['energy_error']:.2g}; "
        f"{long['newton_per_step']:.2f} Newton iterations and {long['nfev_per_step']:.2f} field evaluations "
        f"per step). Subnormal penalty (Gonzalez near the pole, eps = 1e-3): {penalty['normal']:.0f} ns/step with "
        f"normal off-axis components, {penalty['subnormal']:.0f} ns/step with subnormal ones "
        f"({penalty['subnormal'] / penalty['normal']:.1f}x)."
    )
    return "\n\n".join(
        [
            "## Targets (reported, not asserted)" + (" — QUICK MODE, indicative only" if quick else ""),
            markdown_table(["target", "measured", "aim", "verdict"], rows),
            notes,
        ]
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs, for iteration")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    info = machine()
    log = lambda text: print(f"[{time.perf_counter() - start:6.0f} s] {text}", flush=True)  # noqa: E731
    log("benchmark")
    bench_text, ratios, overhead = benchmark.run(args.quick, log)
    log("long run")
    long = long_run.measure(LONG_STEPS[args.quick])
    penalty = long_run.subnormal_penalty()
    log("work-precision")
    wp_text, fastest = work_precision.main(args.quick, log=log)
    log("newton tolerance")
    newton_text = newton_tolerance.main(args.quick, log=log)
    log("drift")
    drift_text = drift.main(args.quick, log=log)
    elapsed = time.perf_counter() - start
    skipped = []
    methods = ", ".join(m.label for m in geomint_methods(skipped=skipped))
    skipped_text = f" Candidates whose constructor refused: {'; '.join(skipped)}." if skipped else ""
    header = "\n\n".join(
        [
            "# Experiments: long-time drift, work-precision, per-step cost",
            f"Generated by `PYTHONPATH=. python -m experiments.all{' --quick' if args.quick else ''}` in "
            f"{elapsed:.0f} s. "
            f"geomint methods found: {methods}.{skipped_text} Generic baselines: our compiled "
            f"{BASELINE_RK4} and scipy `solve_ivp`. Timings are wall-clock on a shared machine: compare ratios "
            "measured "
            "in the same run, not absolute values across runs.",
            markdown_table(["machine", ""], [[k, str(v)] for k, v in info.items()]),
        ]
    )
    text = (
        "\n\n".join(
            [
                header,
                targets_section(ratios, overhead, fastest.get("relaxing_rigid_body"), long, penalty, args.quick),
                bench_text,
                wp_text,
                newton_text,
                drift_text,
            ]
        )
        + "\n"
    )
    DOCS.mkdir(exist_ok=True)
    (DOCS / "experiments.md").write_text(text)
    log(f"wrote {DOCS / 'experiments.md'} ({fmt(elapsed)} s)")


if __name__ == "__main__":
    main()
