"""Where the discrete-gradient methods' implicit step stops while RK4 runs; prints a Markdown table.

For random starts in the box [-1.2, 1.2]^n (seed fixed) on the relaxing and the quartic rigid body (eps = 0.5) and
a random Fish system in R^4 (eps = 0.5, the R^n engine),
8 fixed steps of h = r / lambda(x0) for r = 0.5, 0.6, ..., 3.0, lambda the largest |eigenvalue| of the field's
Jacobian (``geomint.analysis.linearise``): the pairs (start, r) where the generic RK4 runs (RK4 is stable to
h lambda = 2.78 on a linear problem) and the method stops, with the smallest ``h lambda(x0)`` among them and the
statuses (-1: Newton's iteration failed).  docs/hard_cases.md, "Long forward steps", reads it.

Public API only.  Run:  PYTHONPATH=. python experiments/newton_reach.py [--starts 100]
"""

import argparse

import numpy as np

import geomint
from geomint.analysis import linearise

METHODS = ("Gonzalez", "ItohAbe", "SymmetrizedItohAbe", "AVF", "DampedGonzalez")
RATIOS = np.round(np.arange(0.5, 3.01, 0.1), 10)
SEED = 2


def stiffness(system, x):
    """The largest |eigenvalue| of the field's Jacobian at ``x``."""
    return float(np.max(np.abs(linearise(system, x)[1])))


def stops_where_rk4_runs(system, method, x0, rk4_runs):
    """``[(r, status)]``: the ratios r at which ``method`` stops from ``x0`` while RK4 runs."""
    lam = stiffness(system, x0)
    stops = []
    for r, runs in zip(RATIOS, rk4_runs, strict=True):
        if runs:
            sol = geomint.solve(system, x0, (0.0, 8 * r / lam), r / lam, method=method)
            if not sol.success:
                stops.append((r, sol.status))
    return stops


def rk4_verdicts(system, x0):
    lam = stiffness(system, x0)
    return [geomint.solve(system, x0, (0.0, 8 * r / lam), r / lam, method="rk4").success for r in RATIOS]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=100)
    args = parser.parse_args(argv)
    systems = [
        geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.5),
        geomint.systems.quartic_rigid_body(eps=0.5),
        geomint.systems.random_fish(4, seed=3, eps=0.5),
    ]
    print("| system | method | runs stopped where RK4 runs | smallest h lambda among them | statuses |")
    print("|---|---|---|---|---|")
    for system in systems:
        starts = np.random.default_rng(SEED).uniform(-1.2, 1.2, size=(args.starts, system.dim))
        verdicts = [rk4_verdicts(system, x0) for x0 in starts]
        tried = sum(map(sum, verdicts))
        for name in METHODS:
            stops = [
                s
                for x0, v in zip(starts, verdicts, strict=True)
                for s in stops_where_rk4_runs(system, getattr(geomint, name)(), x0, v)
            ]
            smallest = f"{min(r for r, _ in stops):.1f}" if stops else "-"
            statuses = sorted({int(status) for _, status in stops})
            print(f"| {system.name} | {name} | {len(stops)} / {tried} | {smallest} | {statuses} |", flush=True)


if __name__ == "__main__":
    main()
