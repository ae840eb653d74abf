"""``Scene``: a declarative run as data, and its file layout (``geomint.scene`` describes the file form).

A scene is validated field by field when it is made (``checks._Checker``) and fully, once, by ``resolved``,
which writes out every default, builds the system and the method, samples the initial states and keeps them.
"""

from __future__ import annotations

import dataclasses
import inspect
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from .. import _validate
from ..analysis import level_set as _level_set
from ..integrators.data import MethodDataError, method_from_data, method_to_data
from ..model.system import MetriplecticSystem
from ..run.arguments import MAX_STEPS
from ..run.controller import step_count
from ..systems import CATALOGUE
from .checks import _EXPRESSION_KEYS, _KEY_OF, _LAYOUT, SceneError, _Checker, _describe, _unknown, _with_options
from .toml import plain, read_toml, scene_file

if TYPE_CHECKING:
    import os

    from ..integrators import Integrator


def _energy_errors(H):
    """``|H - H0| / |H0|`` of each trajectory (a row of ``H``, its first value ``H0``; absolute when ``H0 = 0``),
    as ``geomint.diagnostics.energy_error`` gives it for each."""
    H0 = H[:, :1]
    return np.abs(H - H0) / np.where(H0 != 0, np.abs(H0), 1.0)


def _per_state(function, x):
    """``function`` (a system's field of states) at every state of ``x``, shape (trajectories, rows, 3)."""
    values = np.asarray(function(x.reshape(-1, 3)))
    return values.reshape(x.shape[:2] + values.shape[1:])


#: observable -> (what it is, how it is computed from a system and the run's states stacked: ``x``, ``H``, ``S``
#: of shape (trajectories, rows, ...), NaN after each trajectory's rows, as ``geomint.Ensemble`` holds them)
OBSERVABLES = {
    "x": ("state, (rows, 3)", lambda system, run: run.x),
    "H": ("energy", lambda system, run: run.H),
    "S": ("Casimir", lambda system, run: run.S),
    "energy_error": ("|H - H0| / |H0| (absolute when H0 = 0)", lambda system, run: _energy_errors(run.H)),
    "sigma": ("sigma = grad S x grad H, (rows, 3)", lambda system, run: _per_state(system.sigma, run.x)),
    "dS_dt": ("dS/dt = -eps |sigma|^2", lambda system, run: _per_state(system.dS_dt, run.x)),
    "xi": ("the simulated field, (rows, 3)", lambda system, run: _per_state(system.xi, run.x)),
}

#: figure -> what it draws (geomint.plotting draws them)
FIGURES = {
    "overview": "trajectories on the level surface of H in 3-D, with H(t) and S(t) panels",
    "trajectories": "trajectories on the level surface of H in 3-D, equilibria marked",
    "invariants": "relative energy error and S against t",
    "drift": "windowed maxima of the energy error against t (log-log) with the fitted growth law",
}


class Built(NamedTuple):
    """What resolving a scene builds: the system (effects applied), the method, the initial states (n, 3)."""

    system: MetriplecticSystem
    method: Integrator
    states: np.ndarray


@dataclass(frozen=True, eq=False)
class Scene:
    """A declarative run; the file form is described in ``geomint.scene``.

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
        (the method's plain-data form, ``geomint.integrators.data``).
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

    def __post_init__(self) -> None:
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
            raise SceneError(
                self.source,
                "effects",
                "every effect is off (hamiltonian = false, eps = 0): there is nothing to simulate.",
            )
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
            raise SceneError(
                self.source,
                _KEY_OF["figures"],
                f"figures {list(self.figures)} draw whole trajectories; set `output.every` to an "
                "integer or `output.figures = []`.",
            )
        set_("view", check.numbers("view", self.view, 2, "angles [elevation, azimuth] in degrees"))
        set_("sections", check.planes("sections", self.sections))
        for label in ("title", "description"):
            set_(label, check.string(label, getattr(self, label)))
        check.mathtext("title", self.title)
        set_("name", check.label("name", self.name))
        set_("_built", None)  # what ``resolved`` builds, kept by the resolved scene

    # -- construction ----------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> Scene:
        """Read a scene file; a malformed or invalid file raises ``SceneError`` naming it."""
        path = Path(path)
        return cls.from_dict(read_toml(path), source=str(path), name=path.stem)

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>", name: str = "scene") -> Scene:
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
            if (
                required.default is dataclasses.MISSING
                and required.default_factory is dataclasses.MISSING
                and required.name not in fields
            ):
                raise SceneError(source, _KEY_OF[required.name], "missing; it is required.")
        return cls(**fields, source=source, name=name)

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # -- resolution --------------------------------------------------------------------------
    def build_system(self) -> MetriplecticSystem:
        """The system (catalogue or formulas) with this scene's parameters and effects."""
        return self._system(self.parameters)

    def _system(self, parameters):
        if self.expressions is not None:
            from ..model import expressions as _expressions  # sympy, slow to import, only for systems as formulas

            try:
                kwargs = _expressions.build(
                    **self.expressions, params=parameters, eps=self.eps, name=self.system, prefix="system."
                )
                system = MetriplecticSystem(**kwargs)
            except ValueError as exc:
                raise SceneError(self.source, None, str(exc)) from None
            return system.with_effects(hamiltonian=self.hamiltonian)
        constructor = CATALOGUE[self.system]
        try:
            system = constructor(**parameters, eps=self.eps)
        except (TypeError, ValueError) as exc:
            raise SceneError(self.source, "system.parameters", str(exc)) from None
        return system.with_effects(hamiltonian=self.hamiltonian)

    def build_method(self) -> Integrator:
        """The integrator (wrapped in ``geomint.Projected`` when ``projection`` is on)."""
        return self._projected(self._base_method())

    def _projected(self, method):
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

    def initial_states(self, system: MetriplecticSystem | None = None) -> np.ndarray:
        """The initial states, ``(n, 3)``: the given points, or a sample of the level set (a resolved scene's
        sample, taken once)."""
        if self._built is not None and system is None:  # pyright: ignore[reportAttributeAccessIssue]  # set in __post_init__
            return self._built.states.copy()  # pyright: ignore[reportAttributeAccessIssue]
        return self._initial_states(self.build_system() if system is None else system, self.level_set)

    def _initial_states(self, system, level_set):
        if self.points is not None:
            return np.array(self.points, dtype=np.float64)
        center = level_set.get("center")
        center = _level_set.energy_minimiser(system) if center is None else np.array(center)
        try:
            return _level_set.on_rays(system, level_set["H0"], _level_set.fibonacci_directions(level_set["n"]), center)
        except ValueError as exc:
            raise SceneError(self.source, "initial.level_set", str(exc)) from None

    def resolved(self) -> Scene:
        """This scene with every default written out; builds the system and method, so it validates fully.

        Done once: the resolved scene keeps the system, method and initial states it built (``built``), and
        resolving it again returns it."""
        if self._built is not None:  # pyright: ignore[reportAttributeAccessIssue]  # set in __post_init__
            return self
        parameters = dict(self.parameters)
        if self.expressions is None:
            signature = inspect.signature(CATALOGUE[self.system])
            parameters = {k: plain(p.default) for k, p in signature.parameters.items() if k != "eps"}
            parameters.update(self.parameters)
            parameters = _Checker(self.source).parameters(self.system, parameters)
        system = self._system(parameters)
        base = self._base_method()
        method = self._projected(base)
        level_set = None
        if self.level_set is not None:
            center = self.level_set.get("center")
            center = _level_set.energy_minimiser(system).tolist() if center is None else center
            level_set = {**self.level_set, "center": center}
        states = self._initial_states(system, level_set)
        try:
            method.check_system(system)
            method.lower(system)
        except (TypeError, ValueError) as exc:
            raise SceneError(self.source, _KEY_OF["integrator"], str(exc)) from None
        resolved = self.replace(parameters=parameters, integrator=method_to_data(base), level_set=level_set)
        resolved._check_size()
        object.__setattr__(resolved, "_built", Built(system, method, states))
        return resolved

    def built(self) -> Built:
        """``Built(system, method, states)`` of a resolved scene (``resolved`` builds them once)."""
        if self._built is None:  # pyright: ignore[reportAttributeAccessIssue]  # set in __post_init__
            raise ValueError("only a resolved scene keeps what it built; call `scene.resolved()` first.")
        return self._built  # pyright: ignore[reportAttributeAccessIssue]

    def _check_size(self):
        """Step counts and the size of the output, computed before anything runs."""
        steps = self.duration / self.h
        if not steps <= MAX_STEPS:
            raise SceneError(
                self.source,
                _KEY_OF["h"],
                f"duration / h = {steps:.3g} steps per trajectory; at most "
                "2**52 are allowed: use a larger h or a shorter duration.",
            )
        rows = 2 if self.every == "final" else self.steps_per_trajectory // self.every + 2  # pyright: ignore[reportOperatorIssue]
        # per saved row: t, x, H, S in the solution, and each recorded observable (at most 3 values) stacked
        nbytes = rows * self.n_trajectories * 8 * (6 + 3 * len(self.record))
        problem = _validate.memory_problem(nbytes)
        if problem:
            raise SceneError(
                self.source,
                _KEY_OF["every"],
                f"saving {rows} states of {self.n_trajectories} "
                f"trajectories {problem}; save less often (a larger "
                '`every`, or "final").',
            )

    @property
    def steps_per_trajectory(self) -> int:
        """Steps ``geomint.solve`` takes for each initial state."""
        return step_count(0.0, self.duration, self.h)

    @property
    def n_trajectories(self) -> int:
        """Number of initial states."""
        return len(self.points) if self.points is not None else self.level_set["n"]  # pyright: ignore[reportOptionalSubscript]

    def to_dict(self) -> dict[str, Any]:
        """The file form: nested sections, ``Scene.from_dict(scene.to_dict()) == scene``."""
        out = {}
        for section, keys in _LAYOUT.items():
            table = {
                key: plain(getattr(self, name))
                for key, name in keys.items()
                if getattr(self, name) is not None and name != "expressions"
            }
            if section:
                out[section] = table
            else:
                out.update(table)
        if isinstance(self.integrator, dict) and list(self.integrator) == ["name"]:
            out["integrator"]["method"] = self.integrator["name"]
        if self.expressions is not None:
            out["system"].update(plain(self.expressions))
        return out

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()


def load_scene(scene: str) -> Scene:
    """A ``Scene`` from a file path or the name of a bundled scene (``bundled_scenes``)."""
    return Scene.from_toml(scene_file(scene))  # pyright: ignore[reportArgumentType]  # bundled scenes are files
