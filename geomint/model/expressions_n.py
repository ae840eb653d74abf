"""Systems in R^n written as formulas: named variables, indexed families, sums, and matrices given by rules.

    variables = ("q[1..N]", "p[1..N]", "s"),   sizes = {"N": 128},
    E = "sum(p[i]**2/2 + cos(q[i]), i) + s",   S = "s",
    L = {"q[i], p[i]": "1", "p[i], q[i]": "-1"},
    M = {"p[i], p[i]": "gamma", "p[i], s": "-gamma*p[i]", "s, p[i]": "-gamma*p[i]", "s, s": "gamma*sum(p[i]**2, i)"}

is the GENERIC form of N damped pendula sharing one entropy (``geomint.systems.damped_pendula``).  Text
becomes a system as in R^3 (``geomint.model.expressions``), each step refusing what it cannot vouch for:

1. **Declarations.**  ``variables`` lists the coordinates in order: a name (``"s"``) is one coordinate,
   ``"q[N]"`` a family ``q[0] ... q[N-1]`` and ``"q[a..b]"`` a family ``q[a] ... q[b]`` (bounds inclusive,
   integers or expressions of ``sizes``: ``"q[1..N]"``, ``"r[0..2*N-1]"``).  The system's coordinates are
   named ``q1 ... qN`` (``system.variables``).  ``sizes`` are integers fixed when the code is generated;
   ``params`` are floats read at run time (``p[i]``: one compilation serves every value); ``define``
   names sub-formulas (``{"T": "T0*exp(s/c)"}``), each usable in later definitions and every field.
2. **Parse** with the R^3 whitelist (Python's ``ast``, a walk that admits numbers, names, ``+ - * / **``,
   unary minus and the functions of ``expressions.FUNCTIONS``; the text is never evaluated) and:

   - ``q[i]``, ``q[i+1]``, ``q[N]``, ``q[0]``: a member of a family; the index is an integer, a size,
     or an index in scope plus a constant;
   - ``sum(term, i)`` and ``prod(term, i)``: over the range of the family members ``term`` indexes with
     ``i`` (all of them must give the same range); ``sum(term, i, first, last)`` over an explicit range,
     bounds inclusive (``sum(cos(q[i+1] - q[i]), i, 1, N-1)``);
   - ``delta(i, j)``: 1 where the indices are equal, else 0; an index in scope is also a number
     (``sum(i*q[i]**2, i)``).

3. **Matrices** (``P``, ``metric``, ``L``, ``M``) are either n lists of n formulas, or a dict of rules
   ``{"row, column": formula}``: a row and a column are variables (``"s"``, ``"q[3]"``) or members of a
   family with indices (``"q[i]"``, ``"p[i+1]"``, ``"p[j]"``); each index of a key runs over every value
   for which its row and column both exist, and the formula may use it.  Rules add up where they
   overlap; every other entry is 0.  A rule with ``delta(i, j)`` in its formula is reduced to ``j = i``
   (``"p[i], p[j]": "gamma*delta(i, j)"`` is the diagonal ``"p[i], p[i]": "gamma"``).
4. **Differentiate** with sympy over the indexed forms: ``d/dq[k] sum(f(q[i]), i)`` is ``f'(q[k])`` for k
   in the sum's range, found by resolving the Kronecker delta of ``q[i]`` against ``q[k]``, not by
   unrolling the sum.  The gradient is a set of rules (a loop over k per family), exact.
5. **Check the structure** symbolically on the entries the rules give (sparse: only the nonzeros):
   P (L) skew, ``P grad S = 0`` (``L grad S = 0``), a metric (M) symmetric and annihilating ``grad H``
   (``grad E``).  A residual sympy cannot reduce to 0 is evaluated at the sample points; a failure names
   the field, the entry, the rule and the residual (`` `L` is not skew: L[q1, p1] + L[p1, q1] = 2 ``).
   Semidefiniteness is the constructor's numeric check.  Beyond ``MAX_CHECKED_TERMS`` the symbolic
   checks are skipped and the constructor's numeric ones (at the samples) remain.
6. **Generate** one numba module: ``H``, ``grad_H``, ``S``, ``grad_S``, ``P`` and ``M`` (the metric) as
   functions of ``(x, params)``; a family is a loop, not N unrolled statements, a matrix is filled at the
   entries its rules give, a sum inside a formula is a loop whose result is computed once, outside every
   loop it does not depend on.  The source is checked (only the names and calls the generator writes)
   and written to ``<cache>/expressions/geomint_expr_<hash>.py`` with ``numba.njit(cache=True)``.
   An index ``<cache>/expressions/geomint_exprn_<hash of the formulas, sizes and parameter names>.json``
   points at it, so a second process with the same formulas skips sympy too and loads machine code.

``MetriplecticSystemN.from_expressions`` and ``GenericSystem.from_expressions`` are the public entries
(``MetriplecticSystem.from_expressions(..., variables=...)`` reaches the first).  Step 1 is
``expressions_variables``, steps 2 to 6 ``expressions_symbolic`` (the only half that imports sympy); this
module keeps the index of the disk cache and builds the systems.

Example
-------
>>> import geomint
>>> pendula = geomint.GenericSystem.from_expressions(
...     variables=("q[1..N]", "p[1..N]", "s"), sizes={"N": 3},
...     E="sum(p[i]**2/2 + cos(q[i]), i) + s", S="s",
...     L={"q[i], p[i]": "1", "p[i], q[i]": "-1"},
...     M={"p[i], p[i]": "gamma", "p[i], s": "-gamma*p[i]", "s, p[i]": "-gamma*p[i]",
...        "s, s": "gamma*sum(p[i]**2, i)"},
...     params={"gamma": 0.5})
>>> pendula.variables
('q1', 'q2', 'q3', 'p1', 'p2', 'p3', 's')
>>> pendula.xi([0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0]).tolist()
[1.0, 2.0, 0.0, -0.5, -1.0, 0.0, 2.5]
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from typing import TYPE_CHECKING, Any

from . import expressions_cache
from .expressions_variables import Coordinates, check_name

if TYPE_CHECKING:
    from collections.abc import Mapping
    from types import ModuleType


# -- 1. the disk cache of whole systems ------------------------------------------------------
def _index_path(key):
    return expressions_cache.cache_directory() / f"geomint_exprn_{key}.json"


def _cached_module(key: str, values: Mapping[str, float]) -> ModuleType | None:
    """The module an earlier process generated for the same formulas (its index file), or None."""
    try:
        record = json.loads(_index_path(key).read_text(encoding="utf-8"))
        name = record["module"]
        path = expressions_cache.cache_directory() / f"{name}.py"
        text = path.read_text(encoding="utf-8")
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if name != "geomint_expr_" + hashlib.sha256(text.encode()).hexdigest()[:20]:
        return None  # a file that is not what the generator wrote
    held_at = record.get("held_at")
    if held_at is not None and held_at != dict(values):
        return None  # the checks held only at other parameter values: check again
    return expressions_cache.compile_functions(text)


def _remember(key, module, held_at):
    path = _index_path(key)
    partial = path.with_suffix(f".{os.getpid()}.tmp")
    partial.write_text(json.dumps({"module": module.__name__, "held_at": held_at}), encoding="utf-8")
    partial.replace(path)


# -- 2. the builders -------------------------------------------------------------------------------
GENERATOR_VERSION = "n1"
#: the fields of each form: (energy, Poisson matrix, metric) as the user names them
FORMS = {"Fish": ("H", "P", "metric"), "GENERIC": ("E", "L", "M")}


def build(
    form: str,
    *,
    variables: Any,
    energy: str,
    S: str,
    poisson: Any,
    metric: Any = None,
    params: Mapping[str, float] | None = None,
    sizes: Mapping[str, int] | None = None,
    define: Mapping[str, str] | None = None,
    samples: Any = None,
    check: bool = True,
) -> dict[str, Any]:
    """The generated functions and what the constructor of ``form`` (``"Fish"`` or ``"GENERIC"``) needs
    (``check=False``: without the symbolic structure checks).

    Returns ``{"H", "grad_H", "S", "grad_S", "P", "M" (None without a metric), "params" (list), "dim",
    "variables", "checks"}``: ``checks`` is ``"symbolic"``, ``"numeric"`` (symbolic checks skipped beyond
    ``MAX_CHECKED_TERMS``: the constructor's at the samples remain), ``"skipped"`` (``check=False``) or
    ``"cached"`` (generated and checked by an earlier call with the same formulas), and ``"remember"``: call it
    once the constructor's own checks have passed, to record the module in the index (a system the constructor
    refuses is never found there).
    """
    E_name, P_name, M_name = FORMS[form]
    if form == "GENERIC" and metric is None:
        raise ValueError("`M` (the friction matrix: symmetric, positive semidefinite, M grad E = 0) is required.")
    coords = Coordinates(variables, sizes)
    taken = {name: "a variable" for name in list(coords.scalars) + list(coords.families)}
    taken.update({name: "a size" for name in coords.sizes})
    if params is not None and not isinstance(params, dict):
        raise ValueError(f"`params` must be a dict {{name: value}}; got {params!r} ({type(params).__name__}).")
    values = {}
    for name, value in (params or {}).items():
        check_name("params", name, taken)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"`params.{name}` must be a finite real number; got {value!r}.")
        values[name] = float(value)
    fields = {E_name: energy, "S": S, P_name: poisson, M_name: metric}
    key = _key(form, coords, values, sizes, define, {**fields, "checked": bool(check)})
    out = {"params": list(values.values()), "dim": coords.n, "variables": tuple(coords.names)}
    module = _cached_module(key, values)
    if module is not None:
        return {**_functions(module), **out, "checks": "cached", "remember": lambda: None}

    from . import expressions_symbolic  # sympy: only for formulas not generated before

    text, checks, used_values = expressions_symbolic.generate(
        FORMS[form], coords, values, define, energy, S, poisson, metric, samples, check
    )
    module = expressions_cache.compile_functions(text)
    held_at = dict(values) if used_values else None  # values-dependent: a hit with other values checks anew
    return {**_functions(module), **out, "checks": checks, "remember": lambda: _remember(key, module, held_at)}


def _functions(module):
    return {
        "H": module.H,
        "grad_H": module.grad_H,
        "S": module.S,
        "grad_S": module.grad_S,
        "P": module.P,
        "M": getattr(module, "M", None),
    }


@functools.cache
def _generator_digest():
    """A digest of the generator's sources and sympy's version: generated code is not reused across versions."""
    from importlib import metadata
    from pathlib import Path

    digest = hashlib.sha256(GENERATOR_VERSION.encode())
    for name in ("expressions.py", "expressions_n.py", "expressions_symbolic.py", "expressions_variables.py"):
        digest.update((Path(__file__).with_name(name)).read_bytes())
    try:
        digest.update(metadata.version("sympy").encode())
    except metadata.PackageNotFoundError:  # pragma: no cover - sympy is a dependency
        pass
    return digest.hexdigest()


def _key(form, coords, values, sizes, define, fields):
    """The disk cache's key: the generator (its sources), the form, the declarations, the parameter names and
    every formula."""
    data = {
        "generator": _generator_digest(),
        "form": form,
        "variables": [f.shown for f in coords.families.values()] + list(coords.scalars),
        "order": coords.names,
        "sizes": sizes or {},
        "params": list(values),
        "define": list(define.items()) if isinstance(define, dict) else define,
        "fields": fields,
    }
    try:
        text = json.dumps(data, sort_keys=True)
    except (TypeError, ValueError):
        text = repr(data)  # an unusual field (a tuple of tuples is fine; anything else fails in the parser anyway)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def record(form: str, **fields: Any) -> dict[str, Any]:
    """The formulas as plain data for saved results (``system.expressions``)."""
    out: dict[str, Any] = {"form": form}
    for name, value in fields.items():
        if value is None:
            continue
        if isinstance(value, dict):
            value = dict(value)
        elif isinstance(value, (list, tuple)) and name != "variables":
            value = [list(row) if isinstance(row, (list, tuple)) else row for row in value]
        elif isinstance(value, tuple):
            value = list(value)
        out[name] = value
    return out


def fish_system(
    cls: Any,
    *,
    variables: Any,
    H: str,
    S: str,
    P: Any,
    params: Mapping[str, float] | None = None,
    eps: float = 1.0,
    metric: Any = None,
    sizes: Mapping[str, int] | None = None,
    define: Mapping[str, str] | None = None,
    name: str = "expressions",
    samples: Any = None,
    check: bool = True,
) -> Any:
    """``cls(...)`` (a ``MetriplecticSystemN``) from formulas; see ``MetriplecticSystemN.from_expressions``."""
    built = build(
        "Fish",
        variables=variables,
        energy=H,
        S=S,
        poisson=P,
        metric=metric,
        params=params,
        sizes=sizes,
        define=define,
        samples=samples,
        check=check,
    )
    system = cls(
        H=built["H"],
        grad_H=built["grad_H"],
        S=built["S"],
        grad_S=built["grad_S"],
        P=built["P"],
        metric=built["M"],
        eps=eps,
        params=built["params"],
        dim=built["dim"],
        name=name,
        samples=samples,
        check=check,
        variables=built["variables"],
    )
    system.expressions = record(
        "Fish", variables=variables, sizes=sizes, define=define, H=H, S=S, P=P, metric=metric, params=params or {}
    )
    system.expression_checks = built["checks"]
    built["remember"]()
    return system


def generic_system(
    cls: Any,
    *,
    variables: Any,
    E: str,
    S: str,
    L: Any,
    M: Any,
    params: Mapping[str, float] | None = None,
    sizes: Mapping[str, int] | None = None,
    define: Mapping[str, str] | None = None,
    name: str = "expressions",
    samples: Any = None,
    check: bool = True,
) -> Any:
    """``cls(...)`` (a ``GenericSystem``) from formulas; see ``GenericSystem.from_expressions``."""
    built = build(
        "GENERIC",
        variables=variables,
        energy=E,
        S=S,
        poisson=L,
        metric=M,
        params=params,
        sizes=sizes,
        define=define,
        samples=samples,
        check=check,
    )
    system = cls(
        E=built["H"],
        grad_E=built["grad_H"],
        S=built["S"],
        grad_S=built["grad_S"],
        L=built["P"],
        M=built["M"],
        params=built["params"],
        dim=built["dim"],
        name=name,
        samples=samples,
        check=check,
        variables=built["variables"],
    )
    system.expressions = record(
        "GENERIC", variables=variables, sizes=sizes, define=define, E=E, S=S, L=L, M=M, params=params or {}
    )
    system.expression_checks = built["checks"]
    built["remember"]()
    return system
