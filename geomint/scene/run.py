"""Running a scene: ``run_scene`` on a scene resolved once, ``SceneResult``, and the checkpoint folder.

Trajectories of at most ``ENSEMBLE_STEPS`` steps run together through ``geomint.solve_ensemble``: one compiled
call over every core for chunks of about ``ENSEMBLE_STEPS`` steps, with progress reports and Ctrl-C answered
between chunks.  Longer trajectories, and every checkpointed run, run one by one through ``geomint.solve``: its
compiled loop reports progress and answers Ctrl-C within a trajectory (cutting it short, ``status`` 2) and
writes the checkpoints, which the ensemble engine does not.  Both give each trajectory the same states bit for
bit (``solve_ensemble`` runs ``solve``'s step loop), so which one ran does not show in the results.
"""

from __future__ import annotations

import json
import shutil
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..integrators.data import method_to_data
from ..results import io as _io
from ..results import solution as _solution
from ..results.solution import AccuracyWarning
from ..run.ensemble import solve_ensemble
from ..run.solve import solve
from ..run.status import Status
from . import relaxation as _relaxation
from .schema import OBSERVABLES, Scene

if TYPE_CHECKING:
    import os
    from collections.abc import Callable

    import numpy.typing as npt

    from ..integrators import Integrator
    from ..model.system import MetriplecticSystem
    from ..run.ensemble import Ensemble

#: the most steps of a trajectory run together with others through ``solve_ensemble`` (and about the steps of
#: one chunk of them: progress reports and Ctrl-C come between chunks); longer ones run alone through ``solve``
ENSEMBLE_STEPS = 100_000


@dataclass(frozen=True, eq=False)
class SceneResult:
    """What ``run_scene`` computed.

    Attributes
    ----------
    scene : Scene
        The resolved scene that ran.
    system, method
        The simulated system (effects applied) and the integrator.
    solutions : list of Solution
        One per initial state.
    records : dict
        Observable -> array ``(n_trajectories, rows, ...)`` for the recorded
        observables, plus ``"t"`` and ``"rows"`` (valid rows per trajectory; a
        trajectory that failed early is padded with NaN after its last row).
    wall : list of float
        Seconds per trajectory (trajectories run together share their
        chunk's seconds equally).
    partial : bool
        True when Ctrl-C stopped the run: the trajectories run so far (the
        last one possibly cut short, ``status`` 2) are the result.
    """

    scene: Scene
    system: MetriplecticSystem
    method: Integrator
    solutions: list
    records: dict
    wall: list
    partial: bool = False

    @property
    def success(self) -> bool:
        return all(sol.success for sol in self.solutions)

    def limits(self) -> list[_relaxation.Limit]:
        """S_inf of each trajectory as ``output.limit`` says: given, the catalogue's closed form from the
        trajectory's start (``"known"``), or estimated from its tail (``"tail"``, and where the scene says
        nothing and knows no closed form)."""
        limit = self.scene.limit
        out = []
        for i, sol in enumerate(self.solutions):
            if isinstance(limit, (int, float)):
                out.append(_relaxation.Limit(float(limit), "given", "S_inf given by the scene"))
            elif isinstance(limit, tuple):
                out.append(_relaxation.Limit(float(limit[i]), "given", "S_inf given by the scene"))
            elif limit == "known" and self.scene.known_limit is not None:
                known = self.scene.known_limit
                value = known.value(self.system, sol.x[0], self.scene.arguments or {})
                out.append(_relaxation.Limit(float(value), "known", known.why))
            else:
                out.append(_relaxation.tail_limit(sol.t, sol.S))
        return out

    def relaxation(self) -> list[dict[str, Any]]:
        """Per trajectory: S_inf and where it comes from, the final gap ``|S - S_inf|``, the fitted rate of
        the approach (``geomint.scene.relaxation.decay_rate``; None without a clean exponential tail) and,
        for 2-D Euler, the final state's distance from the span of the lowest shell ``|k|^2 = 1``."""
        direction = float(getattr(self.system, "direction", -1.0))
        out = []
        for sol, limit in zip(self.solutions, self.limits()):
            rate = _relaxation.decay_rate(sol.t, sol.S, limit.value, direction)
            entry = {
                "S_limit": limit.value,
                "S_limit_from": limit.source,
                "S_limit_why": limit.why,
                "S_gap_final": float(abs(sol.S[-1] - limit.value)),
                "decay_rate": None if rate is None else rate.rate,
                "decay_rate_fitted_over": None if rate is None else [rate.t_from, rate.t_to],
            }
            expected = self.scene.expected_rate(float(sol.H[0]))
            if expected is not None:
                entry["expected_rate"], entry["expected_rate_why"] = expected
            if self.scene.is_euler:
                entry["lowest_shell_distance"] = _relaxation.lowest_shell_distance(sol.x_final)
            out.append(entry)
        return out

    def summary(self) -> dict[str, Any]:
        """A JSON-ready dict: invariant errors, S rises, work, wall time, versions, the scene."""
        ulp = float(np.finfo(np.float64).eps)  # machine epsilon; `eps` is the dissipation parameter
        trajectories = []
        for sol, wall in zip(self.solutions, self.wall):
            trajectories.append(
                {
                    "x0": sol.x[0].tolist(),
                    "x_final": sol.x_final.tolist(),
                    "t_final": sol.t_final,
                    "H0": float(sol.H[0]),
                    "S0": float(sol.S[0]),
                    "S_final": float(sol.S[-1]),
                    "energy_error": sol.energy_error,
                    "energy_error_in_ulp": sol.energy_error / ulp,
                    "S_rises": sol.S_rises,
                    "success": sol.success,
                    "status": sol.status,
                    "message": sol.message,
                    "n_steps": sol.n_steps,
                    "n_newton": sol.n_newton,
                    "nfev": sol.nfev,
                    "wall_s": wall,
                }
            )
        if self.scene.in_rn:
            for entry, sol, more in zip(trajectories, self.solutions, self.relaxation()):
                entry["S_against_direction"] = sol.S_against_direction
                entry.update(more)
        totals = {
            "partial": self.partial,
            "trajectories": len(trajectories),
            "failed": sum(t["status"] < 0 for t in trajectories),
            "max_energy_error": max(t["energy_error"] for t in trajectories),
            "S_rises": sum(t["S_rises"] for t in trajectories),
            **{k: sum(t[k] for t in trajectories) for k in ("n_steps", "n_newton", "nfev", "wall_s")},
            "rows_saved_per_trajectory": int(self.records["rows"].max()),
        }
        if self.scene.in_rn:
            totals["S_against_direction"] = sum(t["S_against_direction"] for t in trajectories)
            totals["S_direction"] = float(getattr(self.system, "direction", -1.0))
            totals["form"] = "GENERIC" if totals["S_direction"] > 0 else "Fish"
            totals["dim"] = int(self.system.dim)
            totals["variables"] = list(self.system.variables)
        return {
            "scene": self.scene.to_dict(),
            "system": repr(self.system),
            "method": method_to_data(self.method),
            "totals": totals,
            "trajectories": trajectories,
            "versions": versions(),
            "notes": "energy_error = max |H - H0|/|H0| and S_rises (S up by more than 16 ulps) over the saved "
            "states; energy_error_in_ulp is it in ulp (units of machine epsilon, 2**-52); "
            "scene.effects.eps is the dissipation parameter."
            + (
                " In R^n, S_against_direction counts the saved steps where S moved against its direction (rose "
                "in the Fish form, fell in GENERIC form, where S_rises are the normal direction); S_limit is S_inf "
                "(S_limit_from: given, known in closed form, or tail: estimated), decay_rate the fitted rate of "
                "|S - S_inf| ~ exp(-rate t)."
                if self.scene.in_rn
                else ""
            ),
        }


def run_scene(
    scene: Scene,
    progress: Callable[[int], object] | None = None,
    checkpoint: tuple[str | os.PathLike[str], int | None] | None = None,
    resume: bool = False,
    before_steps: Callable[[MetriplecticSystem, Integrator], object] | None = None,
) -> SceneResult:
    """Run a scene; ``progress(n)`` is called with the number of steps done since its last call, and
    ``before_steps(system, method)`` once the scene and its checkpoint are validated, before the first step.

    Validates the scene fully (``Scene.resolved``; a resolved scene is not
    resolved again), integrates its initial states (together with
    ``geomint.solve_ensemble``, or one by one with ``geomint.solve``: see the
    module docstring) and computes only the recorded observables.

    ``checkpoint = (folder, steps)`` keeps the run resumable: each finished
    trajectory is saved in ``folder`` and the running one checkpointed every
    ``steps`` steps (``geomint.solve``'s ``checkpoint``); ``resume=True``
    continues from that folder (``steps`` may then be None: the checkpoint's),
    and the result equals the uninterrupted run's bit for bit.  A folder
    written for another scene raises ``CheckpointError``.
    """
    if not isinstance(scene, Scene):
        raise TypeError(
            f"`scene` must be a geomint.Scene; got {scene!r} ({type(scene).__name__}). Read one with "
            "geomint.scene.load_scene(path or bundled name) or build it with Scene(...)."
        )
    scene = scene.resolved()
    system, method, states = scene.built()
    checkpoint = _checkpoint_folder(scene, checkpoint, resume)
    if before_steps is not None:
        before_steps(system, method)
    if runs_together(scene, checkpoint):
        solutions, wall, run = _together(scene, system, method, states, progress)
    else:
        solutions, wall = _one_by_one(scene, system, method, states, progress, checkpoint)
        run = _stacked(solutions)
    if not solutions:  # interrupted before a first trajectory ran: nothing to return
        raise KeyboardInterrupt
    records = {
        "rows": run.rows,
        "t": run.t,
        **{name: np.asarray(OBSERVABLES[name][1](system, run)) for name in scene.record},
    }
    partial = len(solutions) < len(states) or solutions[-1].status == Status.INTERRUPTED
    return SceneResult(
        scene=scene, system=system, method=method, solutions=solutions, records=records, wall=wall, partial=partial
    )


class _Run(NamedTuple):
    """The saved states of the trajectories run, stacked as ``geomint.Ensemble`` holds them: (trajectories, rows,
    ...) arrays, NaN after each trajectory's ``rows``."""

    t: np.ndarray
    x: np.ndarray
    H: np.ndarray
    S: np.ndarray
    rows: np.ndarray


def _save_every(scene):
    return None if scene.every == "final" else scene.every


def _together(scene, system, method, states, progress):
    """Every trajectory through ``solve_ensemble``, in chunks of about ``ENSEMBLE_STEPS`` steps; Ctrl-C leaves the
    chunks not started unrun.  ``(solutions, wall, run)`` of the trajectories run."""
    steps = scene.steps_per_trajectory
    reported = [0]

    def report(done):
        progress(steps * (done - reported[0]))
        reported[0] = done

    span, save_every = (0.0, scene.duration), _save_every(scene)
    started = time.perf_counter()
    ensemble = solve_together(
        system,
        states,
        span,
        scene.h,
        method=method,
        save_every=save_every,
        progress=None if progress is None else report,
        chunk=max(1, ENSEMBLE_STEPS // steps),
    )
    seconds = time.perf_counter() - started
    for i in np.flatnonzero(ensemble.status == Status.INVALID_START):
        # raises solve's error (and solve takes save_every=None)
        solve(system, states[i], span, scene.h, method=method, save_every=save_every)
    ran = int(np.count_nonzero(ensemble.status != Status.NOT_RUN))  # chunks run in order: the first ``ran``
    solutions = [ensemble.solution(i) for i in range(ran)]
    rows = ensemble.rows[:ran]
    used = max(1, int(rows.max(initial=0)))
    run = _Run(*(a[:ran, :used] for a in (ensemble.t, ensemble.x, ensemble.H, ensemble.S)), rows)  # pyright: ignore[reportCallIssue]
    return solutions, [seconds / len(states)] * ran, run


def solve_together(
    system: MetriplecticSystem,
    X0: npt.ArrayLike,
    t_span: tuple[float, float],
    h: float | None,
    method: Integrator | str | None,
    **options: Any,
) -> Ensemble:
    """``geomint.solve_ensemble``, each trajectory's caveat said as an ``AccuracyWarning`` of its own, as
    ``geomint.solve`` says it (the ensemble says one for all)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        ensemble = solve_ensemble(system, X0, t_span, h, method=method, **options)
    for caveats in ensemble.caveats:
        for caveat in caveats:
            warnings.warn(caveat, AccuracyWarning, stacklevel=2)
    return ensemble


def runs_together(scene: Scene, checkpoint: tuple[str | os.PathLike[str], int | None] | None = None) -> bool:
    """Whether ``run_scene`` runs the trajectories of ``scene`` together through ``solve_ensemble`` (else one by
    one through ``solve``; the module docstring says when)."""
    return checkpoint is None and scene.steps_per_trajectory <= ENSEMBLE_STEPS


def _one_by_one(scene, system, method, states, progress, checkpoint):
    """Each trajectory through ``solve``, checkpointed in ``checkpoint = (folder, steps)`` if given, until Ctrl-C
    stops one (``status`` 2) or the run between two.  ``(solutions, wall)`` of the trajectories run."""
    folder = None if checkpoint is None else checkpoint[0]
    solutions, wall = [], []
    for i, x0 in enumerate(states):
        if folder is not None and (folder / f"{i}.npz").exists():  # finished before the interruption
            solutions.append(_solution.load(folder / f"{i}.npz"))
            wall.append(0.0)
            continue
        done = [0]

        def report(steps, done=done):
            progress(steps - done[0])  # pyright: ignore[reportOptionalCall]  # passed on only with a progress
            done[0] = steps

        start = time.perf_counter()
        running = None if folder is None else folder / "running.npz"
        try:
            sol = solve(
                system,
                x0,
                (0.0, scene.duration),
                scene.h,
                method=method,
                save_every=_save_every(scene),
                progress=None if progress is None else report,
                checkpoint=None if folder is None else (running, checkpoint[1]),  # pyright: ignore[reportOptionalSubscript, reportArgumentType]
                resume=running if running is not None and running.exists() else None,
            )
        except KeyboardInterrupt:  # Ctrl-C outside the compiled loop (which answers it with status 2)
            break
        wall.append(time.perf_counter() - start)
        solutions.append(sol)
        if folder is not None and sol.status != Status.INTERRUPTED:
            _io.save(sol, folder / f"{i}.npz")
            running.unlink(missing_ok=True)  # pyright: ignore[reportOptionalMemberAccess]  # with a folder
        if sol.status == Status.INTERRUPTED:
            break
    return solutions, wall


def _stacked(solutions):
    """The solutions' saved states stacked (``_Run``), as ``solve_ensemble`` returns them."""
    rows = np.array([len(sol.t) for sol in solutions], dtype=np.int64)
    arrays = []
    for name in ("t", "x", "H", "S"):
        first = getattr(solutions[0], name) if solutions else np.empty(0)
        array = np.full((len(solutions), max(1, int(rows.max(initial=0)))) + first.shape[1:], np.nan)
        for i, sol in enumerate(solutions):
            array[i, : rows[i]] = getattr(sol, name)
        arrays.append(array)
    return _Run(*arrays, rows)  # pyright: ignore[reportCallIssue]  # the four arrays


class CheckpointError(ValueError):
    """A checkpoint folder that cannot be resumed (missing, or written for another scene)."""


def _checkpoint_folder(scene, checkpoint, resume):
    """``(folder, steps)`` for a checkpointed run: a new folder stamped with the scene and ``steps``
    (``checkpoint.json``), or on ``resume`` the stamped folder checked against the scene (its ``steps``
    used when none is given)."""
    if checkpoint is None:
        if resume:
            raise CheckpointError("`resume` needs `checkpoint` = (folder, steps or None).")
        return None
    folder, steps = Path(checkpoint[0]), checkpoint[1]
    stamp = folder / "checkpoint.json"
    if resume:
        if not stamp.is_file():
            raise CheckpointError(
                f"no checkpoint in {folder} (the run finished, which removes it, or was not checkpointed); "
                "run with a checkpoint first."
            )
        written = json.loads(stamp.read_text())
        if written.get("scene") != json.loads(json.dumps(scene.to_dict())):
            raise CheckpointError(
                f"the checkpoint in {folder} was written for another scene; remove it or run without resuming."
            )
        return folder, written["every"] if steps is None else steps
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"`checkpoint` steps must be an integer >= 1; got {steps!r}.")
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    stamp.write_text(json.dumps({"scene": scene.to_dict(), "every": int(steps)}))
    return folder, int(steps)


def versions() -> dict[str, str]:
    """Versions of geomint, Python and the numerical libraries, for summaries."""
    import platform

    import numba
    import scipy

    from .._version import __version__

    return {
        "geomint": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
    }
