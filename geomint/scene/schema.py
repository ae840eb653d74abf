"""``Scene``: a declarative run as data, and its file layout (``geomint.scene`` describes the file form).

A scene is validated field by field when it is made (``checks._Checker``) and fully, once, by ``resolved``,
which writes out every default, builds the system and the method, samples the initial states and keeps them.

A scene in R^n names a system of ``geomint.systems.RN_CATALOGUE`` (``[system] catalogue = ...`` with its
arguments as further keys) or writes one as formulas with named ``variables`` (``formulas_n``); its states
are given by name, as vectors or drawn from a distribution (``states``), and its figures are those of
``FIGURES`` that draw in any dimension (``FIGURES_R3`` draw level surfaces in R^3).
"""

from __future__ import annotations

import dataclasses
import inspect
import os
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
from ..systems import CATALOGUE, RN_CATALOGUE
from . import catalogue_n, formulas_n
from . import states as _states
from .checks import (
    _EXPRESSION_KEYS,
    _EXPRESSION_KEYS_N,
    _KEY_OF,
    _LAYOUT,
    SceneError,
    _Checker,
    _describe,
    _listing,
    _unknown,
    _with_options,
)
from .toml import plain, read_toml, scene_file

if TYPE_CHECKING:
    from ..integrators import Integrator


def _energy_errors(H):
    """``|H - H0| / |H0|`` of each trajectory (a row of ``H``, its first value ``H0``; absolute when ``H0 = 0``),
    as ``geomint.diagnostics.energy_error`` gives it for each."""
    H0 = H[:, :1]
    return np.abs(H - H0) / np.where(H0 != 0, np.abs(H0), 1.0)


def _per_state(function, x):
    """``function`` (a system's field of states) at every state of ``x``, shape (trajectories, rows, n)."""
    values = np.asarray(function(x.reshape(-1, x.shape[-1])))
    return values.reshape(x.shape[:2] + values.shape[1:])


#: observable -> (what it is, how it is computed from a system and the run's states stacked: ``x``, ``H``, ``S``
#: of shape (trajectories, rows, ...), NaN after each trajectory's rows, as ``geomint.Ensemble`` holds them)
OBSERVABLES = {
    "x": ("state, (rows, n): n = 3, or the system's dimension in R^n", lambda system, run: run.x),
    "H": ("energy (E in GENERIC form)", lambda system, run: run.H),
    "S": ("Casimir (the entropy in GENERIC form)", lambda system, run: run.S),
    "energy_error": ("|H - H0| / |H0| (absolute when H0 = 0)", lambda system, run: _energy_errors(run.H)),
    "sigma": ("sigma = grad S x grad H, (rows, 3); R^3 only", lambda system, run: _per_state(system.sigma, run.x)),
    "dS_dt": ("dS/dt (-eps |sigma|^2 in R^3)", lambda system, run: _per_state(system.dS_dt, run.x)),
    "xi": ("the simulated field, (rows, n)", lambda system, run: _per_state(system.xi, run.x)),
}
#: the observables of systems in R^3 only
OBSERVABLES_R3 = ("sigma",)

#: figure -> what it draws (geomint.plotting draws them)
FIGURES = {
    "overview": "trajectories on the level surface of H in 3-D, with H(t) and S(t) panels [R^3]",
    "trajectories": "trajectories on the level surface of H in 3-D, equilibria marked [R^3]",
    "invariants": "relative energy error and S against t",
    "drift": "windowed maxima of the energy error against t (log-log) with the fitted growth law",
    "series": "chosen coordinates against t, by name (output.series; a family name draws its members)",
    "relaxation": "E - E0 in ulps, S with its limit S_inf, and |S - S_inf| on a log axis with the fitted rate "
    "(output.limit)",
    "energy_ulps": "the energy error (E - E0)/|E0| in ulps against t, step by step and its running maximum",
    "phase": "trajectories projected onto 2 or 3 chosen coordinates (output.phase), start and end marked",
    "vorticity": "2-D Euler: the vorticity field at chosen times (output.snapshots) and |S - S_inf| against t",
}
#: the figures that draw level surfaces in R^3, and the default figures of a scene in R^3 and in R^n
FIGURES_R3 = ("overview", "trajectories")
DEFAULT_FIGURES = ("overview",)
DEFAULT_FIGURES_N = ("relaxation", "series")
#: how ``output.limit`` says where S_inf comes from (or a number, or one per trajectory)
LIMITS = ("known", "tail")


class Built(NamedTuple):
    """What resolving a scene builds: the system (effects applied), the method, the initial states (m, n)."""

    system: MetriplecticSystem
    method: Integrator
    states: np.ndarray


@dataclass(frozen=True, eq=False)
class Scene:
    """A declarative run; the file form is described in ``geomint.scene``.

    Parameters
    ----------
    system : str
        A name in ``geomint.systems.CATALOGUE``, or in ``RN_CATALOGUE`` (a
        system in R^n; the file's ``[system] catalogue = ...``); with
        ``expressions``, a label (letters, digits, ``_ . -``).
    parameters : dict
        Keyword arguments of the R^3 catalogue function except ``eps``; with
        ``expressions``, the formulas' parameters ``{name: value}``.
    arguments : dict, optional
        Keyword arguments of the R^n catalogue function except ``eps`` (the
        file's further keys of ``[system]``: ``N = 8``, ``gamma = 0.5``).
    expressions : dict, optional
        ``{"H": str, "S": str, "J": [3 str]}`` or with ``"P": [[3 str] x 3]``:
        the system as formulas (``geomint.MetriplecticSystem.from_expressions``).
        In R^n, with ``"variables"`` (and ``"sizes"``, ``"define"``): H, S, P,
        metric (Fish form) or E, S, L, M (GENERIC), as
        ``MetriplecticSystemN.from_expressions`` and
        ``GenericSystem.from_expressions`` take them (``geomint.scene.formulas_n``).
    hamiltonian : bool, default True
        Simulate the Hamiltonian part ``xi_P = grad H x J`` (in R^n: P grad H,
        or L grad E).
    eps : float, default 1.0
        Dissipation ``eps xi_g``; 0 switches it off (GENERIC: scales M).
    projection : bool, default False
        Wrap the integrator in ``geomint.Projected`` (projection onto H = H0).
    points : sequence of vectors, optional
        Initial states (3 numbers each; n in R^n, in the order of
        ``system.variables``).
    level_set : dict, optional
        ``{"H0": float, "n": int, "center": 3-vector (default: the minimiser of H)}``:
        ``n`` initial states spread over ``H = H0`` (``geomint.level_set.sample``).
        In R^3 give exactly one of ``points`` and ``level_set``.
    state : dict or sequence of dicts, optional
        R^n: initial states by name, ``{"q": 1.5, "p": 0.0}`` (a family name,
        ``q`` for ``q1 ... qN``, takes a number or one per member).
    random : dict, optional
        R^n: ``{"n": m, "seed": int, "ranges": {name: [low, high] or number}}``
        or ``{"n": m, "seed": int, "around": {name: number} or vector, "std":
        number, {name: number} or vector}`` (``geomint.scene.states``). In R^n
        give exactly one of ``points``, ``state`` and ``random``.
    fill : float, optional
        The value of the coordinates a table by name does not give (without
        it, every coordinate must be given).
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
    figures : sequence of str, optional
        Keys of ``FIGURES``; they need ``every`` to be an integer. Default
        ``("overview",)`` in R^3, ``("relaxation", "series")`` in R^n.
    view : (elevation, azimuth), default (30, -60)
        Viewing angles of 3-D panels, in degrees.
    sections : sequence of (a, b, c, d)
        Planes ``a x + b y + c z = d`` whose intersections with the level
        surface are drawn (e.g. the plane where the Poisson tensor vanishes).
    series : sequence of str, optional
        The coordinates the figure ``series`` draws, by name (a family name
        draws its members); default the first family's, or the first six.
    phase : sequence of 2 or 3 str, optional
        The coordinates the figure ``phase`` projects onto; default the first
        two (the first members of the first two families).
    snapshots : sequence of float, optional
        The times the figure ``vorticity`` draws (each at the nearest saved
        state); default 0, T/10, T/4, T/2, T.
    limit : "known", "tail", float or sequence of float, optional
        The limit S_inf of S for the figures and the summary: the catalogue's
        closed form (``"known"``, the default where there is one), estimated
        from the tail (``"tail"``, the default otherwise), or given (one number,
        or one per trajectory).
    title, description, name : str
        Labels; ``name`` is the stem of output files.
    source : str
        Where the scene came from (a file path, or ``"<Scene>"``); errors name it.
    """

    system: str
    h: float
    duration: float
    parameters: dict = field(default_factory=dict)
    arguments: dict | None = None
    expressions: dict | None = None
    hamiltonian: bool = True
    eps: float = 1.0
    projection: bool = False
    points: tuple | None = None
    level_set: dict | None = None
    state: Any = None
    random: dict | None = None
    fill: float | None = None
    integrator: str | dict = "gonzalez"
    record: tuple = ("x", "H", "S")
    every: int | str = 1
    figures: Any = None  # a tuple once made (None: the default of the scene's dimension)
    view: tuple = (30.0, -60.0)
    sections: tuple = ()
    series: tuple | None = None
    phase: tuple | None = None
    snapshots: tuple | None = None
    limit: Any = None
    title: str = ""
    description: str = ""
    name: str = "scene"
    source: str = "<Scene>"

    def __post_init__(self) -> None:
        check = _Checker(self.source)
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731 (frozen dataclass)
        set_("_declared_names", None)  # the coordinates of a system as formulas in R^n, from its declarations
        if self.expressions is None and (self.arguments is not None or self.system in RN_CATALOGUE):
            set_("system", check.rn_catalogue(self.system))
            set_("arguments", check.arguments(self.system, {} if self.arguments is None else self.arguments))
            if self.parameters:
                check.fail(
                    "system.parameters",
                    f"{self.system!r} is a system in R^n: give its arguments as keys of [system] "
                    f"({', '.join(catalogue_n.arguments(self.system))}), not in `parameters`.",
                )
        elif self.expressions is None:
            set_("system", check.catalogue(self.system))
            set_("parameters", check.parameters(self.system, self.parameters))
        elif "variables" in self.expressions:
            set_("system", check.label("system", self.system))
            expressions, declared = formulas_n.check(self.source, self.expressions, self.parameters)
            set_("expressions", expressions)
            set_("_declared_names", tuple(declared.names))
            set_("parameters", {k: float(v) for k, v in self.parameters.items()})
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
        if self.in_rn:
            _states.static_check(self.source, self.points, self.state, self.random, self.level_set, self.fill)
            if self.fill is not None:
                set_("fill", float(self.fill))
        else:
            for key in ("state", "random", "fill"):
                if getattr(self, key) is not None:
                    check.fail(
                        f"initial.{key}",
                        "states by name, `random` and `fill` are for systems in R^n; in R^3 give `points` or "
                        "`level_set`.",
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
        figures = check.names(
            "figures",
            (DEFAULT_FIGURES_N if self.in_rn else DEFAULT_FIGURES) if self.figures is None else self.figures,
            FIGURES,
            "figure",
        )
        set_("figures", figures)
        if self.in_rn:
            self._check_rn(check)
        elif "vorticity" in figures:
            check.fail(
                "output.figures",
                "'vorticity' draws 2-D Euler's vorticity (catalogue euler_zeitlin, euler_galerkin), a system in R^n.",
            )
        if self.figures and self.every == "final":
            raise SceneError(
                self.source,
                _KEY_OF["figures"],
                f"figures {list(self.figures)} draw whole trajectories; set `output.every` to an "
                "integer or `output.figures = []`.",
            )
        set_("view", check.numbers("view", self.view, 2, "angles [elevation, azimuth] in degrees"))
        set_("sections", check.planes("sections", self.sections))
        if self.sections and self.in_rn:
            check.fail("output.sections", "planes a x + b y + c z = d cut level surfaces in R^3; not in R^n.")
        for key in ("series", "phase"):
            if getattr(self, key) is not None:
                set_(key, check.coordinate_names(f"output.{key}", getattr(self, key), 2 if key == "phase" else None))
        if self.snapshots is not None:
            set_("snapshots", check.times("output.snapshots", self.snapshots, self.duration))
        set_("limit", check.limit(self.limit))
        self._check_limit(check)
        if isinstance(self.limit, tuple) and len(self.limit) != self.n_trajectories:
            check.fail(
                "output.limit",
                f"one S_inf per trajectory: the scene has {self.n_trajectories}; got {len(self.limit)} values.",
            )
        for label in ("title", "description"):
            set_(label, check.string(label, getattr(self, label)))
        check.mathtext("title", self.title)
        set_("name", check.label("name", self.name))
        set_("_built", None)  # what ``resolved`` builds, kept by the resolved scene

    def _check_rn(self, check):
        """What a scene in R^n can check before its system is built: the observables and figures it can draw."""
        for name in self.record:
            if name in OBSERVABLES_R3:
                check.fail(
                    "output.record",
                    f"{name!r} is a cross product, defined in R^3 only; a system in R^n records "
                    f"{_listing(k for k in OBSERVABLES if k not in OBSERVABLES_R3)}.",
                )
        drawable = [f for f in FIGURES if f not in FIGURES_R3 and (f != "vorticity" or self.is_euler)]
        for name in self.figures:
            if name in FIGURES_R3:
                check.fail(
                    "output.figures",
                    f"{name!r} draws the level surface of H in R^3; a system in R^n draws {', '.join(drawable)}.",
                )
            if name == "vorticity" and not self.is_euler:
                check.fail(
                    "output.figures",
                    f"'vorticity' draws 2-D Euler's vorticity field (catalogue euler_zeitlin, euler_galerkin); "
                    f"{self.system!r} draws {', '.join(drawable)}.",
                )

    def _check_limit(self, check):
        if self.limit == "known" and self.known_limit is None:
            check.fail(
                "output.limit",
                f"{self.system!r} has no closed-form S_inf with these effects; give a number (or one per "
                'trajectory) or "tail" (estimated from the end of the run).',
            )

    # -- what kind of scene --------------------------------------------------------------------
    @property
    def in_rn(self) -> bool:
        """Whether the scene's system lives in R^n (an R^n catalogue system or formulas with ``variables``)."""
        return self.arguments is not None or (self.expressions is not None and "variables" in self.expressions)

    @property
    def is_euler(self) -> bool:
        """Whether the system is a truncation of 2-D Euler from the catalogue (it has a vorticity field)."""
        return self.arguments is not None and self.system in ("euler_zeitlin", "euler_galerkin")

    @property
    def known_limit(self) -> catalogue_n.Limit | None:
        """The catalogue's closed-form S_inf for this scene's system and effects, or None."""
        if self.arguments is None:
            return None
        return catalogue_n.known_limit(self.system, self.arguments, self.hamiltonian, self.eps)

    def expected_rate(self, H0: float) -> tuple[float, str] | None:
        """The catalogue's linearised rate of ``|S - S_inf|`` near the limit for energy ``H0``, with what it is
        (``catalogue_n.expected_rate``), or None."""
        if self.arguments is None:
            return None
        return catalogue_n.expected_rate(self.system, self.arguments, self.hamiltonian, self.eps, H0)

    # -- construction ----------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> Scene:
        """Read a scene file; a malformed or invalid file raises ``SceneError`` naming it."""
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"`path` must be a scene file's path; got {path!r} ({type(path).__name__}).")
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
                if key == "system":
                    _system_fields(source, value, fields)
                    continue
                for sub, subvalue in value.items():
                    if key == "integrator" and sub not in _LAYOUT[key]:
                        options[sub] = subvalue  # an option of the method, checked when it is built
                    elif sub not in _LAYOUT[key]:
                        raise SceneError(source, f"{key}.{sub}", _unknown(sub, _LAYOUT[key], f"`[{key}]` takes"))
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
        return self._system(self.arguments if self.arguments is not None else self.parameters)

    def _system(self, parameters):
        if self.in_rn:
            return self._system_n(parameters)
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

    def _system_n(self, arguments):
        """A system in R^n: the catalogue's with these arguments, or the formulas'; the effects applied."""
        if self.arguments is None:
            system = formulas_n.build(self.source, self.expressions, self.parameters, self.eps, self.system)
        else:
            try:
                system = RN_CATALOGUE[self.system](**arguments)
            except (TypeError, ValueError) as exc:
                raise SceneError(self.source, _argument_key(str(exc), arguments), " ".join(str(exc).split())) from None
        return system.with_effects(hamiltonian=self.hamiltonian, eps=self.eps)

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
        """The initial states, ``(m, n)``: the given points, or a sample of the level set (a resolved scene's
        sample, taken once); in R^n the states by name, the vectors or the draw."""
        if self._built is not None and system is None:  # pyright: ignore[reportAttributeAccessIssue]  # set in __post_init__
            return self._built.states.copy()  # pyright: ignore[reportAttributeAccessIssue]
        return self._initial_states(self.build_system() if system is None else system, self.level_set)

    def _initial_states(self, system, level_set):
        if self.in_rn:
            return _states.resolve(self.source, system.variables, self.points, self.state, self.random, self.fill)
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
        if self.in_rn:
            return self._resolved_n()
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
        self._check_method(method, system)
        resolved = self.replace(parameters=parameters, integrator=method_to_data(base), level_set=level_set)
        resolved._check_size()
        object.__setattr__(resolved, "_built", Built(system, method, states))
        return resolved

    def _resolve_names(self, variables, system=None):
        """``(series, phase, states)`` with the coordinates ``variables``: every name the scene gives checked."""
        states = _states.resolve(self.source, variables, self.points, self.state, self.random, self.fill)
        series = self.series if self.series is not None else _states.default_series(variables)
        phase = self.phase if self.phase is not None else _states.default_phase(variables)
        for key, names in (("output.series", series), ("output.phase", phase)):
            _states.check_names(self.source, key, names, variables)
        if len(set(_states.expand(phase, variables))) not in (2, 3):
            raise SceneError(
                self.source,
                "output.phase",
                f"must name 2 or 3 coordinates to project onto; {list(phase)} names "
                f"{len(_states.expand(phase, variables))}.",
            )
        return series, phase, states

    def _check_starts(self, system, states):
        """Each start where the system is defined (E or H and S finite), or a ``SceneError`` naming the state."""
        with np.errstate(all="ignore"):
            try:
                H, S = np.atleast_1d(system.H(states)), np.atleast_1d(system.S(states))
            except (ValueError, TypeError, ArithmeticError) as exc:
                raise SceneError(self.source, "initial", " ".join(str(exc).split())) from None
        for i in np.flatnonzero(~(np.isfinite(H) & np.isfinite(S))):
            if self.points is not None:
                key = f"initial.points[{i}]"
            elif self.state is not None:
                key = "initial.state" if isinstance(self.state, dict) else f"initial.state[{i}]"
            else:
                key = f"initial.random (state {i}, seed {self.random.get('seed', 0)})"  # pyright: ignore[reportOptionalMemberAccess]
            energy = "E" if system.direction > 0 else "H"
            named = ", ".join(f"{v} = {x:.6g}" for v, x in zip(system.variables[:12], states[i]))
            raise SceneError(
                self.source,
                key,
                f"{energy} and S must be finite at the start; at ({named}){' ...' if len(states[i]) > 12 else ''} "
                f"{energy} = {float(H[i])!r}, S = {float(S[i])!r}: the state is outside the system's domain.",
            )

    def _check_method(self, method, system):
        try:
            method.check_system(system)
            method.lower(system)
        except (TypeError, ValueError) as exc:
            raise SceneError(self.source, _KEY_OF["integrator"], " ".join(str(exc).split())) from None

    def _resolved_n(self):
        arguments = None
        if self.arguments is not None:
            arguments = {k: plain(v) for k, v in {**catalogue_n.defaults(self.system), **self.arguments}.items()}
        declared = self._declared_names  # pyright: ignore[reportAttributeAccessIssue]  # set in __post_init__
        if declared is not None:  # formulas: the coordinates are known before the system is built
            self._resolve_names(declared)
        system = self._system_n(arguments)
        series, phase, states = self._resolve_names(system.variables, system)
        self._check_starts(system, states)
        base = self._base_method()
        method = self._projected(base)
        self._check_method(method, system)
        snapshots = self.snapshots
        if snapshots is None and "vorticity" in self.figures:
            snapshots = tuple(float(f * self.duration) for f in (0.0, 0.1, 0.25, 0.5, 1.0))
        limit = self.limit if self.limit is not None else ("known" if self.known_limit is not None else "tail")
        resolved = self.replace(
            arguments=arguments,
            integrator=method_to_data(base),
            series=series,
            phase=phase,
            snapshots=snapshots,
            limit=limit,
        )
        resolved._check_size(system.dim)
        object.__setattr__(resolved, "_built", Built(system, method, states))
        return resolved

    def built(self) -> Built:
        """``Built(system, method, states)`` of a resolved scene (``resolved`` builds them once)."""
        if self._built is None:  # pyright: ignore[reportAttributeAccessIssue]  # set in __post_init__
            raise ValueError("only a resolved scene keeps what it built; call `scene.resolved()` first.")
        return self._built  # pyright: ignore[reportAttributeAccessIssue]

    def _check_size(self, dim=3):
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
        # per saved row: t, x, H, S in the solution, and each recorded observable (at most n values) stacked
        nbytes = rows * self.n_trajectories * 8 * (2 * dim + dim * len(self.record))
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
        if self.points is not None:
            return len(self.points)
        if self.state is not None:
            return 1 if isinstance(self.state, dict) else len(self.state)
        if self.random is not None:
            return self.random["n"]
        return self.level_set["n"]  # pyright: ignore[reportOptionalSubscript]

    def to_dict(self) -> dict[str, Any]:
        """The file form: nested sections, ``Scene.from_dict(scene.to_dict()) == scene``."""
        out = {}
        for section, keys in _LAYOUT.items():
            if section == "system":
                out["system"] = self._system_table()
                continue
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
        return out

    def _system_table(self):
        if self.arguments is not None:
            return {"catalogue": self.system, **plain(self.arguments)}
        table = {"name": self.system, "parameters": plain(self.parameters)}
        if self.expressions is not None:
            table.update(plain(self.expressions))
        return table

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()


def _system_fields(source, table, fields):
    """The fields of ``[system]``: ``catalogue`` and the arguments as further keys (a system in R^n), or
    ``name`` with ``parameters`` (R^3) and the formulas (R^3, or R^n with ``variables``)."""
    if "catalogue" in table:
        others = [k for k in ("name", "parameters", *_EXPRESSION_KEYS_N, "J") if k in table]
        if others:
            raise SceneError(
                source,
                f"system.{others[0]}",
                "a catalogue system in R^n (`catalogue = ...`) takes its arguments as keys of [system] "
                f"(N = 8, gamma = 0.5); `{others[0]}` is a key of a system named by `name` or written as formulas.",
            )
        fields["system"] = table["catalogue"]
        fields["arguments"] = {k: v for k, v in table.items() if k != "catalogue"}
        return
    formulas_n_given = "variables" in table
    known = (
        ["name", "parameters", *_EXPRESSION_KEYS_N] if formulas_n_given else ["name", "parameters", *_EXPRESSION_KEYS]
    )
    for sub, value in table.items():
        if sub not in known:
            if sub in _EXPRESSION_KEYS_N:  # a key of systems in R^n, without variables
                raise SceneError(
                    source,
                    f"system.{sub}",
                    "a key of a system in R^n written as formulas: declare its coordinates with `variables` "
                    '(["q[1..N]", "p[1..N]", "s"]); in R^3 a system as formulas takes H, S and J or P.',
                )
            takes = "`[system]` takes catalogue (a system in R^n, with its arguments), name, parameters and formulas:"
            raise SceneError(source, f"system.{sub}", _unknown(sub, ["catalogue", *known], takes))
        if sub == "name":
            if value in RN_CATALOGUE and not formulas_n_given and not any(k in table for k in _EXPRESSION_KEYS):
                raise SceneError(
                    source,
                    "system.name",
                    f"{value!r} is a system in R^n: name it with catalogue = {value!r}, its arguments as keys of "
                    "[system] (N = 8, gamma = 0.5).",
                )
            fields["system"] = value
        elif sub == "parameters":
            fields["parameters"] = value
        else:
            fields.setdefault("expressions", {})[sub] = value


def _argument_key(message, arguments):
    """The key of an R^n catalogue constructor's error: the argument it names in backticks, else ``system``."""
    import re

    for name in re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", message):
        if name in arguments:
            return f"system.{name}"
    return "system.catalogue"


def load_scene(scene: str) -> Scene:
    """A ``Scene`` from a file path or the name of a bundled scene (``bundled_scenes``)."""
    return Scene.from_toml(scene_file(scene))  # pyright: ignore[reportArgumentType]  # bundled scenes are files
