"""The ``geomint`` command line.

``geomint`` (or ``geomint drift``) integrates the relaxing rigid body
(REFERENCES.md R2) with the Gonzalez discrete-gradient method and with RK4 and
prints the energy and Casimir drift side by side.

Exit codes: 0 success, 1 a run failed numerically, 2 bad command-line input.
"""

import argparse
import sys
import time

import numpy as np

from . import __version__
from .integrators import RK4, Gonzalez
from .solve import solve
from .systems import relaxing_rigid_body


def _positive(kind):
    def parse(text):
        value = kind(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"must be > 0; got {text}")
        return value

    return parse


def _parser():
    parser = argparse.ArgumentParser(prog="geomint", description=__doc__.split("\n\n")[1])
    parser.add_argument("--version", action="version", version=f"geomint {__version__}")
    commands = parser.add_subparsers(dest="command")
    drift = commands.add_parser("drift", help="energy and Casimir drift: Gonzalez vs RK4 (the default)")
    drift.add_argument("--steps", type=_positive(int), default=200_000, help="number of steps (default 200000)")
    drift.add_argument("--h", type=_positive(float), default=0.05, help="step size (default 0.05)")
    drift.add_argument("--eps", type=float, default=0.1, help="perturbation parameter (default 0.1)")
    return parser


def drift(steps, h, eps, out=sys.stdout):
    """Print max |H - H0|/|H0|, S rises and the final S for Gonzalez and RK4."""
    system = relaxing_rigid_body(0.5, 1.0, 1.5, eps=eps)
    x0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
    save_every = max(1, steps // 1000)
    print(f"relaxing rigid body (a, b, c) = (0.5, 1, 1.5), eps = {eps}, m0 = (cos 1.1, 0, sin 1.1)", file=out)
    print(f"h = {h}, {steps} steps (t = {steps * h:g}); S_inf = H0/c = {system.H(x0) / 1.5:.16f}", file=out)
    header = f"{'method':<10}{'max|H-H0|/|H0|':>18}{'S rises':>9}{'S(t_end)':>22}{'wall s':>9}  status"
    print(header, file=out)
    failed = False
    for method in (Gonzalez(), RK4()):
        start = time.perf_counter()
        sol = solve(system, x0, (0.0, steps * h), h, method=method, save_every=save_every)
        wall = time.perf_counter() - start
        print(
            f"{method.name:<10}{sol.energy_error:>18.3e}{sol.S_rises:>9d}{sol.S[-1]:>22.16f}{wall:>9.2f}  "
            f"{'ok' if sol.success else sol.message}",
            file=out,
        )
        failed |= not sol.success
    print("(drift and rises over the states saved every", save_every, "steps)", file=out)
    return 1 if failed else 0


def main(argv=None):
    args = _parser().parse_args(argv)
    if args.command in (None, "drift"):
        steps = getattr(args, "steps", 200_000)
        h = getattr(args, "h", 0.05)
        eps = getattr(args, "eps", 0.1)
        if eps < 0:
            print("geomint: error: --eps must be >= 0", file=sys.stderr)
            return 2
        return drift(steps, h, eps)
    return 2


if __name__ == "__main__":
    sys.exit(main())
