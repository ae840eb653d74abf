"""What a scene costs: effects switched off, the progress bar, and memory of final-state-only runs.

    PYTHONPATH=. python experiments/scene_costs.py [--steps 200000] [--repeats 5]

1. Hamiltonian-only (``eps = 0``) and dissipation-only (``hamiltonian = false``)
   scenes against the full field, for Gonzalez and RK4: median wall time of
   ``--repeats`` runs (one process, after a warm-up that compiles), the ratio to
   the full field, and Newton iterations per step.
2. The progress callback (a tqdm bar writing to /dev/null, called every 100 000
   steps) against none: ratio of medians.
3. Peak RSS of a final-state-only scene (``every = "final"``) of 10^6 and 10^7
   steps, each in a fresh process, against a 10-step run: constant memory means
   the three agree.

Uses only the public API (``geomint.Scene``, ``geomint.run_scene``).
"""

import argparse
import os
import statistics
import subprocess
import sys
import time

import geomint

RIGID = dict(
    system="relaxing_rigid_body",
    parameters={"a": 0.5, "b": 1.0, "c": 1.5},
    points=[[0.4535961214255773, 0.0, 0.8912073600614354]],
    record=(),
    every="final",
    figures=(),
)
# eps small enough that the body does not relax within the run (a relaxed state makes Newton trivial)
EPS = 1e-4
EFFECTS = {
    "full field": dict(eps=EPS),
    "Hamiltonian only": dict(eps=0.0),
    "dissipation only": dict(eps=EPS, hamiltonian=False),
}


def _interleaved(runs, repeats):
    """Median wall time of the integration (``SceneResult.wall``: the solves, without resolving the scene)
    and last result of each ``label -> (scene, progress factory)``; runs taken round-robin so that a change
    in machine load hits every variant alike."""
    walls = {label: [] for label in runs}
    results = {}
    for _ in range(repeats):
        for label, (scene, make_progress) in runs.items():
            with make_progress() as progress:
                results[label] = geomint.run_scene(scene, progress=progress)
            walls[label].append(sum(results[label].wall))
            assert results[label].success, results[label].solutions[0].message
    return {label: (statistics.median(w), results[label]) for label, w in walls.items()}


class _NoProgress:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def effects_table(steps, repeats):
    print(f"## Effects: {steps} steps, relaxing rigid body, eps = {EPS:g}, median of {repeats} (one process)\n")
    print("| method | scene | median s | ns/step | ratio to full | Newton it./step |")
    print("|---|---|---|---|---|---|")
    for method in ("gonzalez", "rk4"):
        runs = {}
        for label, effects in EFFECTS.items():
            scene = geomint.Scene(**RIGID, **effects, integrator=method, h=0.01, duration=steps * 0.01)
            geomint.run_scene(scene.replace(duration=0.05))  # compile this kernel form
            runs[label] = (scene, _NoProgress)
        rows = _interleaved(runs, repeats)
        full = rows["full field"][0]
        for label, (wall, result) in rows.items():
            print(
                f"| {method} | {label} | {wall:.4f} | {1e9 * wall / steps:.0f} | {wall / full:.3f} | "
                f"{result.solutions[0].n_newton / steps:.2f} |"
            )
    print()


def progress_cost(steps, repeats):
    from tqdm import tqdm

    scene = geomint.Scene(**RIGID, eps=EPS, h=0.01, duration=steps * 0.01)
    geomint.run_scene(scene.replace(duration=0.05))
    sink = open(os.devnull, "w")

    class _Bar:
        def __enter__(self):
            self.bar = tqdm(total=steps, file=sink, mininterval=0.0)
            return self.bar.update

        def __exit__(self, *exc):
            self.bar.close()
            return False

    rows = _interleaved({"without": (scene, _NoProgress), "with tqdm": (scene, _Bar)}, repeats)
    sink.close()
    plain, barred = rows["without"][0], rows["with tqdm"][0]
    system = scene.build_system()
    x0 = scene.points[0]
    one_step = statistics.median(_timed(lambda: geomint.solve(system, x0, (0.0, 0.01), 0.01)) for _ in range(200))
    chunks = -(-steps // 100_000)
    print(f"## Progress bar: {steps} Gonzalez steps, median of {repeats}, runs interleaved\n")
    print(
        f"without: {plain:.4f} s, with tqdm updated every 100 000 steps: {barred:.4f} s, "
        f"ratio {barred / plain:.4f} ({100 * (barred / plain - 1):+.2f} %)"
    )
    print(
        f"bound from the parts: a whole 1-step solve (validation, allocation, kernel call) takes "
        f"{1e6 * one_step:.0f} us; {chunks} chunks cost at most {chunks * one_step:.4f} s = "
        f"{100 * chunks * one_step / plain:.3f} % of the run\n"
    )


def _timed(fn):
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


_RSS = """
import resource, time, geomint
scene = geomint.Scene(system="relaxing_rigid_body", points=[[0.4535961214255773, 0.0, 0.8912073600614354]],
                      eps=1e-4, h=0.01, duration={steps} * 0.01, record=(), every="final", figures=())
start = time.perf_counter()
result = geomint.run_scene(scene)
wall = time.perf_counter() - start
assert result.success
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, wall, result.solutions[0].n_steps, len(result.solutions[0].t))
"""


def peak_rss():
    print("## Peak RSS of final-state-only scenes (fresh process each)\n")
    print("| steps | rows kept | peak RSS MiB | wall s |")
    print("|---|---|---|---|")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.getcwd(), os.environ.get("PYTHONPATH", "")])}
    for steps in (10, 10**6, 10**7):
        done = subprocess.run(
            [sys.executable, "-c", _RSS.replace("{steps}", str(steps))],
            capture_output=True,
            text=True,
            env=env,
            check=True,
        )
        rss_kib, wall, n_steps, rows = done.stdout.split()
        print(f"| {int(n_steps):,} | {rows} | {int(rss_kib) / 1024:.1f} | {float(wall):.2f} |")
    print()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"geomint {geomint.__version__}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}\n")
    effects_table(args.steps, args.repeats)
    progress_cost(10 * args.steps, args.repeats)
    peak_rss()


if __name__ == "__main__":
    main()
