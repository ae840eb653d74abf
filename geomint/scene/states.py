"""Initial states of a scene in R^n: by name, as vectors, or drawn from a distribution with a seed.

    [initial]
    state = { q = 1.5, p = 0.0, S1 = 0.0, S2 = 0.5 }     # one state by name (or a list of such tables)
    points = [[1.5, 0.0, 0.0, 0.5]]                      # or vectors in the order of system.variables
    random = { n = 16, seed = 1, ranges = { q = [0.5, 1.5], p = 0.0, S1 = [0, 1], S2 = 0.0 } }
    random = { n = 16, seed = 1, around = { q = 1.0, p = 0.0, S1 = 0.0, S2 = 0.0 }, std = 0.1 }
    fill = 0.0                                           # the coordinates a table does not name

A name is a coordinate (``system.variables``) or a family: the coordinates named by it and a number
(``q`` for ``q1 ... qN``, ``S`` for ``S1, S2``; a family of a system as formulas, ``q[1..N]``), given one
number (every member) or a list (one per member, in order).  Without ``fill`` every coordinate must be
given.  ``ranges`` draws each coordinate uniformly in ``[low, high]`` (a number fixes it); ``around`` and
``std`` draw a Gaussian around a state (``std`` a number, a table by name, unnamed coordinates 0, or a
vector); both with ``numpy.random.default_rng(seed)``, so a scene draws the same states every time.
"""

from __future__ import annotations

import re
from typing import Any, NoReturn

import numpy as np

from .. import _validate
from .checks import MAX_TRAJECTORIES, SceneError, _describe, _short

RANDOM_KEYS = ("n", "seed", "ranges", "around", "std")
_MEMBER = re.compile(r"([A-Za-z_]+)(m?\d+)")


def families(variables) -> dict[str, list[int]]:
    """``{family: positions}``: the coordinates named by a prefix of letters and a number (``q1 ... q8``,
    ``S1, S2``, ``qm1`` for a negative index), in order; a name that is a coordinate itself is not a family."""
    out: dict[str, list[int]] = {}
    for i, name in enumerate(variables):
        match = _MEMBER.fullmatch(name)
        if match and match.group(1) not in variables:
            out.setdefault(match.group(1), []).append(i)
    return out


def shown(variables, most=10) -> str:
    """The coordinates, short: ``q1 ... q8, p1 ... p8, s`` (families compressed) or the first ones and the
    count."""
    groups, seen = [], set()
    fam = families(variables)
    member_of = {i: f for f, positions in fam.items() for i in positions}
    for i, name in enumerate(variables):
        f = member_of.get(i)
        if f is None:
            groups.append(name)
        elif f not in seen:
            seen.add(f)
            members = [variables[j] for j in fam[f]]
            groups.append(members[0] if len(members) == 1 else f"{members[0]} ... {members[-1]}")
    if len(groups) > most:
        return ", ".join(groups[: most - 1]) + f", ..., {groups[-1]} ({len(variables)} coordinates)"
    return ", ".join(groups)


class _States:
    def __init__(self, source, variables):
        self.source, self.variables = source, tuple(variables)
        self.n = len(self.variables)
        self.index = {name: i for i, name in enumerate(self.variables)}
        self.families = families(self.variables)

    def fail(self, key, problem) -> NoReturn:
        raise SceneError(self.source, key, problem)

    def number(self, key, value):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            self.fail(key, f"must be a number; got {_describe(value)}.")
        value = float(value)
        if not np.isfinite(value):
            self.fail(key, f"must be finite; got {value!r}.")
        return value

    def positions(self, key, name):
        """The coordinates ``name`` names (one, or a family's) and whether it is a family, or a failure naming
        the nearest name."""
        if name in self.index:
            return [self.index[name]], False
        if name in self.families:
            return self.families[name], True
        known = [*self.variables, *self.families]
        self.fail(
            f"{key}.{name}",
            f"unknown coordinate {_short(name)}; the system's coordinates are {shown(self.variables)}"
            + (f" (families {', '.join(self.families)})" if self.families else "")
            + _validate.did_you_mean(name, known),
        )

    def table(self, key, value, fill, what="numbers", each=None, listed=None):
        """A vector from a table by name; ``each(key, value)`` reads one value (default a number), ``listed(value)``
        says whether a family's value is one per member (default: a list); the coordinates not named are
        ``fill`` (all must be named when it is None)."""
        each = self.number if each is None else each
        listed = (lambda item: isinstance(item, (list, tuple))) if listed is None else listed
        if not isinstance(value, dict):
            self.fail(key, f"must be a table of coordinate = {what}; got {_describe(value)}.")
        out: list[Any] = [None] * self.n
        for name, item in value.items():
            positions, family = self.positions(key, name)
            if family and listed(item):
                if len(item) != len(positions):
                    self.fail(
                        f"{key}.{name}",
                        f"the family {name} has {len(positions)} coordinates "
                        f"({', '.join(self.variables[i] for i in positions)}); got a list of {len(item)}.",
                    )
                values = [each(f"{key}.{name}[{j}]", v) for j, v in enumerate(item)]
            else:
                values = [each(f"{key}.{name}", item)] * len(positions)
            for i, v in zip(positions, values):
                if out[i] is not None:
                    self.fail(f"{key}.{name}", f"coordinate {self.variables[i]} is given twice.")
                out[i] = v
        missing = [self.variables[i] for i in range(self.n) if out[i] is None]
        if missing:
            if fill is None:
                listed_names = ", ".join(missing[:8]) + (f", ... ({len(missing)})" if len(missing) > 8 else "")
                self.fail(
                    key,
                    f"coordinates not given: {listed_names}; give every coordinate of {shown(self.variables)}, or "
                    "`initial.fill = 0.0` for the rest.",
                )
            out = [fill if v is None else v for v in out]
        return out

    def vector(self, key, value):
        if isinstance(value, (str, dict)) or not isinstance(value, (list, tuple)):
            self.fail(key, f"must be a list of n = {self.n} numbers ({shown(self.variables)}); got {_describe(value)}.")
        if len(value) != self.n:
            self.fail(
                key,
                f"a state of the wrong length: the system has n = {self.n} coordinates ({shown(self.variables)}); "
                f"got {len(value)} numbers.",
            )
        return [self.number(f"{key}[{i}]", v) for i, v in enumerate(value)]


def static_check(source, points, state, random, level_set, fill):
    """What can be checked of an R^n scene's initial states without the system: exactly one form given, the
    count of states and the distribution's keys and types.  Returns the number of states."""

    def fail(key, problem):
        raise SceneError(source, key, problem)

    given = [k for k, v in (("points", points), ("state", state), ("random", random)) if v is not None]
    if level_set is not None:
        fail(
            "initial.level_set",
            "samples a level surface in R^3; in R^n give `points`, `state` (by name) or `random` (a distribution).",
        )
    if len(given) != 1:
        fail("initial", "give exactly one of `points` (vectors), `state` (by name) and `random` (a distribution).")
    if fill is not None and (isinstance(fill, bool) or not isinstance(fill, (int, float)) or not np.isfinite(fill)):
        fail("initial.fill", f"must be a finite number; got {_describe(fill)}.")
    if points is not None:
        if isinstance(points, (str, dict)) or not isinstance(points, (list, tuple)) or not points:
            fail("initial.points", f"must be a non-empty list of states (lists of numbers); got {_describe(points)}.")
        return len(points)
    if state is not None:
        tables = [state] if isinstance(state, dict) else state
        if not isinstance(tables, (list, tuple)) or not tables or not all(isinstance(t, dict) for t in tables):
            fail("initial.state", f"must be a table {{ q = 1.5, p = 0.0 }} or a list of them; got {_describe(state)}.")
        return len(tables)
    if not isinstance(random, dict):
        fail("initial.random", f"must be a table {{ n = 8, seed = 1, ranges = {{...}} }}; got {_describe(random)}.")
    for key in random:
        if key not in RANDOM_KEYS:
            fail(
                f"initial.random.{key}",
                f"unknown key; `random` takes {', '.join(RANDOM_KEYS)}{_validate.did_you_mean(key, RANDOM_KEYS)}",
            )
    n = random.get("n")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_TRAJECTORIES:
        fail(
            "initial.random.n",
            f"must be an integer in [1, {MAX_TRAJECTORIES}] (the number of states); got {_describe(n)}.",
        )
    seed = random.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        fail("initial.random.seed", f"must be an integer >= 0; got {_describe(seed)}.")
    if ("ranges" in random) == ("around" in random):
        fail(
            "initial.random",
            "give exactly one of `ranges` (uniform, { q = [low, high], ... }) and `around` (a Gaussian around a "
            "state, with `std`).",
        )
    if "std" in random and "around" not in random:
        fail("initial.random.std", "goes with `around` (a Gaussian around a state); `ranges` draws uniformly.")
    if "around" in random and "std" not in random:
        fail("initial.random.std", "missing; a Gaussian around a state needs `std` (a number, or a table by name).")
    return n


def resolve(source, variables, points, state, random, fill) -> np.ndarray:
    """The initial states ``(m, n)`` of an R^n scene for a system with these ``variables``."""
    states = _States(source, variables)
    if points is not None:
        return np.array([states.vector(f"initial.points[{i}]", p) for i, p in enumerate(points)], dtype=np.float64)
    if state is not None:
        if isinstance(state, dict):
            return np.array([states.table("initial.state", state, fill)], dtype=np.float64)
        return np.array([states.table(f"initial.state[{i}]", t, fill) for i, t in enumerate(state)], dtype=np.float64)
    rng = np.random.default_rng(random.get("seed", 0))
    m = random["n"]
    if "ranges" in random:
        bounds = np.array(
            states.table(
                "initial.random.ranges",
                random["ranges"],
                None if fill is None else (float(fill), float(fill)),
                "[low, high] or a number",
                _range(states),
                lambda item: isinstance(item, (list, tuple)) and all(isinstance(v, (list, tuple)) for v in item),
            )
        )
        low, high = bounds[:, 0], bounds[:, 1]
        return low + (high - low) * rng.random((m, states.n))
    around = random["around"]
    key = "initial.random.around"
    mean = np.array(
        states.vector(key, around) if isinstance(around, (list, tuple)) else states.table(key, around, fill)
    )
    std = random["std"]
    key = "initial.random.std"
    if isinstance(std, dict):
        spread = np.array(states.table(key, std, 0.0, "standard deviations", _deviation(states)))
    elif isinstance(std, (list, tuple)):
        spread = np.array([_deviation(states)(f"{key}[{i}]", v) for i, v in enumerate(states.vector(key, std))])
    else:
        spread = np.full(states.n, _deviation(states)(key, std))
    return mean + spread * rng.standard_normal((m, states.n))


def _range(states):
    def each(key, value):
        if isinstance(value, (list, tuple)):
            if len(value) != 2:
                states.fail(key, f"must be [low, high] or a number (fixed); got {_describe(value)}.")
            low, high = states.number(key, value[0]), states.number(key, value[1])
            if high < low:
                states.fail(key, f"must be [low, high] with low <= high; got {list(value)}.")
            return low, high
        value = states.number(key, value)
        return value, value

    return each


def _deviation(states):
    def each(key, value):
        value = states.number(key, value)
        if value < 0:
            states.fail(key, f"a standard deviation must be >= 0; got {value!r}.")
        return value

    return each


def check_names(source, key, names, variables) -> None:
    """Each of ``names`` a coordinate of ``variables`` or a family of them (``q`` for q1 ... qN), or a
    ``SceneError`` naming ``key`` and the nearest name."""
    fams = families(variables)
    for name in names:
        if name not in variables and name not in fams:
            raise SceneError(
                source,
                key,
                f"unknown coordinate {_short(name)}; the system's coordinates are {shown(variables)}"
                + (f" (families {', '.join(fams)})" if fams else "")
                + _validate.did_you_mean(name, [*variables, *fams]),
            )


def expand(names, variables) -> list[str]:
    """Coordinate names with each family name replaced by its members (``q`` -> q1 ... qN), in order."""
    fams = families(variables)
    out: list[str] = []
    for name in names:
        if name in fams and name not in variables:
            out.extend(variables[i] for i in fams[name])
        else:
            out.append(name)
    return out


def default_series(variables) -> tuple[str, ...]:
    """The coordinates a time series draws by default: the first family's members (at most 8), else the first
    six coordinates."""
    for members in families(variables).values():
        if len(members) > 1:
            return tuple(variables[i] for i in members[:8])
    return tuple(variables[:6])


def default_phase(variables) -> tuple[str, ...]:
    """The coordinates a projection draws by default: the first members of the first two families (q1, p1),
    else the first two coordinates."""
    fams = [m for m in families(variables).values() if len(m) > 1]
    if len(fams) >= 2:
        return (variables[fams[0][0]], variables[fams[1][0]])
    return tuple(variables[:2])
