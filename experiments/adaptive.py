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
import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import geomint
from geomint.diagnostics import median_time

from .compiled import lsoda_rhs, scipy_rhs
from .runs import lsoda_result

DOCS = Path(__file__).resolve().parents[1] / "docs"
BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
M0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
T = 1000.0
TARGET = 1e-8

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
        if peer in wall:
            lines.append(
                f"- against {peer}: {wall[best] / wall[peer]:.2f}x its time ({wall[peer] / wall[best]:.1f}x faster)"
                if wall[best] < wall[peer]
                else f"- against {peer}: {wall[best] / wall[peer]:.2f}x its time"
            )
    fixed = wall.get("Gonzalez(), fixed h")
    for label in exact_adaptive:
        if "Gonzalez" in label and fixed is not None:
            lines.append(f"- {label} against fixed-step Gonzalez at the same target: {fixed / wall[label]:.0f}x faster")
    return lines


def lsoda_row(rows, error, repeats):
    """Append numbalsoda's row to ``rows`` (loosest rtol reaching the target); returns notes for the page."""
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


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    rhs = scipy_rhs(BODY)
    ref = solve_ivp(rhs, (0.0, T), M0, method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)

    def error(t, x):
        return float(np.max(np.abs(ref.sol(t).T - x)))

    rows = []
    missed = []
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
    lines_after = missed + lsoda_row(rows, error, args.repeats) + ratios(rows)
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
