"""What a user waits for before the first result: the start-up lines of issue 30, each in fresh processes.

    PYTHONPATH=. python -m experiments.startup [--repeats R] [--cold C]

Writes docs/startup_lines.md (~5 min on a 2-core machine).  Every figure is the wall time of a fresh Python
process, or a clock read inside one, and each line is quoted as the median over its processes: a shared machine's
single runs vary by tens of percent.

* ``import geomint``, warm: the import timed inside the process (``R`` processes);
* ``geomint run rigid_body_distinct``, warm: the whole command, its figure drawn, after one run that fills the
  cache (``R`` processes);
* the same, cold: each process with a cache folder of its own, empty (``GEOMINT_CACHE_DIR``; ``C`` processes):
  what the first run after an install costs;
* the first ``solve`` of a new user system: a module of five ``numba.njit`` functions (the relaxing rigid body
  written out) under a name no process has seen, solved with Gonzalez at h = 0.01 over (0, 10); the solve timed
  inside the process (compilation included), and the process from start to end; then a second process that
  builds and solves the same system (its kernels found on disk), timed from before ``import geomint`` to the end
  of the solve, and as a whole (``R`` new systems).

The user systems' repeats share one cache folder of their own, filled first by a solve of the catalogue's rigid
body (an installed library that has run before), and removed at the end: the user's cache is never written.
"""

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "startup_lines.md"

#: issue 30's limits, in seconds
IMPORT_LIMIT = 0.3
WARM_LIMIT = 3.0
COLD_LIMIT = 15.0
FIRST_SOLVE_LIMIT = 10.0
SECOND_PROCESS_LIMIT = 1.0

#: a user's module: the relaxing rigid body written out (H quadratic, S the Casimir |m|^2 / 2, J = m)
USER_MODULE = """\
import numba


@numba.njit
def H(m, p):
    return 0.5 * (p[0] * m[0] * m[0] + p[1] * m[1] * m[1] + p[2] * m[2] * m[2])


@numba.njit
def grad_H(m, p):
    return (p[0] * m[0], p[1] * m[1], p[2] * m[2])


@numba.njit
def S(m, p):
    return 0.5 * (m[0] * m[0] + m[1] * m[1] + m[2] * m[2])


@numba.njit
def grad_S(m, p):
    return (m[0], m[1], m[2])


@numba.njit
def J(m, p):
    return (m[0], m[1], m[2])
"""

#: the user's script: prints the seconds from before ``import geomint`` to the end of the solve, and of the solve
USER_SCRIPT = """\
import time

started = time.perf_counter()
import numpy as np

import geomint
import {module} as u

system = geomint.MetriplecticSystem(
    H=u.H, grad_H=u.grad_H, S=u.S, grad_S=u.grad_S, J=u.J, params=[0.5, 1.0, 1.5], eps=0.1
)
before = time.perf_counter()
sol = geomint.solve(system, [np.cos(1.1), 0.0, np.sin(1.1)], (0.0, 10.0), 0.01)
done = time.perf_counter()
assert sol.success, sol.message
print(done - started, done - before)
"""

IMPORT_SCRIPT = "import time; t = time.perf_counter(); import geomint; print(time.perf_counter() - t)"
CLI = "import sys; from geomint.cli import main; sys.exit(main(sys.argv[1:]))"
WARM_UP = (
    "import numpy as np, geomint; geomint.solve(geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1), "
    "[np.cos(1.1), 0.0, np.sin(1.1)], (0.0, 10.0), 0.01)"
)


def _process(args, env=None, cwd=None):
    """``(wall seconds, stdout)`` of a fresh Python process running ``args``; raises where it fails."""
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, *args], env=env, cwd=cwd, capture_output=True, text=True, check=False, timeout=600
    )
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise RuntimeError(f"{args[:2]} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return wall, done.stdout


def _environment(cache=None, path=None):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (path, str(ROOT), env.get("PYTHONPATH")) if p)
    if cache is not None:
        env["GEOMINT_CACHE_DIR"] = str(cache)
    return env


def import_times(repeats):
    return [float(_process(["-c", IMPORT_SCRIPT], _environment())[1]) for _ in range(repeats)]


def command_line_times(repeats, cold):
    """``(warm walls, cold walls)`` of ``geomint run rigid_body_distinct`` (its figure drawn)."""
    with tempfile.TemporaryDirectory() as scratch:
        out = ["-c", CLI, "run", "rigid_body_distinct", "--out", str(Path(scratch) / "out"), "--quiet"]
        cold_walls = []
        for k in range(cold):
            cache = Path(scratch) / f"cache{k}"
            cache.mkdir()
            cold_walls.append(_process(out, _environment(cache))[0])
        _process(out, _environment())  # fills the user's cache, as a first run did
        warm_walls = [_process(out, _environment())[0] for _ in range(repeats)]
    return warm_walls, cold_walls


def user_system_times(repeats):
    """Per new user system: ``(first solve, first process, second in process, second process)`` in seconds."""
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        cache = Path(scratch) / "cache"
        cache.mkdir()
        _process(["-c", WARM_UP], _environment(cache))
        for k in range(repeats):
            folder = Path(scratch) / f"user{k}"
            folder.mkdir()
            module = f"user_system_{os.getpid()}_{time.time_ns()}_{k}"
            (folder / f"{module}.py").write_text(USER_MODULE)
            (folder / "run.py").write_text(USER_SCRIPT.format(module=module))
            env = _environment(cache, str(folder))
            first_wall, first = _process(["run.py"], env, folder)
            second_wall, second = _process(["run.py"], env, folder)
            rows.append((float(first.split()[1]), first_wall, float(second.split()[0]), second_wall))
    return rows


def _seconds(values):
    return ", ".join(f"{v:.2f}" for v in values)


def _line(name, values, limit):
    median = statistics.median(values)
    verdict = "holds" if median <= limit else "missed"
    return f"| {name} | {_seconds(values)} | **{median:.2f}** | {limit:g} | {verdict} |"


def page(imports, warm, cold, users):
    first, first_wall, second, second_wall = (list(column) for column in zip(*users))
    lines = [
        "# Start-up lines, measured",
        "",
        "Regenerate: `PYTHONPATH=. python -m experiments.startup` (the module's docstring says what each line",
        "times). Seconds, each a fresh process; the median over the processes is the figure issue 30 limits.",
        f"Measured on {time.strftime('%Y-%m-%d')}, {os.cpu_count()} cores, Python {platform.python_version()},",
        f"numba {numba.__version__}, on a shared machine: compare within this page, not across days.",
        "",
        "| line | per process | median | limit | |",
        "| --- | --- | --- | --- | --- |",
        _line("`import geomint`, warm (in the process)", imports, IMPORT_LIMIT),
        _line("`geomint run rigid_body_distinct`, warm (the process)", warm, WARM_LIMIT),
        _line("the same, cold: an empty cache (the process)", cold, COLD_LIMIT),
        _line("first `solve` of a new user system, compilation included", first, FIRST_SOLVE_LIMIT),
        _line("a second process: import, system, solve (in the process)", second, SECOND_PROCESS_LIMIT),
        "",
        "Beside them, not limited: the new user system's first process as a whole "
        f"({_seconds(first_wall)}; median {statistics.median(first_wall):.2f}) and the second process as a whole "
        f"({_seconds(second_wall)}; median {statistics.median(second_wall):.2f}), Python's own start included.",
        "",
        "docs/startup.md says what a first run compiles and where its seconds go.",
        "",
    ]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="processes per warm line and new user systems")
    parser.add_argument("--cold", type=int, default=3, help="cold command-line processes")
    args = parser.parse_args(argv)
    imports = import_times(args.repeats)
    warm, cold = command_line_times(args.repeats, args.cold)
    users = user_system_times(args.repeats)
    text = page(imports, warm, cold, users)
    PAGE.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
