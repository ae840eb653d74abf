"""Scenes: declarative runs that compute only what they call for.

A scene names a catalogue system (or writes one as formulas) and its
parameters, the effects to simulate, the initial states, the integrator and
what to record and draw.  As a TOML file (read with the standard library's
``tomllib``; nothing in it is evaluated as Python)::

    title = "Relaxing rigid body, a, b, c distinct"

    [system]
    name = "relaxing_rigid_body"
    parameters = { a = 0.5, b = 1.0, c = 1.5 }

    [effects]
    hamiltonian = true      # xi_P = grad H x J on/off
    eps = 1.0               # dissipation eps xi_g; 0 = off
    projection = false      # project every step back onto H = H0

    [initial]
    level_set = { H0 = 0.6471, n = 12 }    # or: points = [[0.45, 0.0, 0.89], ...]

    [integrator]
    method = "gonzalez"     # or { name = "gonzalez", max_newton_iter = 50 }
    h = 0.02
    duration = 30.0

    [output]
    record = ["x", "H", "S"]   # observables written to the .npz
    every = 5                  # save every 5th state; "final": initial and final only
    figures = ["overview"]

A system written as formulas (``geomint.expressions``: a whitelist grammar of
numbers, x, y, z, parameter names, + - * / ** and exp, log, sin, cosh, ...;
formulas are parsed, never evaluated) replaces ``name`` by ``H``, ``S`` and
``J`` (3 formulas) or ``P`` (3x3 formulas); ``name`` is then a label::

    [system]
    name = "lorenz_nevir"
    H = "(y**2 + z**2)/2 - r*z"
    S = "x**2/2 - sigma*z"
    J = ["-x", "0", "sigma"]
    parameters = { sigma = 10.0, r = 28.0 }

Every integrator can be named, with its options as further keys of
``[integrator]`` (or in a table ``method = { name = ..., ... }``);
sub-integrators are names or tables themselves (``geomint.method_data``)::

    method = "yoshida4"                      # a composition ...
    base = "symmetrized_itoh_abe"            # ... of the symmetrized Itoh-Abe step
    # method = "strang", hamiltonian_part = "rigid_body_flow", gradient_part = "gonzalez"
    # method = { name = "projected", method = "rk4", symmetric = false }

What is off is not computed: ``hamiltonian = false`` runs kernels that never
call ``J``; ``eps = 0`` runs kernels that never call ``grad S``
(``MetriplecticSystem.with_effects``); observables not in ``record`` are
neither computed nor stored, and ``every = "final"`` runs in constant memory.
"""

import dataclasses
import inspect
import json
import math
import re
import shutil
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _validate
from ..results import io as _io
from ..results import solution as _solution
from ..analysis import level_set as _level_set
from .. import diagnostics as _diagnostics
from ..integrators.data import MethodDataError, method_from_data, method_to_data
from ..run.arguments import MAX_STEPS
from ..run.controller import step_count
from ..run.solve import solve
from ..run.status import Status
from ..model.system import MetriplecticSystem
from ..systems import CATALOGUE


class SceneError(ValueError):
    """A scene that cannot run: names the file, the key and the problem."""

    def __init__(self, source, key, problem):
        self.source, self.key, self.problem = source, key, problem
        where = f"{source}: " if source else ""
        super().__init__(f"{where}`{key}`: {problem}" if key else f"{where}{problem}")


#: observable -> (what it is, how it is computed from a system and a Solution)
OBSERVABLES = {
    "x": ("state, (rows, 3)", lambda system, sol: sol.x),
    "H": ("energy", lambda system, sol: sol.H),
    "S": ("Casimir", lambda system, sol: sol.S),
    "energy_error": ("|H - H0| / |H0| (absolute when H0 = 0)", lambda system, sol: _diagnostics.energy_error(sol)),
    "sigma": ("sigma = grad S x grad H, (rows, 3)", lambda system, sol: system.sigma(sol.x)),
    "dS_dt": ("dS/dt = -eps |sigma|^2", lambda system, sol: system.dS_dt(sol.x)),
    "xi": ("the simulated field, (rows, 3)", lambda system, sol: system.xi(sol.x)),
}

#: figure -> what it draws (geomint.plotting draws them)
FIGURES = {
    "overview": "trajectories on the level surface of H in 3-D, with H(t) and S(t) panels",
    "trajectories": "trajectories on the level surface of H in 3-D, equilibria marked",
    "invariants": "relative energy error and S against t",
    "drift": "windowed maxima of the energy error against t (log-log) with the fitted growth law",
}

# section -> key in the file -> Scene field; "" is the top level
_LAYOUT = {
    "": {"title": "title", "description": "description"},
    "system": {"name": "system", "parameters": "parameters", "H": "expressions", "S": "expressions",
               "J": "expressions", "P": "expressions"},
    "effects": {"hamiltonian": "hamiltonian", "eps": "eps", "projection": "projection"},
    "initial": {"points": "points", "level_set": "level_set"},
    "integrator": {"method": "integrator", "h": "h", "duration": "duration"},
    "output": {"record": "record", "every": "every", "figures": "figures", "view": "view", "sections": "sections"},
}
_KEY_OF = {name: (f"{section}.{key}" if section else key) for section, keys in _LAYOUT.items()
           for key, name in keys.items()}
_KEY_OF["expressions"] = "system"
_LEVEL_SET_KEYS = ("H0", "n", "center")
#: the most initial states a level set may ask for
MAX_TRAJECTORIES = 10**6
_EXPRESSION_KEYS = ("H", "S", "J", "P")
_LABEL = re.compile(r"[A-Za-z][A-Za-z0-9_.-]{0,99}")


@dataclass(frozen=True, eq=False)
class Scene:
    """A declarative run; see the module docstring for the file form.

    Parameters
    ----------
    system : str
        A name in ``geomint.systems.CATALOGUE``; with ``expressions``, a label
        (letters, digits, ``_ . -``).
    parameters : dict
        Keyword arguments of the catalogue function except ``eps``; with
        ``expressions``, the formulas' parameters ``{name: value}``.
    expressions : dict, optional
        ``{"H": str, "S": str, "J": [3 str]}`` or with ``"P": [[3 str] x 3]``:
        the system as formulas (``geomint.MetriplecticSystem.from_expressions``).
    hamiltonian : bool, default True
        Simulate the Hamiltonian part ``xi_P = grad H x J``.
    eps : float, default 1.0
        Dissipation ``eps xi_g``; 0 switches it off.
    projection : bool, default False
        Wrap the integrator in ``geomint.Projected`` (projection onto H = H0).
    points : sequence of 3-vectors, optional
        Initial states.
    level_set : dict, optional
        ``{"H0": float, "n": int, "center": 3-vector (default: the minimiser of H)}``:
        ``n`` initial states spread over ``H = H0`` (``geomint.level_set.sample``).
        Give exactly one of ``points`` and ``level_set``.
    integrator : str or dict, default "gonzalez"
        A short name, or ``{"name": ..., option: value, ...}`` with the
        integrator's options; sub-integrators are names or such dicts
        (``geomint.method_data.method_from_data``).
    h, duration : float
        Step size and length of the run from t = 0; both finite and > 0.
    record : sequence of str
        Observables written out; keys of ``OBSERVABLES``.
    every : int or "final", default 1
        Save every ``every``-th state; ``"final"`` keeps the initial and final
        states only (constant memory).
    figures : sequence of str
        Keys of ``FIGURES``; they need ``every`` to be an integer.
    view : (elevation, azimuth), default (30, -60)
        Viewing angles of 3-D panels, in degrees.
    sections : sequence of (a, b, c, d)
        Planes ``a x + b y + c z = d`` whose intersections with the level
        surface are drawn (e.g. the plane where the Poisson tensor vanishes).
    title, description, name : str
        Labels; ``name`` is the stem of output files.
    source : str
        Where the scene came from (a file path, or ``"<Scene>"``); errors name it.
    """

    system: str
    h: float
    duration: float
    parameters: dict = field(default_factory=dict)
    expressions: dict | None = None
    hamiltonian: bool = True
    eps: float = 1.0
    projection: bool = False
    points: tuple | None = None
    level_set: dict | None = None
    integrator: str | dict = "gonzalez"
    record: tuple = ("x", "H", "S")
    every: int | str = 1
    figures: tuple = ("overview",)
    view: tuple = (30.0, -60.0)
    sections: tuple = ()
    title: str = ""
    description: str = ""
    name: str = "scene"
    source: str = "<Scene>"

    def __post_init__(self):
        check = _Checker(self.source)
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731 (frozen dataclass)
        if self.expressions is None:
            set_("system", check.choice("system", self.system, CATALOGUE, "catalogue system"))
            set_("parameters", check.parameters(self.system, self.parameters))
        else:
            set_("system", check.label("system", self.system))
            set_("parameters", check.formula_parameters(self.parameters))
            set_("expressions", check.expressions(self.expressions, list(self.parameters)))
        for flag in ("hamiltonian", "projection"):
            set_(flag, check.boolean(flag, getattr(self, flag)))
        set_("eps", check.real("eps", self.eps, minimum=0.0))
        if not self.hamiltonian and self.eps == 0.0:
            raise SceneError(self.source, "effects",
                             "every effect is off (hamiltonian = false, eps = 0): there is nothing to simulate.")
        if (self.points is None) == (self.level_set is None):
            raise SceneError(self.source, "initial", "give exactly one of `points` and `level_set`.")
        if self.points is not None:
            set_("points", check.points("points", self.points))
        else:
            set_("level_set", check.level_set(self.level_set))
        set_("integrator", check.integrator(self.integrator))
        set_("h", check.real("h", self.h, positive=True))
        set_("duration", check.real("duration", self.duration, positive=True))
        set_("record", check.names("record", self.record, OBSERVABLES, "observable"))
        set_("every", check.every(self.every))
        set_("figures", check.names("figures", self.figures, FIGURES, "figure"))
        if self.figures and self.every == "final":
            raise SceneError(self.source, _KEY_OF["figures"],
                             f"figures {list(self.figures)} draw whole trajectories; set `output.every` to an "
                             "integer or `output.figures = []`.")
        set_("view", check.numbers("view", self.view, 2, "angles [elevation, azimuth] in degrees"))
        set_("sections", check.planes("sections", self.sections))
        for label in ("title", "description"):
            set_(label, check.string(label, getattr(self, label)))
        check.mathtext("title", self.title)
        set_("name", check.label("name", self.name))

    # -- construction ----------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path):
        """Read a scene file; a malformed or invalid file raises ``SceneError`` naming it."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise SceneError(str(path), None, f"cannot read the scene file ({exc.strerror}).") from None
        except UnicodeDecodeError as exc:
            raise SceneError(str(path), None, f"not UTF-8 text (byte {exc.object[exc.start]:#04x} at position "
                                              f"{exc.start}); save the file as UTF-8.") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(str(path), None, f"not valid TOML: {exc}.") from None
        except RecursionError:
            raise SceneError(str(path), None, "tables or arrays nested too deeply to read; a scene needs two "
                                              "levels.") from None
        return cls.from_dict(data, source=str(path), name=path.stem)

    @classmethod
    def from_dict(cls, data, source="<dict>", name="scene"):
        """A scene from the nested sections of the file form (what ``to_dict`` returns)."""
        if not isinstance(data, dict):
            raise SceneError(source, None, f"a scene must be a table of sections; got {type(data).__name__}.")
        fields, options = {}, {}
        for key, value in data.items():
            if key in _LAYOUT[""]:
                fields[_LAYOUT[""][key]] = value
            elif key in _LAYOUT and key:
                if not isinstance(value, dict):
                    raise SceneError(source, key, f"must be a table `[{key}]`; got {_describe(value)}.")
                for sub, subvalue in value.items():
                    if key == "integrator" and sub not in _LAYOUT[key]:
                        options[sub] = subvalue  # an option of the method, checked when it is built
                    elif sub not in _LAYOUT[key]:
                        raise SceneError(source, f"{key}.{sub}", _unknown(sub, _LAYOUT[key], f"`[{key}]` takes"))
                    elif sub in _EXPRESSION_KEYS:
                        fields.setdefault("expressions", {})[sub] = subvalue
                    else:
                        fields[_LAYOUT[key][sub]] = subvalue
            else:
                known = [k for k in _LAYOUT[""]] + [f"[{k}]" for k in _LAYOUT if k]
                raise SceneError(source, key, _unknown(key, known, "a scene takes", sort=False))
        if options:
            fields["integrator"] = _with_options(source, fields.get("integrator", "gonzalez"), options)
        if "expressions" in fields:
            fields.setdefault("system", "expressions")
        for required in dataclasses.fields(cls):
            if required.default is dataclasses.MISSING and required.default_factory is dataclasses.MISSING \
                    and required.name not in fields:
                raise SceneError(source, _KEY_OF[required.name], "missing; it is required.")
        return cls(**fields, source=source, name=name)

    def replace(self, **changes):
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # -- resolution --------------------------------------------------------------------------
    def build_system(self):
        """The system (catalogue or formulas) with this scene's parameters and effects."""
        if self.expressions is not None:
            from ..model import expressions as _expressions  # sympy (~0.5 s to import) only for systems as formulas

            try:
                kwargs = _expressions.build(**self.expressions, params=self.parameters, eps=self.eps,
                                            name=self.system, prefix="system.")
                system = MetriplecticSystem(**kwargs)
            except ValueError as exc:
                raise SceneError(self.source, None, str(exc)) from None
            return system.with_effects(hamiltonian=self.hamiltonian)
        constructor = CATALOGUE[self.system]
        try:
            system = constructor(**self.parameters, eps=self.eps)
        except (TypeError, ValueError) as exc:
            raise SceneError(self.source, "system.parameters", str(exc)) from None
        return system.with_effects(hamiltonian=self.hamiltonian)

    def build_method(self):
        """The integrator (wrapped in ``geomint.Projected`` when ``projection`` is on)."""
        method = self._base_method()
        if not self.projection:
            return method
        return self._method({"name": "projected", "method": method_to_data(method)}, "effects.projection")

    def _base_method(self):
        return self._method(self.integrator, _KEY_OF["integrator"])

    def _method(self, data, key):
        try:
            return method_from_data(data, key)
        except MethodDataError as exc:
            raise SceneError(self.source, exc.key, exc.problem) from None

    def initial_states(self, system=None):
        """The initial states, ``(n, 3)``: the given points, or a sample of the level set."""
        if self.points is not None:
            return np.array(self.points, dtype=np.float64)
        system = self.build_system() if system is None else system
        spec = self.level_set
        center = _level_set.energy_minimiser(system) if spec.get("center") is None else np.array(spec["center"])
        try:
            return _level_set.on_rays(system, spec["H0"], _level_set.fibonacci_directions(spec["n"]), center)
        except ValueError as exc:
            raise SceneError(self.source, "initial.level_set", str(exc)) from None

    def resolved(self):
        """This scene with every default written out; builds the system and method, so it validates fully."""
        parameters = dict(self.parameters)
        if self.expressions is None:
            signature = inspect.signature(CATALOGUE[self.system])
            parameters = {k: _plain(p.default) for k, p in signature.parameters.items() if k != "eps"}
            parameters.update(self.parameters)
        system = self.replace(parameters=parameters).build_system()
        method = self.build_method()
        integrator = method_to_data(self._base_method())
        level_set = None
        if self.level_set is not None:
            center = self.level_set.get("center")
            center = _level_set.energy_minimiser(system).tolist() if center is None else center
            level_set = {**self.level_set, "center": center}
        self.replace(level_set=level_set).initial_states(system)  # validates the level set
        try:
            method.check_system(system)
            method.lower(system)
        except (TypeError, ValueError) as exc:
            raise SceneError(self.source, _KEY_OF["integrator"], str(exc)) from None
        resolved = self.replace(parameters=parameters, integrator=integrator, level_set=level_set)
        resolved._check_size()
        return resolved

    def _check_size(self):
        """Step counts and the size of the output, computed before anything runs."""
        steps = self.duration / self.h
        if not steps <= MAX_STEPS:
            raise SceneError(self.source, _KEY_OF["h"], f"duration / h = {steps:.3g} steps per trajectory; at most "
                                                        "2**52 are allowed: use a larger h or a shorter duration.")
        rows = 2 if self.every == "final" else self.steps_per_trajectory // self.every + 2
        # per saved row: t, x, H, S in the solution, and each recorded observable (at most 3 values) stacked
        nbytes = rows * self.n_trajectories * 8 * (6 + 3 * len(self.record))
        problem = _validate.memory_problem(nbytes)
        if problem:
            raise SceneError(self.source, _KEY_OF["every"], f"saving {rows} states of {self.n_trajectories} "
                                                            f"trajectories {problem}; save less often (a larger "
                                                            "`every`, or \"final\").")

    @property
    def steps_per_trajectory(self):
        """Steps ``geomint.solve`` takes for each initial state."""
        return step_count(0.0, self.duration, self.h)

    @property
    def n_trajectories(self):
        """Number of initial states."""
        return len(self.points) if self.points is not None else self.level_set["n"]

    def to_dict(self):
        """The file form: nested sections, ``Scene.from_dict(scene.to_dict()) == scene``."""
        out = {}
        for section, keys in _LAYOUT.items():
            table = {key: _plain(getattr(self, name)) for key, name in keys.items()
                     if getattr(self, name) is not None and name != "expressions"}
            if section:
                out[section] = table
            else:
                out.update(table)
        if isinstance(self.integrator, dict) and list(self.integrator) == ["name"]:
            out["integrator"]["method"] = self.integrator["name"]
        if self.expressions is not None:
            out["system"].update(_plain(self.expressions))
        return out

    def __eq__(self, other):
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()


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
        Seconds per trajectory.
    partial : bool
        True when Ctrl-C stopped the run: the trajectories run so far (the
        last one possibly cut short, ``status`` 2) are the result.
    """

    scene: Scene
    system: object
    method: object
    solutions: list
    records: dict
    wall: list
    partial: bool = False

    @property
    def success(self):
        return all(sol.success for sol in self.solutions)


    def summary(self):
        """A JSON-ready dict: invariant errors, S rises, work, wall time, versions, the scene."""
        ulp = float(np.finfo(np.float64).eps)  # machine epsilon; `eps` is the dissipation parameter
        trajectories = []
        for sol, wall in zip(self.solutions, self.wall):
            trajectories.append({
                "x0": sol.x[0].tolist(), "x_final": sol.x_final.tolist(), "t_final": sol.t_final,
                "H0": float(sol.H[0]), "S0": float(sol.S[0]), "S_final": float(sol.S[-1]),
                "energy_error": sol.energy_error, "energy_error_in_ulp": sol.energy_error / ulp,
                "S_rises": sol.S_rises, "success": sol.success, "status": sol.status, "message": sol.message,
                "n_steps": sol.n_steps, "n_newton": sol.n_newton, "nfev": sol.nfev, "wall_s": wall,
            })
        totals = {
            "partial": self.partial,
            "trajectories": len(trajectories),
            "failed": sum(t["status"] < 0 for t in trajectories),
            "max_energy_error": max(t["energy_error"] for t in trajectories),
            "S_rises": sum(t["S_rises"] for t in trajectories),
            **{k: sum(t[k] for t in trajectories) for k in ("n_steps", "n_newton", "nfev", "wall_s")},
            "rows_saved_per_trajectory": int(self.records["rows"].max()),
        }
        return {
            "scene": self.scene.to_dict(), "system": repr(self.system), "method": method_to_data(self.method),
            "totals": totals, "trajectories": trajectories, "versions": versions(),
            "notes": "energy_error = max |H - H0|/|H0| and S_rises (S up by more than 16 ulps) over the saved "
                     "states; energy_error_in_ulp is it in ulp (units of machine epsilon, 2**-52); "
                     "scene.effects.eps is the dissipation parameter.",
        }


def run_scene(scene, progress=None, checkpoint=None, resume=False, before_steps=None):
    """Run a scene; ``progress(n)`` is called with the number of steps done since its last call, and
    ``before_steps(system, method)`` once the scene and its checkpoint are validated, before the first step.

    Validates the scene fully (``Scene.resolved``), integrates each initial
    state with ``geomint.solve``, and computes only the recorded observables.

    ``checkpoint = (folder, steps)`` keeps the run resumable: each finished
    trajectory is saved in ``folder`` and the running one checkpointed every
    ``steps`` steps (``geomint.solve``'s ``checkpoint``); ``resume=True``
    continues from that folder (``steps`` may then be None: the checkpoint's),
    and the result equals the uninterrupted run's bit for bit.  A folder
    written for another scene raises ``CheckpointError``.
    """
    scene = scene.resolved()
    system = scene.build_system()
    method = scene.build_method()
    states = scene.initial_states(system)
    save_every = None if scene.every == "final" else scene.every
    checkpoint = _checkpoint_folder(scene, checkpoint, resume)
    folder = None if checkpoint is None else checkpoint[0]
    if before_steps is not None:
        before_steps(system, method)
    solutions, wall, partial = [], [], False
    for i, x0 in enumerate(states):
        if folder is not None and (folder / f"{i}.npz").exists():  # finished before the interruption
            solutions.append(_solution.load(folder / f"{i}.npz"))
            wall.append(0.0)
            continue
        done = [0]

        def report(steps, done=done):
            progress(steps - done[0])
            done[0] = steps

        start = time.perf_counter()
        running = None if folder is None else folder / "running.npz"
        try:
            sol = solve(system, x0, (0.0, scene.duration), scene.h, method=method, save_every=save_every,
                        progress=None if progress is None else report,
                        checkpoint=None if folder is None else (running, checkpoint[1]),
                        resume=running if running is not None and running.exists() else None)
        except KeyboardInterrupt:  # Ctrl-C outside the compiled loop (which answers it with status 2)
            partial = True
            break
        wall.append(time.perf_counter() - start)
        solutions.append(sol)
        if folder is not None and sol.status != Status.INTERRUPTED:
            _io.save(sol, folder / f"{i}.npz")
            running.unlink(missing_ok=True)
        if sol.status == Status.INTERRUPTED:
            partial = True
            break
    if not solutions:  # interrupted before a first trajectory ran: nothing to return
        raise KeyboardInterrupt
    records = _records(scene.record, system, solutions)
    return SceneResult(scene=scene, system=system, method=method, solutions=solutions, records=records, wall=wall,
                       partial=partial)


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
            raise CheckpointError(f"no checkpoint in {folder}; run with a checkpoint first.")
        written = json.loads(stamp.read_text())
        if written.get("scene") != json.loads(json.dumps(scene.to_dict())):
            raise CheckpointError(f"the checkpoint in {folder} was written for another scene; remove it or run "
                                  "without resuming.")
        return folder, written["every"] if steps is None else steps
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"`checkpoint` steps must be an integer >= 1; got {steps!r}.")
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    stamp.write_text(json.dumps({"scene": scene.to_dict(), "every": int(steps)}))
    return folder, int(steps)


def _records(names, system, solutions):
    rows = np.array([len(sol.t) for sol in solutions])
    out = {"rows": rows, "t": _stack([sol.t for sol in solutions], rows.max())}
    for name in names:
        out[name] = _stack([np.asarray(OBSERVABLES[name][1](system, sol)) for sol in solutions], rows.max())
    return out


def _stack(arrays, rows):
    out = np.full((len(arrays), rows) + arrays[0].shape[1:], np.nan)
    for i, array in enumerate(arrays):
        out[i, : len(array)] = array
    return out


def versions():
    """Versions of geomint, Python and the numerical libraries, for summaries."""
    import platform

    import numba
    import scipy

    from .._version import __version__

    return {"geomint": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__}


def bundled_scenes():
    """Names of the scenes shipped with geomint -> their paths."""
    from importlib import resources

    folder = resources.files("geomint") / "scenes"
    return {p.name[:-5]: p for p in sorted(folder.iterdir(), key=lambda p: p.name) if p.name.endswith(".toml")}


def load(scene):
    """A ``Scene`` from a file path or the name of a bundled scene."""
    path = Path(scene)
    if path.is_file():
        return Scene.from_toml(path)
    if path.is_dir():
        raise SceneError(scene, None, "is a folder; give a scene file (.toml) or the name of a bundled scene.")
    bundled = bundled_scenes()
    stem = scene[:-5] if scene.endswith(".toml") else scene
    if stem in bundled:
        return Scene.from_toml(bundled[stem])
    raise SceneError(scene, None, f"no such scene file, nor a bundled scene; bundled: {_listing(bundled)}.")


# -- checks (the boundary) ------------------------------------------------------------------
class _Checker:
    def __init__(self, source):
        self.source = source

    def fail(self, name, problem):
        raise SceneError(self.source, _KEY_OF.get(name, name), problem)

    def real(self, name, value, minimum=None, positive=False):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            self.fail(name, f"must be a number; got {_describe(value)}.")
        try:
            value = float(value)
        except OverflowError:
            self.fail(name, f"must be finite in float64; got an integer of {len(str(abs(value)))} digits.")
        if not math.isfinite(value):
            self.fail(name, f"must be finite; got {value!r}.")
        if positive and not value > 0.0:
            self.fail(name, f"must be > 0; got {value!r}.")
        if minimum is not None and value < minimum:
            self.fail(name, f"must be >= {minimum:g}; got {value!r}.")
        return value

    def label(self, name, value):
        self.string(name, value)
        if not _LABEL.fullmatch(value):
            self.fail(name, f"must be a label of letters, digits and _ . - (it names output files), starting with a "
                            f"letter, at most 100 characters; got {value!r}.")
        return value

    def formula_parameters(self, value):
        from ..model import expressions as _expressions

        try:
            return _expressions.check_parameters(value, "system.parameters")
        except ValueError as exc:
            raise SceneError(self.source, None, str(exc)) from None

    def expressions(self, value, parameters):
        unknown = [k for k in value if k not in _EXPRESSION_KEYS]
        if unknown:
            self.fail(f"system.{unknown[0]}", _unknown(unknown[0], _EXPRESSION_KEYS, "a system as formulas takes"))
        for key in ("H", "S"):
            if key not in value:
                self.fail(f"system.{key}", "missing; a system as formulas needs H, S and one of J, P.")
        from ..model import expressions as _expressions

        try:
            _expressions.parse_system(value["H"], value["S"], value.get("J"), value.get("P"), parameters, "system.")
        except ValueError as exc:
            raise SceneError(self.source, None, str(exc)) from None
        return dict(value)

    def boolean(self, name, value):
        if not isinstance(value, (bool, np.bool_)):
            self.fail(name, f"must be true or false; got {_describe(value)}.")
        return bool(value)

    def string(self, name, value):
        if not isinstance(value, str):
            self.fail(name, f"must be a string; got {_describe(value)}.")
        return value

    def mathtext(self, name, value):
        """Text drawn on figures: its ``$...$`` parts must parse as matplotlib mathtext."""
        if value.replace(r"\$", "").count("$") >= 2:
            from matplotlib.mathtext import MathTextParser

            try:
                MathTextParser("path").parse(value)
            except ValueError as exc:
                self.fail(name, f"its $...$ math does not parse ({str(exc).strip().splitlines()[-1]}); "
                                "write \\$ for a dollar sign.")

    def choice(self, name, value, known, what):
        self.string(name, value)
        if value not in known:
            self.fail(name, f"unknown {what} {value!r}; known: {_listing(known)}.")
        return value

    def numbers(self, name, value, count, what="numbers"):
        if isinstance(value, (str, dict)) or not hasattr(value, "__len__") or len(value) != count:
            self.fail(name, f"must be a list of {count} {what}; got {_describe(value)}.")
        return tuple(self.real(name, v) for v in value)

    def vector(self, name, value):
        return self.numbers(name, value, 3)

    def points(self, name, value):
        if isinstance(value, (str, dict)) or not hasattr(value, "__len__") or len(value) == 0:
            self.fail(name, f"must be a non-empty list of points [x, y, z]; got {_describe(value)}.")
        return tuple(self.vector(f"{_KEY_OF[name]}[{i}]", p) for i, p in enumerate(value))

    def level_set(self, value):
        key = _KEY_OF["level_set"]
        if not isinstance(value, dict):
            self.fail("level_set", f"must be a table {{ H0 = ..., n = ... }}; got {_describe(value)}.")
        for sub in value:
            if sub not in _LEVEL_SET_KEYS:
                self.fail(f"{key}.{sub}", _unknown(sub, _LEVEL_SET_KEYS, "`level_set` takes"))
        for sub in ("H0", "n"):
            if sub not in value:
                self.fail(f"{key}.{sub}", "missing; it is required.")
        n = value["n"]
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_TRAJECTORIES:
            self.fail(f"{key}.n", f"must be an integer in [1, {MAX_TRAJECTORIES}]; got {_describe(n)}.")
        center = value.get("center")
        return {"H0": self.real(f"{key}.H0", value["H0"]), "n": int(n),
                "center": None if center is None else list(self.vector(f"{key}.center", center))}

    def integrator(self, value):
        if isinstance(value, str):
            return {"name": value}
        if not isinstance(value, dict) or "name" not in value:
            self.fail("integrator", f"must be a short name or a table {{ name = ..., option = ... }}; "
                                    f"got {_describe(value)}.")
        self.string(f"{_KEY_OF['integrator']}.name", value["name"])
        return dict(value)

    def names(self, name, value, known, what):
        if isinstance(value, str) or not isinstance(value, (list, tuple)):
            self.fail(name, f"must be a list of names; got {_describe(value)}.")
        for item in value:
            self.choice(name, item, known, what)
        return tuple(value)

    def planes(self, name, value):
        if isinstance(value, (str, dict)) or not isinstance(value, (list, tuple)):
            self.fail(name, f"must be a list of planes [a, b, c, d] (a x + b y + c z = d); got {_describe(value)}.")
        planes = []
        for i, plane in enumerate(value):
            key = f"{_KEY_OF[name]}[{i}]"
            numbers = self.numbers(key, plane, 4, "numbers [a, b, c, d] (a x + b y + c z = d)")
            if not any(numbers[:3]):
                self.fail(key, f"the normal (a, b, c) must not be zero; got {list(numbers)}.")
            planes.append(numbers)
        return tuple(planes)

    def every(self, value):
        if value == "final":
            return value
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            self.fail("every", f"must be an integer >= 1 or \"final\"; got {_describe(value)}.")
        return int(value)

    def parameters(self, system, value):
        if not isinstance(value, dict):
            self.fail("parameters", f"must be a table of parameter = value; got {_describe(value)}.")
        known = [k for k in inspect.signature(CATALOGUE[system]).parameters if k != "eps"]
        out = {}
        for key, item in value.items():
            if key == "eps":
                self.fail(f"system.parameters.{key}", "set the dissipation as `effects.eps`.")
            if key not in known:
                self.fail(f"system.parameters.{key}", f"unknown parameter of {system!r}; it takes {_listing(known)}"
                                                      f"{_validate.did_you_mean(key, known)}")
            if isinstance(item, (list, tuple)):
                out[key] = [self.real(f"system.parameters.{key}", v) for v in item]
            else:
                number = self.real(f"system.parameters.{key}", item)
                out[key] = int(item) if isinstance(item, (int, np.integer)) else number
        return out


def _with_options(source, method, options):
    """``[integrator]`` keys besides method, h, duration: the options of ``method``, as one table.

    A key that is no option of a known method is refused here, naming the nearest key (a misspelt
    ``duration`` would otherwise be reported as missing)."""
    from ..integrators.data import options_of, short_names

    cls = short_names().get(method) if isinstance(method, str) else None
    for option in options:
        if cls is not None and option not in options_of(cls):
            known = options_of(cls)
            takes = f"`[integrator]` takes {_listing(_LAYOUT['integrator'])} and the options of {method!r}: " \
                    f"{_listing(known) or 'none'}"
            raise SceneError(source, f"integrator.{option}", _unknown(option, [*_LAYOUT["integrator"], *known],
                                                                      takes, listed=False))
    if not isinstance(method, str):
        key = f"integrator.{next(iter(options))}"
        raise SceneError(source, key, "give the method's options either as keys of `[integrator]` with "
                                      "`method = \"name\"`, or inside the table `method = { name = ..., ... }`, "
                                      "not both.")
    return {"name": method, **options}


def _listing(names):
    return ", ".join(sorted(str(n) for n in names))


def _unknown(key, known, takes, sort=True, listed=True):
    """The problem of an unknown ``key``: what the table ``takes`` (``known``, listed unless ``listed`` is
    False: ``takes`` lists them) and the nearest known key, if one is near."""
    names = [str(k) for k in known]
    listing = (_listing(names) if sort else ", ".join(names)) if listed else ""
    return f"unknown key; {takes}{' ' + listing if listing else ''}{_validate.did_you_mean(key, names)}"


def _describe(value):
    return f"{value!r} ({type(value).__name__})"


def _plain(value):
    """A value TOML and JSON can hold: tuples and arrays become lists."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
