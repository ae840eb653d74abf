"""The boundary of a scene: ``SceneError``, the file's layout of sections and keys, and ``_Checker``, which
validates each field and names the key, the rule and the nearest known name when one is misspelt."""

import inspect
import math
import re
from typing import NoReturn

import numpy as np

from .. import _validate
from ..systems import CATALOGUE, RN_CATALOGUE


class SceneError(ValueError):
    """A scene that cannot run: names the file, the key and the problem."""

    def __init__(self, source: str, key: str | None, problem: str) -> None:
        self.source, self.key, self.problem = source, key, problem
        where = f"{source}: " if source else ""
        shown = key if key is None or len(key) <= 120 else f"{key[:100]}... ({len(key)} characters)"
        super().__init__(f"{where}`{shown}`: {problem}" if key else f"{where}{problem}")


# section -> key in the file -> Scene field; "" is the top level
_LAYOUT = {
    "": {"title": "title", "description": "description"},
    "system": {
        "name": "system",
        "parameters": "parameters",
        "H": "expressions",
        "S": "expressions",
        "J": "expressions",
        "P": "expressions",
        # in R^n: a catalogue system (its arguments are further keys of [system]) or formulas
        "catalogue": "system",
        "variables": "expressions",
        "sizes": "expressions",
        "define": "expressions",
        "metric": "expressions",
        "E": "expressions",
        "L": "expressions",
        "M": "expressions",
    },
    "effects": {"hamiltonian": "hamiltonian", "eps": "eps", "projection": "projection"},
    "initial": {"points": "points", "level_set": "level_set", "state": "state", "random": "random", "fill": "fill"},
    "integrator": {"method": "integrator", "h": "h", "duration": "duration"},
    "output": {
        "record": "record",
        "every": "every",
        "figures": "figures",
        "view": "view",
        "sections": "sections",
        "series": "series",
        "phase": "phase",
        "snapshots": "snapshots",
        "limit": "limit",
    },
}
_KEY_OF = {
    name: (f"{section}.{key}" if section else key) for section, keys in _LAYOUT.items() for key, name in keys.items()
}
_KEY_OF["expressions"] = "system"
_KEY_OF["system"] = "system.name"
_KEY_OF["arguments"] = "system"
_LEVEL_SET_KEYS = ("H0", "n", "center")
#: the most initial states a level set may ask for
MAX_TRAJECTORIES = 10**6
_EXPRESSION_KEYS = ("H", "S", "J", "P")
#: the keys of a system in R^n written as formulas (``MetriplecticSystemN.from_expressions``, Fish form, and
#: ``GenericSystem.from_expressions``, GENERIC form, take them as they are)
_EXPRESSION_KEYS_N = ("variables", "sizes", "define", "H", "S", "P", "metric", "E", "L", "M")
_LABEL = re.compile(r"[A-Za-z][A-Za-z0-9_.-]{0,99}")


class _Checker:
    def __init__(self, source):
        self.source = source

    def fail(self, name, problem) -> NoReturn:
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
            self.fail(
                name,
                f"must be a label of letters, digits and _ . - (it names output files), starting with a "
                f"letter, at most 100 characters; got {value!r}.",
            )
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
                self.fail(
                    name,
                    f"its $...$ math does not parse ({str(exc).strip().splitlines()[-1]}); "
                    "write \\$ for a dollar sign.",
                )

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
        return {
            "H0": self.real(f"{key}.H0", value["H0"]),
            "n": int(n),
            "center": None if center is None else list(self.vector(f"{key}.center", center)),
        }

    def integrator(self, value):
        if isinstance(value, str):
            return {"name": value}
        if not isinstance(value, dict) or "name" not in value:
            self.fail(
                "integrator", f"must be a short name or a table {{ name = ..., option = ... }}; got {_describe(value)}."
            )
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
            self.fail("every", f'must be an integer >= 1 or "final"; got {_describe(value)}.')
        return int(value)

    def catalogue(self, value):
        """A system of the R^3 catalogue (``[system] name``), naming the R^n catalogue too."""
        self.string("system", value)
        if value not in CATALOGUE:
            self.fail(
                "system",
                f"unknown catalogue system {value!r}; known: {_listing(CATALOGUE)}; in R^n (`catalogue = ...`): "
                f"{_listing(RN_CATALOGUE)}.",
            )
        return value

    def rn_catalogue(self, value):
        """A system of the R^n catalogue (``[system] catalogue``)."""
        self.string("system.catalogue", value)
        if value not in RN_CATALOGUE:
            if value in CATALOGUE:
                self.fail(
                    "system.catalogue",
                    f"{value!r} is a system in R^3: name it with `name = {value!r}`, its arguments in "
                    "`parameters = { ... }`.",
                )
            self.fail(
                "system.catalogue",
                f"unknown R^n catalogue system {_short(value)}; known: {_listing(RN_CATALOGUE)}"
                f"{_validate.did_you_mean(value, RN_CATALOGUE)}",
            )
        return value

    def arguments(self, system, value):
        """The arguments of R^n catalogue system ``system``: known names (the nearest named), numbers or strings;
        the constructor checks their values."""
        if not isinstance(value, dict):
            self.fail("system", f"the arguments of {system!r} must be a table; got {_describe(value)}.")
        known = [k for k in inspect.signature(RN_CATALOGUE[system]).parameters if k != "eps"]
        out = {}
        for key, item in value.items():
            if key == "eps":
                self.fail(f"system.{key}", "set the dissipation as `effects.eps`.")
            if key not in known:
                self.fail(
                    f"system.{key}",
                    f"unknown argument of {system!r}; it takes {_listing(known) or 'none'}"
                    f"{_validate.did_you_mean(key, known)}",
                )
            if isinstance(item, str):
                out[key] = item
            elif isinstance(item, (int, np.integer)) and not isinstance(item, (bool, np.bool_)):
                self.real(f"system.{key}", item)
                out[key] = int(item)
            else:
                out[key] = self.real(f"system.{key}", item)
        return out

    def coordinate_names(self, key, value, count=None):
        """A list of coordinate names (checked against the system's variables when it is built)."""
        if isinstance(value, str) or not isinstance(value, (list, tuple)) or not value:
            self.fail(key, f"must be a non-empty list of coordinate names; got {_describe(value)}.")
        for item in value:
            self.string(key, item)
        return tuple(value)

    def times(self, key, value, duration):
        if isinstance(value, (str, dict)) or not isinstance(value, (list, tuple)) or not value:
            self.fail(key, f"must be a non-empty list of times; got {_describe(value)}.")
        times = tuple(self.real(key, v) for v in value)
        for t in times:
            if not 0.0 <= t <= duration:
                self.fail(key, f"the times must lie in the run, [0, duration = {duration:g}]; got {t:g}.")
        return times

    def limit(self, value):
        if value is None or value in ("known", "tail"):
            return value
        if isinstance(value, (list, tuple)):
            if not value:
                self.fail("output.limit", 'must name S_inf: "known", "tail", a number or one per trajectory.')
            return tuple(self.real("output.limit", v) for v in value)
        if isinstance(value, str):
            self.fail(
                "output.limit",
                f'must be "known" (the closed form), "tail" (estimated from the run), a number or one per '
                f"trajectory; got {_short(value)}{_validate.did_you_mean(value, ['known', 'tail'])}",
            )
        return self.real("output.limit", value)

    def parameters(self, system, value):
        if not isinstance(value, dict):
            self.fail("parameters", f"must be a table of parameter = value; got {_describe(value)}.")
        known = [k for k in inspect.signature(CATALOGUE[system]).parameters if k != "eps"]
        out = {}
        for key, item in value.items():
            if key == "eps":
                self.fail(f"system.parameters.{key}", "set the dissipation as `effects.eps`.")
            if key not in known:
                self.fail(
                    f"system.parameters.{key}",
                    f"unknown parameter of {system!r}; it takes {_listing(known)}{_validate.did_you_mean(key, known)}",
                )
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
            takes = (
                f"`[integrator]` takes {_listing(_LAYOUT['integrator'])} and the options of {method!r}: "
                f"{_listing(known) or 'none'}"
            )
            raise SceneError(
                source, f"integrator.{option}", _unknown(option, [*_LAYOUT["integrator"], *known], takes, listed=False)
            )
    if not isinstance(method, str):
        key = f"integrator.{next(iter(options))}"
        raise SceneError(
            source,
            key,
            "give the method's options either as keys of `[integrator]` with "
            '`method = "name"`, or inside the table `method = { name = ..., ... }`, '
            "not both.",
        )
    return {"name": method, **options}


def _listing(names):
    return ", ".join(sorted(str(n) for n in names))


def _unknown(key, known, takes, sort=True, listed=True):
    """The problem of an unknown ``key``: what the table ``takes`` (``known``, listed unless ``listed`` is
    False: ``takes`` lists them) and the nearest known key, if one is near."""
    names = [str(k) for k in known]
    listing = (_listing(names) if sort else ", ".join(names)) if listed else ""
    return f"unknown key; {takes}{' ' + listing if listing else ''}{_validate.did_you_mean(key, names)}"


def _short(text, most=60):
    """``repr(text)`` of at most ``most`` characters (a name quoted in a one-line error)."""
    return repr(text) if len(text) <= most else repr(text[:most]) + f"... ({len(text)} characters)"


def _describe(value):
    return f"{value!r} ({type(value).__name__})"
