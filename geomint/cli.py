"""The ``geomint`` command line.

    geomint run SCENE [--out DIR] [--quiet]   run a scene: .npz data, JSON summary, PNG figures
    geomint show SCENE                        validate a scene and print it fully resolved (TOML)
    geomint list                              catalogue systems, integrators, bundled scenes
    geomint drift                             Gonzalez vs RK4 drift on the relaxing rigid body

SCENE is a scene file (TOML, see ``geomint.scene``) or the name of a bundled
scene, e.g. ``geomint run rigid_body_distinct``.  Any error prints one line
naming the file, key or option, the rule and the fix (add ``--traceback`` for
the trace).  The output folder is checked before the run starts, and every file
is written under a temporary name and then renamed, so none is ever partial.

Exit codes: 0 success, 1 a run failed numerically (results up to the failure
are written), 2 bad input (command line, scene or output folder), 3 an
internal error, 130 interrupted by Ctrl-C (the trajectories done are written,
marked "partial" in the summary).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, TextIO, cast

import numpy as np

from ._files import atomic
from ._version import __version__
from .integrators import RK4, Gonzalez
from .integrators.data import method_to_data, options_of, short_names
from .run.arguments import MAX_STEPS
from .run.solve import solve
from .run.status import Status
from .scene import (
    FIGURES,
    OBSERVABLES,
    CheckpointError,
    SceneError,
    bundled_scenes,
    catalogue_n,
    load_scene,
    run_scene,
    runs_together,
    solve_together,
)
from .scene.toml import to_toml, toml_value
from .systems import CATALOGUE, RN_CATALOGUE, relaxing_rigid_body

if TYPE_CHECKING:
    import os
    from collections.abc import Sequence

    from .integrators import Integrator
    from .scene import Scene

#: the command line's exit codes (a run's outcome is a ``geomint.Status``)
OK, FAILED, BAD_INPUT, INTERNAL, INTERRUPTED = 0, 1, 2, 3, 130


def _number(kind, minimum, strict, maximum=math.inf):
    """An argparse type: a finite ``kind`` in (minimum, maximum] (``strict``) or [minimum, maximum]."""

    def number(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be {'an integer' if kind is int else 'a number'}; got {text!r}"
            ) from None
        if not (math.isfinite(value) and (value > minimum if strict else value >= minimum) and value <= maximum):
            bounds = f"{'>' if strict else '>='} {minimum:g}" + (f" and <= {maximum:g}" if maximum < math.inf else "")
            raise argparse.ArgumentTypeError(f"must be finite and {bounds}; got {text}")
        return value

    return number


class OutputError(Exception):
    """The output folder cannot take the results (checked before the run)."""


def _parser():
    # (this module's docstring: None only under python -OO, which strips docstrings)
    parser = argparse.ArgumentParser(
        prog="geomint",
        description=cast(str, __doc__).split("\n\n")[1],
        epilog=cast(str, __doc__).split("\n\n")[-1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"geomint {__version__}")
    commands = parser.add_subparsers(dest="command")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--traceback", action="store_true", help="show the Python traceback of an error")
    scene = argparse.ArgumentParser(add_help=False, parents=[common])
    scene.add_argument("scene", metavar="SCENE", help="a scene file (.toml) or the name of a bundled scene")
    run = commands.add_parser("run", parents=[scene], help="run a scene: .npz data, JSON summary, PNG figures")
    run.add_argument("--out", metavar="DIR", type=Path, help="output folder (default: runs/<scene name>)")
    run.add_argument("--quiet", action="store_true", help="no progress bar and no report on stdout")
    run.add_argument(
        "--checkpoint-every",
        metavar="STEPS",
        type=_number(int, 0, True, MAX_STEPS),
        help="keep the run resumable: checkpoint in <out>/<name>.checkpoint/ every STEPS steps (and at Ctrl-C)",
    )
    run.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run from its checkpoint (same scene, same --out); the results "
        "equal an uninterrupted run's bit for bit",
    )
    commands.add_parser("show", parents=[scene], help="validate a scene and print it fully resolved")
    commands.add_parser("list", parents=[common], help="catalogue systems, integrators and bundled scenes")
    drift = commands.add_parser(
        "drift", parents=[common], help="energy and Casimir drift: Gonzalez vs RK4 (the default)"
    )
    drift.add_argument(
        "--steps", type=_number(int, 0, True, MAX_STEPS), default=200_000, help="number of steps (default 200000)"
    )
    drift.add_argument("--h", type=_number(float, 0.0, True), default=0.05, help="step size (default 0.05)")
    drift.add_argument(
        "--eps", type=_number(float, 0.0, False), default=0.1, help="the dissipation parameter ε (default 0.1)"
    )
    return parser


def drift(steps: int, h: float, eps: float, out: TextIO | None = None) -> int:
    """Print max |H - H0|/|H0|, S rises and the final S for Gonzalez and RK4."""
    out = sys.stdout if out is None else out
    system = relaxing_rigid_body(0.5, 1.0, 1.5, eps=eps)
    x0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
    save_every = max(1, steps // 1000)
    print(f"relaxing rigid body (a, b, c) = (0.5, 1, 1.5), eps = {eps}, m0 = (cos 1.1, 0, sin 1.1)", file=out)
    print(f"h = {h}, {steps} steps (t = {steps * h:g}); S_inf = H0/c = {system.H(x0) / 1.5:.16f}", file=out)
    header = f"{'method':<10}{'max|H-H0|/|H0|':>18}{'S rises':>9}{'S(t_end)':>22}{'wall s':>9}  status"
    print(header, file=out)
    failed = False
    for method in (Gonzalez(), RK4()):
        with _CompilationNotice(method.name, sys.stderr):
            solve(system, x0, (0.0, h), h, method=method)  # compiles on first use (said so), outside the timing
        start = time.perf_counter()
        sol = solve(system, x0, (0.0, steps * h), h, method=method, save_every=save_every)
        wall = time.perf_counter() - start
        print(
            f"{method.name:<10}{sol.energy_error:>18.3e}{sol.S_rises:>9d}{sol.S[-1]:>22.16f}{wall:>9.2f}  "
            f"{'ok' if sol.success else sol.message}",
            file=out,
        )
        if sol.status == Status.INTERRUPTED:
            return INTERRUPTED
        failed |= not sol.success
    print("(drift and rises over the states saved every", save_every, "steps)", file=out)
    return FAILED if failed else OK


def run(
    scene_name: str,
    out_dir: str | os.PathLike[str] | None = None,
    quiet: bool = False,
    out: TextIO | None = None,
    checkpoint_every: int | None = None,
    resume: bool = False,
) -> int:
    """``geomint run``: run a scene, write ``<name>.npz``, ``<name>.summary.json`` and figures."""
    out = sys.stdout if out is None else out
    from tqdm import tqdm

    from . import plotting

    scene = load_scene(scene_name).resolved()
    out_dir = Path(out_dir) if out_dir is not None else Path("runs") / scene.name
    data = out_dir / f"{scene.name}.npz"
    summary_path = out_dir / f"{scene.name}.summary.json"
    _check_output(out_dir, [data, summary_path, *(out_dir / f"{scene.name}.{f}.png" for f in scene.figures)])
    folder = out_dir / f"{scene.name}.checkpoint"
    checkpoint = (folder, checkpoint_every) if checkpoint_every is not None or resume else None
    total = scene.steps_per_trajectory * scene.n_trajectories
    with tqdm(
        total=total, unit="step", unit_scale=True, disable=quiet, delay=1.0, file=sys.stderr, desc=scene.name
    ) as bar:

        def prepare(system, method):
            start = scene.built().states[0] if scene.in_rn else None
            _prepare(system, method, scene.h, quiet, runs_together(scene, checkpoint), start)
            bar.unpause()  # the bar's clock (rate, ETA) starts after the compilation

        try:
            result = run_scene(scene, progress=bar.update, checkpoint=checkpoint, resume=resume, before_steps=prepare)
        except CheckpointError as exc:
            raise OutputError(f"--resume: {exc}") from None
    with atomic(data) as temporary:
        np.savez_compressed(
            temporary,
            **result.records,
            x0=np.array([sol.x[0] for sol in result.solutions]),
            status=np.array([sol.status for sol in result.solutions]),
        )
    summary = result.summary()
    with atomic(summary_path) as temporary:
        temporary.write_text(json.dumps(summary, indent=2) + "\n")
    figures = plotting.draw(result, out_dir)
    if not quiet:
        _report(result, summary, [data, summary_path, *figures], out)
    if result.partial:
        resumable = "; resume with --resume" if checkpoint else ""
        cut = " (the last one cut short)" if result.solutions[-1].status == Status.INTERRUPTED else ""
        print(
            f"geomint: interrupted: {len(result.solutions)} of {scene.n_trajectories} trajectories written{cut}, "
            f'marked "partial" in {summary_path}{resumable}',
            file=sys.stderr,
        )
        return INTERRUPTED
    if checkpoint:
        shutil.rmtree(folder, ignore_errors=True)
    for sol in result.solutions:
        if not sol.success:
            print(f"geomint: run failed: x0 = {sol.x[0].tolist()}: {sol.message}", file=sys.stderr)
    return OK if result.success else FAILED


def _prepare(system, method, h, quiet, together=False, start=None):
    """Load the compiled kernels a scene's run uses (a first run compiles them) before its progress bar
    counts: a bar that counted the compilation showed a rate and an ETA off by minutes.  One step of the
    method from an arbitrary point, its result discarded: the types of the model and the method, not their
    values, select the compiled code.  Best effort: a point where the system is undefined only leaves the
    compilation to the run.  ``together``: the kernel of ``solve_ensemble`` (``run_scene`` runs the scene's
    trajectories together), else ``solve``'s; ``start`` the point (default 0.5 in every coordinate of R^3).
    When numba has to compile (nothing cached yet), that is said once, as it starts, and the seconds are
    counted on a progress line (``_CompilationNotice``)."""
    if not quiet:
        print("geomint: loading the compiled kernels ...", end=" ", file=sys.stderr, flush=True)
    started = time.perf_counter()
    with _CompilationNotice(method.name, None if quiet else sys.stderr, lead="") as notice:
        try:
            x0 = np.full(3, 0.5) if start is None else np.asarray(start, dtype=np.float64)
            if together:
                solve_together(system, x0[None, :], (0.0, h), h, method)
            else:
                solve(system, x0, (0.0, h), h, method=method)
        except (ValueError, TypeError):  # refused at the boundary: the run itself reports the scene's own errors
            pass
    if not quiet and not notice.announced:
        print(f"{time.perf_counter() - started:.2f} s", file=sys.stderr)


class _CompilationNotice:
    """Within this block, the first time numba compiles (a cache miss: ``numba:compile`` events fire only then),
    say so on ``stream`` before the wait, once, and count the seconds on a progress line (in place, on a
    terminal) until the block ends, then say how long it took.  ``stream=None``: silent."""

    _INTERVAL = 1.0

    def __init__(self, what, stream, lead="geomint: kernels "):
        self.what, self.stream, self.lead = what, stream, lead
        self.announced, self.depth, self.started = False, 0, None
        self._stop, self._ticker = threading.Event(), None

    def __enter__(self):
        from numba.core import event

        notice = self

        from numba.core.caching import NullCache

        class Listener(event.Listener):
            def on_start(self, ev):
                # a helper of geomint's compiled without a disk cache compiles in every process, in milliseconds
                # (the R^n workspace's size): that is not the first use of a method, and is not announced as one
                dispatcher = ev.data.get("dispatcher")
                module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
                if module.startswith("geomint.") and isinstance(getattr(dispatcher, "_cache", None), NullCache):
                    return
                notice._compiling()

            def on_end(self, ev):
                pass

        self._listener = Listener()
        event.register("numba:compile", self._listener)
        return self

    def _compiling(self):
        if self.announced or self.stream is None:
            self.announced = True
            return
        self.announced, self.started = True, time.perf_counter()
        print(
            f"{self.lead}not cached yet: compiling them for {self.what} (the first use of a method takes 5-25 s, "
            "once; the machine code is then cached on disk for later runs)",
            file=self.stream,
            flush=True,
        )
        if getattr(self.stream, "isatty", lambda: False)():
            self._ticker = threading.Thread(target=self._tick, daemon=True)
            self._ticker.start()

    def _tick(self):
        while not self._stop.wait(self._INTERVAL):
            # (started is set by _compiling before it starts this ticker)
            print(
                f"\rgeomint: compiling ... {time.perf_counter() - cast(float, self.started):.0f} s",
                end="",
                file=self.stream,
                flush=True,
            )

    def __exit__(self, *exc):
        from numba.core import event

        event.unregister("numba:compile", self._listener)
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
            print("\r\033[K", end="", file=self.stream)
        if self.announced and self.stream is not None:  # announced with a stream: started set by _compiling
            print(
                f"geomint: compiled in {time.perf_counter() - cast(float, self.started):.2f} s",
                file=self.stream,
                flush=True,
            )
        return False


def _check_output(folder, paths):
    """The output folder exists or can be made, takes new files, and no result name is taken by a folder."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as exc:
        raise OutputError(
            f"--out {folder}: cannot write there ({exc.strerror or exc}); choose a writable folder with --out DIR."
        ) from None
    for path in paths:
        if path.exists() and not path.is_file():
            raise OutputError(
                f"--out {folder}: {path} exists and is not a file; remove it or choose another --out DIR."
            )


def _report(result, summary, paths, out):
    totals = summary["totals"]
    print(result.scene.title or result.scene.name, file=out)
    print(describe(result.scene, result.method), file=out)
    print(
        f"{totals['trajectories']} trajectories, {totals['n_steps']} steps, {totals['n_newton']} Newton "
        f"iterations, {totals['wall_s']:.3g} s; failed: {totals['failed']}",
        file=out,
    )
    if result.scene.in_rn:
        _report_n(result, summary, out)
    else:
        print(
            f"max |H - H0|/|H0| = {totals['max_energy_error']:.3g} "
            f"({totals['max_energy_error'] / np.finfo(float).eps:.1f} ulp); S rises: {totals['S_rises']}",
            file=out,
        )
    for path in paths:
        print(f"wrote {path}", file=out)


def _report_n(result, summary, out):
    """The R^n lines of a run's report: the energy, S against its direction, and the relaxation (S_inf, the
    final gap, the fitted rate; for 2-D Euler the distance from the lowest shell)."""
    totals = summary["totals"]
    generic = totals["form"] == "GENERIC"
    energy, way = ("E", "never falls") if generic else ("H", "never rises")
    print(
        f"max |{energy} - {energy}0|/|{energy}0| = {totals['max_energy_error']:.3g} "
        f"({totals['max_energy_error'] / np.finfo(float).eps:.1f} ulp); S against its direction (S {way}): "
        f"{totals['S_against_direction']}",
        file=out,
    )
    for i, t in enumerate(summary["trajectories"]):
        rate = "no clean exponential tail" if t["decay_rate"] is None else f"rate {t['decay_rate']:.4g}"
        if "expected_rate" in t:
            rate += f"; expected: {t['expected_rate_why']}"
        line = (
            f"  trajectory {i}: S_inf = {t['S_limit']:.12g} ({t['S_limit_from']}), |S - S_inf| at the end "
            f"{t['S_gap_final']:.2g}, {rate}"
        )
        if "lowest_shell_distance" in t:
            line += f"; distance from the lowest shell |k|^2 = 1: {t['lowest_shell_distance']:.2g}"
        print(line, file=out)
        if i == 9 and len(summary["trajectories"]) > 10:
            print(f"  ... ({len(summary['trajectories']) - 10} more in the summary)", file=out)
            break


def describe(scene: Scene, method: Integrator) -> str:
    """What a scene runs, as a sentence: the system and its parameters, the effects, the method and its options,
    the step and the span (the run's second line; ε is the dissipation parameter)."""

    def assigned(data):
        return ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {toml_value(v)}" for k, v in data.items())

    system = scene.system + (" (written as formulas)" if scene.expressions is not None else "")
    if scene.arguments:
        system += f" with {assigned(scene.arguments)}"
    elif scene.parameters:
        system += f" with {assigned(scene.parameters)}"
    if scene.in_rn and scene._built is not None:  # pyright: ignore[reportAttributeAccessIssue]  # a resolved scene
        built = scene.built().system
        form = "GENERIC" if built.direction > 0 else "Fish form"
        system += f" ({form}, n = {built.dim})"
    generic = scene.in_rn and scene._built is not None and scene.built().system.direction > 0  # pyright: ignore[reportAttributeAccessIssue]
    if generic:
        scaled = "" if scene.eps == 1.0 else f", M scaled by ε = {scene.eps:g}"
        effects = {
            (True, True): f"reversible part L∇E and irreversible part M∇S{scaled}",
            (True, False): "reversible part L∇E only (ε = 0)",
            (False, True): f"irreversible part M∇S only{scaled}",
        }[(scene.hamiltonian, scene.eps > 0)]
    else:
        effects = {
            (True, True): f"Hamiltonian part and dissipation ε = {scene.eps:g}",
            (True, False): "Hamiltonian part only (ε = 0)",
            (False, True): f"dissipation ε = {scene.eps:g} only",
        }[(scene.hamiltonian, scene.eps > 0)]
    data = method_to_data(method)
    options = {k: v for k, v in data.items() if k != "name"}
    integrator = data["name"] + (f" ({assigned(options)})" if options else "")
    return f"{system}: {effects}; integrated with {integrator}, h = {scene.h:g} from t = 0 to {scene.duration:g}."


def show(scene_name: str, out: TextIO | None = None) -> int:
    """``geomint show``: the scene fully resolved, as TOML."""
    out = sys.stdout if out is None else out
    scene = load_scene(scene_name).resolved()
    print(
        f"# {scene.source}, resolved: {scene.n_trajectories} trajectories x {scene.steps_per_trajectory} steps",
        file=out,
    )
    print(to_toml(scene.to_dict()), file=out)
    print("\n# initial states", file=out)
    variables = scene.built().system.variables
    for x0 in scene.initial_states():
        if scene.in_rn and len(variables) <= 12:
            print("#   " + ", ".join(f"{name} = {value!r}" for name, value in zip(variables, x0.tolist())), file=out)
        else:
            print(f"#   {x0.tolist()}", file=out)
    return OK


def list_all(out: TextIO | None = None) -> int:
    """``geomint list``: what scenes can name."""
    out = sys.stdout if out is None else out
    print("systems ([system] name):", file=out)
    # (the constructors and the integrators are documented: a __doc__ is None only under python -OO)
    for name, constructor in CATALOGUE.items():
        print(f"  {name:<24}{cast(str, constructor.__doc__).strip().splitlines()[0]}", file=out)
    print("systems in R^n ([system] catalogue, the arguments as keys of [system]; form and dimension n):", file=out)
    for name, constructor in RN_CATALOGUE.items():
        defaults = catalogue_n.defaults(name)
        dimension = catalogue_n.DIMENSIONS.get(name)
        n = f"n = {dimension.formula}" if dimension is not None else "n from its arguments"
        if dimension is not None and not dimension.formula.strip().isdigit():
            n += f" ({catalogue_n.dimension(name)} with the defaults)"
        print(f"  {name:<24}{catalogue_n.form(name)}, {n}; {_first_line(constructor.__doc__)}", file=out)
        arguments = ", ".join(f"{k} = {toml_value(v)}" for k, v in defaults.items())
        print(f"  {'':<24}arguments: {arguments or 'none'}", file=out)
    print("integrators ([integrator] method; order and traits with the default options):", file=out)
    for name, cls in short_names().items():
        print(f"  {name:<24}{_traits(cls())}; {cast(str, cls.__doc__).strip().splitlines()[0]}", file=out)
        defaults = method_to_data(cls())
        options = ", ".join(f"{k} = {toml_value(defaults[k]) if k in defaults else '(unset)'}" for k in options_of(cls))
        print(f"  {'':<24}options: {options or 'none'}", file=out)
    print("observables ([output] record):", file=out)
    for name, (what, _) in OBSERVABLES.items():
        print(f"  {name:<24}{what}", file=out)
    print("figures ([output] figures):", file=out)
    for name, what in FIGURES.items():
        print(f"  {name:<24}{what}", file=out)
    print("bundled scenes (geomint run NAME):", file=out)
    for name, path in bundled_scenes().items():
        print(f"  {name:<24}{load_scene(str(path)).title}", file=out)
    print("bundled scenes in R^n (geomint run NAME):", file=out)
    for name, path in bundled_scenes(rn=True).items():
        print(f"  {name:<24}{load_scene(str(path)).title}", file=out)
    return OK


def _first_line(doc):
    """The first sentence-line of a docstring (empty under python -OO, which strips docstrings)."""
    return (doc or "").strip().splitlines()[0] if doc else ""


def _traits(method):
    """``order 2, energy-exact, dissipative, symmetric, implicit`` (the traits that hold), for ``list``."""
    order = "exact flow" if method.order == float("inf") else f"order {method.order}"
    traits = [
        label
        for label, on in (
            ("energy-exact", method.energy_exact),
            ("dissipative", method.dissipative),
            ("symmetric", method.symmetric),
            ("implicit", method.implicit),
        )
        if on
    ]
    if getattr(method, "flows", ("full",)) == ("hamiltonian",):
        traits.append("Hamiltonian sub-flow only (a splitting's hamiltonian_part, or eps = 0)")
    return ", ".join([order, *traits])


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return OK
    if args.command == "drift" and not math.isfinite(args.steps * args.h):
        parser.error(f"argument --steps/--h: the span steps * h = {args.steps} * {args.h} is not finite")
    try:
        return _COMMANDS[args.command](args)
    except KeyboardInterrupt:
        if args.traceback:
            raise
        print("geomint: interrupted; nothing was written", file=sys.stderr)
        return INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - the command line reports every error in one line
        if args.traceback:
            raise
        print(f"geomint: error: {_one_line(exc)}", file=sys.stderr)
        return BAD_INPUT if isinstance(exc, (SceneError, OutputError, ValueError, TypeError, OSError)) else INTERNAL


def _one_line(exc):
    """An exception as one line; an unexpected one says how to see more."""
    if isinstance(exc, (SceneError, OutputError, ValueError, TypeError)):
        return " ".join(str(exc).split())
    if isinstance(exc, OSError):
        return f"{exc.filename or ''}: {exc.strerror or exc}".lstrip(": ")
    return (
        f"internal error {type(exc).__name__}: {' '.join(str(exc).split())[:300]} (rerun with --traceback and "
        "report it)"
    )


_COMMANDS = {
    "run": lambda args: run(
        args.scene, args.out, args.quiet, checkpoint_every=args.checkpoint_every, resume=args.resume
    ),
    "show": lambda args: show(args.scene),
    "list": lambda args: list_all(),
    "drift": lambda args: drift(args.steps, args.h, args.eps),
}


if __name__ == "__main__":
    sys.exit(main())
