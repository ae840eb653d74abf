"""What accuracy costs with adaptive steps: time to reach a given error along the trajectory.

    PYTHONPATH=. python -m experiments.adaptive [--repeats R]

Writes docs/adaptive_speed.md.  Relaxing rigid body (0.5, 1, 1.5), eps = 0.1,
m0 = (cos 1.1, 0, sin 1.1), T = 1000.  For each method and tolerance (rtol =
atol) the run is timed (compiled code warmed up; medians of ``R`` interleaved
repeats, one process) and its error measured **along the trajectory**: the
largest deviation over all returned states from scipy's DOP853 at rtol 1e-13
(dense output), since the relaxed final state says nothing.  The fixed-step
rows halve h until the same measure is met.  scipy's DOP853 and LSODA get the
field compiled for this system (``compiled.scipy_rhs``, ~1 us a call from
Python: the fastest right-hand side a scipy user can hand over).  numbalsoda (compiled LSODA, benchmark extra ``pip
install
geomint[bench]``) gets the field as a compiled C callback (``compiled.lsoda_rhs``)
and returns its interpolant at 1001 equally spaced times, where its error is
measured; it is left out, and said so, when it is not installed.
"""

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import geomint
from geomint.diagnostics import median_time

from .compiled import lsoda_rhs, scipy_rhs
from .runs import lsoda_result

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
M0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
T = 1000.0
TARGET = 1e-8
#: the head-to-head timing of the fastest H-exact, S-monotone method against numbalsoda: fresh processes, and
#: interleaved repeats in each (the issue's rule: ratios from one run, medians over fresh processes)
PROCESSES = 5
HEAD_REPEATS = 51

#: label -> method; the "H exact, S monotone" column is read from each method's declared traits
ADAPTIVE = {
    "Projected(DormandPrince853()), adaptive": geomint.Projected(geomint.DormandPrince853()),
    "Projected(DormandPrince54()), adaptive": geomint.Projected(geomint.DormandPrince54()),
    "Gonzalez(), adaptive": geomint.Gonzalez(),
    "Yoshida4(Gonzalez(), monotone=True), adaptive (step doubling)": geomint.Yoshida4(
        geomint.Gonzalez(), monotone=True
    ),
}
FIXED = {
    "Projected(RK4()), fixed h": geomint.Projected(),
    "Gonzalez(), fixed h": geomint.Gonzalez(),
    "RK4(), fixed h": geomint.RK4(),
}


def _timed(run, repeats):
    """Median wall time of ``run()`` over ``repeats`` calls, none cut short; ``(seconds, last result)``."""
    return median_time(run, repeats, budget=math.inf)


#: the page's reading: what the figures are made of, measured when the comparison with numbalsoda was closed
READING = [
    "## Reading",
    "**What a solve costs at this size.** numbalsoda's LSODA takes ~670 steps of a multistep method, about one "
    "field evaluation each, in compiled code from one call. The projected Dormand-Prince 8(5,3) pair takes 181 "
    "steps of ~15 evaluations (13 for the stages and the estimate, 2 for the projection onto H = H0 with S kept "
    "from rising), and a `solve` call validates its arguments, allocates its outputs, makes one compiled call "
    "and builds the Solution. Measured on 2026-11-26 (one process, medians): a one-step `solve` of the relaxing "
    "body costs 55-70 us, and each of the 181 steps 0.25-0.3 us; the whole run, 0.11-0.14 ms.",
    "**What it cost before.** The same run took 0.21-0.24 ms (2.0x numbalsoda on this page, 2.7x before that): "
    "the call cost 110-125 us and a step 0.5 us. Where the call's time went, measured statement by statement: "
    "the first step was chosen by a compiled call of its own (numba's dispatch of the loop and of that call, "
    "5-8 us each, most of it typing the model in Python; the loop now chooses it, `control.start`, and the "
    "model hands numba its type through `_numba_type_`); the run's status, a numpy integer, was compared with an "
    "`IntEnum` twice a call (3 us a comparison); an integrator's traits were rebuilt at each of six reads and the "
    "pair's tableau arrays at each call; numpy's `finfo`, the machine's memory size and the two guards (user "
    "errors, Ctrl-C) as generators added the rest. A step called the field, not inlined, in each of its 12 "
    "stages and tested each of the 66 entries of the tableau's lower triangle; the stages now inline the field "
    "(one call site, compiled once) and walk the 50 nonzero entries from a row-wise list. The same states, bit "
    "for bit (`tests/test_digests.py`).",
    "**What is left.** The two run even, not yet ahead: over nine runs of this script in two hours on this "
    "shared machine the median over processes moved between 0.93 and 1.08 (0.93, 0.98, 0.98, 1.00, 1.02, 1.03, 1.04, "
    "1.06, 1.08; numbalsoda's own time between 110 and 135 us), so issue 30's line (no more time than LSODA) "
    "holds on some runs and not on others; a run later that day, the machine slower for Python (a one-step call "
    "70-75 us, 55-70 us earlier that day), read 1.03, and the run on this page, an hour later, 0.98. Half of "
    "geomint's time is still the call's "
    "fixed cost; of a step's, two `pow` for the PI controller take a tenth (perf) and the rest is the stages' "
    "arithmetic. A longer span or a larger system tips it towards the steps, where LSODA's single evaluation a "
    "step is the harder floor.",
    "**Ahead, later that day.** Timed statement by statement inside `solve` (a run of 181 steps, one process): the "
    "compiled call 57 us, the rest 35 us, of which the check that H and S are finite at x0 took 3-10 us (two "
    "calls of user functions from Python, each through numba's dispatcher), building the Solution 8 us. The "
    "check now reads H(x0) and S(x0) from the run's first row, which the loop evaluates anyway "
    "(`solve._check_start`: where either is not finite, or a user function raised, the same check runs as "
    "before and raises the same error; `tests/test_user_errors.py`); the Solution reads its counters once and "
    "its status from a dict. Measured against the commit before in alternating fresh processes, 6 each, the "
    "same hour: this page's head-to-head, geomint / numbalsoda 0.91-0.97 (median 0.94) before, 0.75-0.93 "
    "(median 0.86) after; with a one-step `solve` timed between the two (101 interleaved runs per process), "
    "0.79-0.98 (median 0.93) before, 0.75-0.90 (median 0.76) after, the one-step call 43-72 us before and "
    "41-54 us after. Runs of this page alone, that hour: 0.93, 0.93, 0.96 (the last is the one below). The "
    "head-to-head processes now run with OpenBLAS single-threaded (`OPENBLAS_NUM_THREADS=1`): neither side "
    "calls BLAS, and its idle threads, seen polling in perf, stay off the second core.",
    "**Measured again on 2026-11-27.** numbalsoda builds from source with a Fortran compiler (`apt-get install "
    "gfortran`, then `pip install geomint[bench]`); without one the page leaves LSODA out and issue 30's line "
    "cannot be read. A first run that day chose the method for the head-to-head from the table's single median of "
    "5 repeats: Projected(DormandPrince54()) at 0.19 ms against Projected(DormandPrince853()) at 0.26 ms, on a "
    "machine then twice as slow for scipy as the page's run before (DOP853 21 ms against 11), and read 1.45 x "
    "LSODA for DormandPrince54; timed head to head in one fresh process, the two pairs took 214 and 302 us and "
    "LSODA 217 us. The head-to-head now times every adaptive H-exact, S-monotone method within 3 x of the table's "
    "fastest against LSODA in the same processes, and reads the line on the method with the smallest median; the "
    "table and the head-to-head above are the next run, the same hour.",
]


def _exact(method):
    return bool(method.energy_exact and method.dissipative)


def ratios(rows):
    """The comparisons the page makes, read off the table (same run)."""
    wall = {row[0]: row[-1] for row in rows}
    exact_adaptive = {label: wall[label] for label, method in ADAPTIVE.items() if _exact(method) and label in wall}
    if not exact_adaptive:
        return ["No adaptive H-exact, S-monotone method reaches the target."]
    best = min(exact_adaptive, key=exact_adaptive.get)
    lines = [f"Fastest adaptive H-exact, S-monotone method: {best}, {1e3 * wall[best]:.2f} ms."]
    for peer in ("numbalsoda LSODA (compiled)", "scipy DOP853"):
        if peer in wall:  # the table's single-process medians: the head-to-head below is what issue 30 reads
            ratio = wall[best] / wall[peer]
            faster = f" ({1 / ratio:.1f}x faster)" if ratio < 1 else ""
            lines.append(f"- against {peer}, in the table: {ratio:.2f}x its time{faster}")
    fixed = wall.get("Gonzalez(), fixed h")
    for label in exact_adaptive:
        if "Gonzalez" in label and fixed is not None:
            lines.append(f"- {label} against fixed-step Gonzalez at the same target: {fixed / wall[label]:.0f}x faster")
    return lines


def lsoda_row(rows, error, repeats, chosen):
    """Append numbalsoda's row to ``rows`` (loosest rtol reaching the target, also put in ``chosen``); returns
    notes for the page."""
    try:
        rhs = lsoda_rhs(BODY)
    except ImportError:
        return [
            "numbalsoda is not installed in this run (`pip install geomint[bench]`; it builds from source and "
            "needs a Fortran compiler, e.g. Debian's gfortran), so compiled LSODA is not in the table."
        ]
    t_eval = np.linspace(0.0, T, 1001)
    for tol in np.logspace(-6, -13, 15):
        states, ok = lsoda_result(rhs, M0, t_eval, tol, tol)
        if ok and error(t_eval, states) <= TARGET:
            wall, (states, ok) = _timed(lambda: lsoda_result(rhs, M0, t_eval, tol, tol), repeats)
            chosen["numbalsoda LSODA (compiled)"] = float(tol)
            H = BODY.H(states)
            rows.append(
                (
                    "numbalsoda LSODA (compiled)",
                    False,
                    f"rtol = atol = {tol:.1e}",
                    error(t_eval, states),
                    "—",
                    "—",
                    float(np.max(np.abs(H - H[0])) / H[0]),
                    int(np.count_nonzero(np.diff(BODY.S(states)) > 0)),
                    wall,
                )
            )
            return [
                "numbalsoda returns its interpolant at 1001 equally spaced times (its step count is not "
                "reported); its error is measured there."
            ]
    return ["numbalsoda LSODA does not reach the target for rtol down to 1e-13."]


#: a method whose table time is within this factor of the fastest is timed head to head too: the table's single
#: median of a few repeats cannot tell two methods ~30 % apart on a shared machine
CANDIDATE_FACTOR = 3.0


def head_to_head(rows, chosen):
    """The page's lines on the adaptive H-exact, S-monotone methods against numbalsoda's LSODA, each at the
    tolerance that reached the target: every such method within ``CANDIDATE_FACTOR`` of the fastest in the table,
    timed in ``PROCESSES`` fresh processes (``--head-to-head``) of ``HEAD_REPEATS`` interleaved runs of all of
    them and LSODA; per method the ratio of medians per process and their median; the line is read on the method
    with the smallest median."""
    peer = "numbalsoda LSODA (compiled)"
    exact = {row[0]: row[-1] for row in rows if row[1] and row[0] in ADAPTIVE}
    if peer not in chosen or not exact:
        return []
    fastest = min(exact.values())
    labels = [label for label, wall in exact.items() if wall <= CANDIDATE_FACTOR * fastest]
    command = [sys.executable, "-m", "experiments.adaptive", "--head-to-head", json.dumps(labels)]
    command += [json.dumps([chosen[label] for label in labels]), repr(chosen[peer])]
    # OpenBLAS single-threaded: neither side calls BLAS, and its idle threads (seen polling in perf) stay off the
    # second core of a two-core machine
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    runs = [
        json.loads(subprocess.run(command, cwd=ROOT, env=env, capture_output=True, check=True, text=True).stdout)
        for _ in range(PROCESSES)
    ]
    theirs = ", ".join(f"{1e6 * run['lsoda']:.0f}" for run in runs)
    lines = [
        f"Head to head, in {PROCESSES} fresh processes of {HEAD_REPEATS} interleaved runs each (medians per "
        f"process), every adaptive H-exact, S-monotone method within {CANDIDATE_FACTOR:g}x of the fastest in the "
        f"table: numbalsoda LSODA at rtol = atol = {chosen[peer]:.1e}, {theirs} us.",
    ]
    medians = {}
    for label in labels:
        ratio = [run[label] / run["lsoda"] for run in runs]
        medians[label] = statistics.median(ratio)
        ours = ", ".join(f"{1e6 * run[label]:.0f}" for run in runs)
        lines.append(
            f"- {label} at rtol = atol = {chosen[label]:.1e}: {ours} us; geomint / numbalsoda per process "
            f"{', '.join(f'{r:.2f}' for r in ratio)}, median {medians[label]:.2f}"
        )
    best = min(medians, key=medians.get)
    lines.append(
        f"- the line (an H-exact, S-monotone method in no more time than LSODA): {best}, median "
        f"{medians[best]:.2f} (target at most 1: {'holds' if medians[best] <= 1.0 else 'not met'})"
    )
    return lines


def _head_to_head_process(labels, tols, lsoda_tol):
    """One process of ``head_to_head``: medians of ``HEAD_REPEATS`` interleaved runs, printed as JSON."""
    rhs = lsoda_rhs(BODY)
    t_eval = np.linspace(0.0, T, 1001)
    runs = {
        label: (
            lambda method=ADAPTIVE[label], tol=tol: geomint.solve(BODY, M0, (0.0, T), rtol=tol, atol=tol, method=method)
        )
        for label, tol in zip(labels, tols, strict=True)
    }
    runs["lsoda"] = lambda: lsoda_result(rhs, M0, t_eval, lsoda_tol, lsoda_tol)
    times = {name: [] for name in runs}
    for _ in range(3):  # compiled, warmed
        for run in runs.values():
            run()
    for _ in range(HEAD_REPEATS):
        for name, run in runs.items():
            start = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - start)
    print(json.dumps({name: statistics.median(values) for name, values in times.items()}))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--head-to-head", nargs=3, metavar=("LABELS", "RTOLS", "LSODA_RTOL"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.head_to_head:
        labels, tols, lsoda_tol = args.head_to_head
        _head_to_head_process(json.loads(labels), json.loads(tols), float(lsoda_tol))
        return
    rhs = scipy_rhs(BODY)
    ref = solve_ivp(rhs, (0.0, T), M0, method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)

    def error(t, x):
        return float(np.max(np.abs(ref.sol(t).T - x)))

    rows = []
    missed = []
    chosen = {}  # label -> the tolerance that reached the target
    for label, method in ADAPTIVE.items():
        best = np.inf
        for tol in np.logspace(-6, -12, 13):
            sol = geomint.solve(BODY, M0, (0.0, T), rtol=tol, atol=tol, method=method)
            if sol.success:
                best = min(best, error(sol.t, sol.x))
            if sol.success and error(sol.t, sol.x) <= TARGET:
                wall, sol = _timed(
                    lambda: geomint.solve(BODY, M0, (0.0, T), rtol=tol, atol=tol, method=method), args.repeats
                )
                chosen[label] = float(tol)
                rows.append(
                    (
                        label,
                        _exact(method),
                        f"rtol = atol = {tol:.1e}",
                        error(sol.t, sol.x),
                        sol.n_steps,
                        sol.n_rejected,
                        sol.energy_error,
                        sol.S_rises,
                        wall,
                    )
                )
                break
        else:
            missed.append(
                f"{label} does not reach {TARGET:g} for rtol = atol down to 1e-12 (smallest error {best:.2e})."
            )
    for label, method in FIXED.items():
        h = 0.1
        while True:
            sol = geomint.solve(BODY, M0, (0.0, T), h, method=method)
            if sol.success and error(sol.t, sol.x) <= TARGET:
                break
            h /= 2
        wall, sol = _timed(
            lambda: geomint.solve(BODY, M0, (0.0, T), h, method=method, save_every=1), max(1, args.repeats // 2)
        )
        rows.append(
            (
                label,
                _exact(method),
                f"h = {h:.3g}",
                error(sol.t, sol.x),
                sol.n_steps,
                0,
                sol.energy_error,
                sol.S_rises,
                wall,
            )
        )
    for name in ("DOP853", "LSODA"):
        for tol in np.logspace(-6, -13, 15):
            res = solve_ivp(rhs, (0.0, T), M0, method=name, rtol=tol, atol=tol)
            if res.success and error(res.t, res.y.T) <= TARGET:
                wall, res = _timed(lambda: solve_ivp(rhs, (0.0, T), M0, method=name, rtol=tol, atol=tol), args.repeats)
                H = BODY.H(res.y.T)
                rows.append(
                    (
                        f"scipy {name}",
                        False,
                        f"rtol = atol = {tol:.1e}",
                        error(res.t, res.y.T),
                        res.t.size - 1,
                        0,
                        float(np.max(np.abs(H - H[0])) / H[0]),
                        int(np.count_nonzero(np.diff(BODY.S(res.y.T)) > 0)),
                        wall,
                    )
                )
                break
    lines_after = missed + lsoda_row(rows, error, args.repeats, chosen) + ratios(rows) + head_to_head(rows, chosen)
    lines_after += READING
    lines = [
        "# Adaptive steps: what 1e-8 along the trajectory costs",
        "",
        f"Generated by `PYTHONPATH=. python -m experiments.adaptive` (medians of {args.repeats} repeats, one process). "
        f"Relaxing rigid body (0.5, 1, 1.5), eps = 0.1, m0 = (cos 1.1, 0, sin 1.1), T = {T:g}; error = max over all "
        "returned states of the distance to scipy's DOP853 at rtol 1e-13. For each method the loosest tolerance "
        "(or largest h, halving) that reaches the target.",
        "",
        "| method | H exact, S monotone | setting | error | steps | rejected | max \\|ΔH\\|/H0 | S rises | ms |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for label, exact, setting, err, steps, rejected, dH, rises, wall in rows:
        lines.append(
            f"| {label} | {'yes' if exact else 'no'} | {setting} | {err:.2e} | {steps} | {rejected} | "
            f"{dH:.1e} | {rises} | {1e3 * wall:.2f} |"
        )
    for note in lines_after:  # paragraphs, and a loose list
        lines += ["", note]
    (DOCS / "adaptive_speed.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
