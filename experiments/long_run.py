"""10^8 Gonzalez steps on the relaxing rigid body keeping only the final state: wall time and peak memory.

    PYTHONPATH=. python -m experiments.long_run [--steps 1e8] [--eps 1e-4] [--h 0.01]

Runs in a fresh process (``measure`` starts one) so the peak resident memory is
this run's: VmHWM after importing geomint and compiling (baseline) and after
the run.  eps = 1e-4, h = 0.01 (t = 1e6) keeps the decaying components
of the state in the normal range (eps = 1e-3 drives them to ~1e-321, and
subnormal arithmetic is much slower: ``subnormal_penalty`` measures it).
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import geomint

from . import problems
from .methods import GONZALEZ, geomint_methods

SMALLEST_NORMAL = np.finfo(np.float64).tiny


def _peak_mb():
    """This process's peak resident memory (VmHWM).

    Not ``ru_maxrss``: Linux carries that across fork+exec, so a child started
    by a large parent would report the parent's size.
    """
    try:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) for line in status if line.startswith("VmHWM")) / 1024.0
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _gonzalez():
    return next(m.integrator for m in geomint_methods() if m.label == GONZALEZ)


def run(steps, eps, h):
    """In this process: compile, then ``steps`` steps with ``save_every=None``."""
    problem = problems.relaxing_rigid_body(eps)
    method = _gonzalez()
    geomint.solve(problem.system, problem.x0, (0.0, 10 * h), h, method=method, save_every=None)
    baseline = _peak_mb()
    start = time.perf_counter()
    solution = geomint.solve(problem.system, problem.x0, (0.0, steps * h), h, method=method, save_every=None)
    wall = time.perf_counter() - start
    x = np.abs(solution.x_final)
    return {
        "steps": solution.n_steps,
        "eps": eps,
        "h": h,
        "wall_s": wall,
        "ns_per_step": 1e9 * wall / solution.n_steps,
        "peak_rss_mb": _peak_mb(),
        "baseline_rss_mb": baseline,
        "success": solution.success,
        "energy_error": solution.energy_error,
        "newton_per_step": solution.n_newton / solution.n_steps,
        "nfev_per_step": solution.nfev / solution.n_steps,
        "distance_to_attractor": float(np.linalg.norm(solution.x_final - problem.attractor)),
        "subnormal_components": int(np.count_nonzero((x > 0) & (x < SMALLEST_NORMAL))),
        "x_final": solution.x_final.tolist(),
    }


def subnormal_penalty(steps=200_000, h=0.01):
    """ns/step of Gonzalez near the pole with normal vs subnormal off-axis components (same problem, eps = 1e-3)."""
    problem = problems.relaxing_rigid_body(1e-3)
    method = _gonzalez()
    pole = problem.attractor
    result = {}
    for label, offset in (("normal", 1e-30), ("subnormal", 1e-318)):
        x0 = pole + np.array([offset, offset, 0.0])
        geomint.solve(problem.system, x0, (0.0, 10 * h), h, method=method, save_every=None)
        start = time.perf_counter()
        geomint.solve(problem.system, x0, (0.0, steps * h), h, method=method, save_every=None)
        result[label] = 1e9 * (time.perf_counter() - start) / steps
    return result


def measure(steps, eps=1e-4, h=0.01):
    """``run`` in a fresh Python process; returns its JSON result.

    A first short process fills numba's disk cache, so the measured process
    loads the kernels instead of compiling them (compilation alone peaks at
    ~70 MB more than a loaded kernel: that is a one-off, not the run's memory).
    """
    root = Path(__file__).resolve().parent.parent
    environment = {**os.environ, "PYTHONPATH": str(root)}
    for count in (10, steps):
        command = [
            sys.executable,
            "-m",
            "experiments.long_run",
            "--steps",
            str(int(count)),
            "--eps",
            repr(eps),
            "--h",
            repr(h),
        ]
        done = subprocess.run(command, capture_output=True, text=True, cwd=root, check=True, env=environment)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=float, default=1e8)
    parser.add_argument("--eps", type=float, default=1e-4)
    parser.add_argument("--h", type=float, default=0.01)
    args = parser.parse_args(argv)
    print(json.dumps(run(int(args.steps), args.eps, args.h)))


if __name__ == "__main__":
    main()
