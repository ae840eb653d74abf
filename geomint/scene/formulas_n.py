"""A system in R^n written as formulas in a scene: the keys of ``[system]``, checked before anything is built.

    [system]
    name = "pendula"
    variables = ["q[1..N]", "p[1..N]", "s"]        # a name is one coordinate; q[1..N] a family q1 ... qN
    sizes = { N = 3 }                              # integers fixed when the code is generated
    parameters = { gamma = 0.5 }                   # floats read at run time
    E = "sum(p[i]**2/2 + cos(q[i]), i) + s"
    S = "s"
    L = { "q[i], p[i]" = "1", "p[i], q[i]" = "-1" }

    [system.M]                                     # a long table of rules as a table of its own
    "p[i], p[i]" = "gamma"
    "p[i], s" = "-gamma*p[i]"
    "s, p[i]" = "-gamma*p[i]"
    "s, s" = "gamma*sum(p[i]**2, i)"

E, S, L, M make the GENERIC form (``GenericSystem.from_expressions``); H, S, P and optionally ``metric`` the
Fish form (``MetriplecticSystemN.from_expressions``, eps from ``effects.eps``).  A matrix is n lists of n
formulas or a table of rules ``"row, column" = formula`` (a row and a column are a variable or a member of a
family with an index, ``q[i]``, ``p[i+1]``, ``q[N]``); ``define`` names sub-formulas.  The keys pass to those
classmethods as they are (``parameters`` as ``params``).

What is checked here, without building anything and without evaluating any text (Python's ``ast`` reads
each formula and a walk admits only the grammar): the declarations (names, families and their bounds from
``sizes``, n), every name a formula uses (a variable, a family indexed, a size, a parameter, a definition,
``pi``, an index in scope, a function of the grammar; a misspelt one is named with the nearest known name),
every index (bound by the rule's key or by ``sum``/``prod``), the size of each matrix.  Derivatives and the
structure (L skew, ``L grad S = 0``, M symmetric, ``M grad E = 0``) are checked by the model when the system
is built; its ``ValueError`` is reported as one line naming the key.
"""

from __future__ import annotations

import ast
import inspect
import keyword
import math
import re
from dataclasses import dataclass, field
from typing import Any, NoReturn

from .. import _validate
from .checks import SceneError, _describe

#: the functions of the formula grammar (``geomint.model.expressions.FUNCTIONS``; named here so that checking a
#: scene imports no sympy, and a test keeps the two equal)
FUNCTION_NAMES = (
    "exp",
    "log",
    "sqrt",
    "abs",
    "sin",
    "cos",
    "tan",
    "sinh",
    "cosh",
    "tanh",
    "asin",
    "acos",
    "atan",
    "asinh",
    "acosh",
    "atanh",
)
#: sum(term, i), sum(term, i, first, last), prod(...), delta(i, j)
SPECIAL = ("sum", "prod", "delta")
RESERVED = set(FUNCTION_NAMES) | set(SPECIAL) | {"pi"}
#: the two forms: the keys each takes, those it needs, its matrices
FORMS = {
    "Fish": {"keys": ("H", "S", "P", "metric"), "required": ("H", "S", "P"), "matrices": ("P", "metric")},
    "GENERIC": {"keys": ("E", "S", "L", "M"), "required": ("E", "S", "L", "M"), "matrices": ("L", "M")},
}
COMMON = ("variables", "sizes", "define")
MAX_SIZE = 100_000
MAX_LENGTH = 4000
MAX_NODES = 2000
_DECLARATION = re.compile(r"\s*([A-Za-z][A-Za-z0-9_]*)\s*(?:\[(.*)\])?\s*", re.DOTALL)


@dataclass
class Declared:
    """The coordinates of a system as formulas: their names in order (a family ``q[1..N]`` names q1 ... qN),
    families ``{name: (first, last)}``, single variables, sizes, parameters and definitions."""

    names: list = field(default_factory=list)
    scalars: set = field(default_factory=set)
    families: dict = field(default_factory=dict)
    sizes: dict = field(default_factory=dict)
    parameters: tuple = ()
    defines: tuple = ()

    @property
    def n(self) -> int:
        return len(self.names)

    def known(self):
        """Every name a formula may use outside an index."""
        return [*self.scalars, *self.families, *self.sizes, *self.parameters, *self.defines, "pi"]


def form_of(expressions: dict) -> str:
    """``"GENERIC"`` when E, L or M is given, else ``"Fish"``."""
    return "GENERIC" if any(k in expressions for k in ("E", "L", "M")) else "Fish"


def check(source: str, expressions: dict, parameters: dict) -> tuple[dict, Declared]:
    """The formulas of ``[system]`` checked (see the module docstring): ``(expressions, declared)``; a
    ``SceneError`` naming the key otherwise."""
    checker = _FormulaChecker(source)
    return checker.system(expressions, parameters)


class _FormulaChecker:
    def __init__(self, source):
        self.source = source

    def fail(self, key, problem) -> NoReturn:
        raise SceneError(self.source, key, problem)

    # -- the whole system ------------------------------------------------------------------
    def system(self, expressions, parameters):
        form = form_of(expressions)
        other = "Fish" if form == "GENERIC" else "GENERIC"
        allowed = (*COMMON, *FORMS[form]["keys"])
        for key in expressions:
            if key not in allowed:
                if key in FORMS[other]["keys"]:
                    self.fail(
                        f"system.{key}",
                        f"a key of the {other} form; this system is in the {form} form (its keys: "
                        f"{', '.join(FORMS[form]['keys'])}): give E, S, L, M (GENERIC) or H, S, P and optionally "
                        "metric (Fish), not both.",
                    )
                self.fail(
                    f"system.{key}",
                    f"unknown key of a system in R^n as formulas; it takes {', '.join(allowed)}"
                    f"{_validate.did_you_mean(key, list(allowed))}",
                )
        for key in FORMS[form]["required"]:
            if key not in expressions:
                needs = ", ".join(FORMS[form]["required"])
                self.fail(f"system.{key}", f"missing; a system in R^n in the {form} form needs {needs}.")
        declared = self.declarations(expressions, parameters)
        out: dict[str, Any] = {"variables": list(expressions["variables"])}
        if expressions.get("sizes"):
            out["sizes"] = dict(declared.sizes)
        defines = expressions.get("define") or {}
        if defines:
            if not isinstance(defines, dict):
                self.fail("system.define", f"must be a table of name = formula; got {_describe(defines)}.")
            done = []
            for name, text in defines.items():
                self.new_name(f"system.define.{name}", name, declared)
                declared.defines = tuple(done)
                self.formula(f"system.define.{name}", text, declared, set())
                done.append(name)
            declared.defines = tuple(done)
            out["define"] = dict(defines)
        for key in FORMS[form]["keys"]:
            if key not in expressions:
                continue
            value = expressions[key]
            if key in FORMS[form]["matrices"]:
                out[key] = self.matrix(f"system.{key}", value, declared)
            else:
                self.formula(f"system.{key}", value, declared, set())
                out[key] = value
        return out, declared

    def declarations(self, expressions, parameters):
        declared = Declared()
        sizes = expressions.get("sizes") or {}
        if not isinstance(sizes, dict):
            self.fail("system.sizes", f"must be a table of name = integer (N = 8); got {_describe(sizes)}.")
        for name, value in sizes.items():
            self.identifier(f"system.sizes.{name}", name)
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SIZE:
                self.fail(f"system.sizes.{name}", f"must be an integer in [0, {MAX_SIZE}]; got {_describe(value)}.")
            declared.sizes[name] = int(value)
        variables = expressions.get("variables")
        if isinstance(variables, (str, bytes)) or not isinstance(variables, (list, tuple)) or not variables:
            self.fail(
                "system.variables",
                'must be a list of names, one per coordinate or family: ["q", "p", "s"] or ["q[1..N]", "p[1..N]", '
                f'"s"] with sizes = {{ N = 8 }}; got {_describe(variables)}.',
            )
        for i, text in enumerate(variables):
            key = f"system.variables[{i}]"
            if not isinstance(text, str) or len(text) > 100:
                self.fail(
                    key,
                    f"must be a name as a string (at most 100 characters), e.g. 'q' or 'q[1..N]'; got "
                    f"{_describe(text)[:120]}.",
                )
            match = _DECLARATION.fullmatch(str(text))
            if match is None:
                self.fail(key, f"{text!r} is neither a name (an identifier) nor a family 'q[N]' or 'q[1..N]'.")
            name, bracket = match.groups()
            self.new_name(key, name, declared)
            if bracket is None:
                declared.scalars.add(name)
                declared.names.append(name)
                continue
            if ".." in bracket:
                first, last = bracket.split("..", 1)
                lo, hi = self.bound(key, first, declared.sizes), self.bound(key, last, declared.sizes)
            else:
                lo, hi = 0, self.bound(key, bracket, declared.sizes) - 1
            if hi < lo:
                self.fail(key, f"the family {text!r} is empty ({name}[{lo}..{hi}]).")
            if hi - lo + 1 > MAX_SIZE:
                self.fail(key, f"the family {text!r} has {hi - lo + 1} members; at most {MAX_SIZE}.")
            declared.families[name] = (lo, hi)
            declared.names.extend(f"{name}{k}" if k >= 0 else f"{name}m{-k}" for k in range(lo, hi + 1))
        repeated = _validate.repeated(declared.names)
        if repeated:
            self.fail(
                "system.variables",
                f"the coordinate name {repeated[0][0]!r} is given twice (a family q[..] names its members q0, q1, "
                "...): rename one.",
            )
        if declared.n < 2:
            self.fail("system.variables", f"must declare at least 2 coordinates; got {declared.names}.")
        if not isinstance(parameters, dict):
            self.fail("system.parameters", f"must be a table of name = number; got {_describe(parameters)}.")
        for name, value in parameters.items():
            self.new_name(f"system.parameters.{name}", name, declared)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                self.fail(f"system.parameters.{name}", f"must be a number; got {_describe(value)}.")
            declared.parameters += (name,)
        return declared

    def identifier(self, key, name):
        if (
            not isinstance(name, str)
            or not name.isidentifier()
            or keyword.iskeyword(name)
            or name.startswith("_")
            or len(name) > 50
        ):
            self.fail(
                key,
                "must be a name (letters, digits, _; not a keyword, not starting with _, at most 50 characters); "
                f"got {_quote(str(name), 60)}.",
            )

    def new_name(self, key, name, declared):
        self.identifier(key, name)
        if name in RESERVED:
            self.fail(key, f"{name!r} is reserved (a function of the grammar, sum, prod, delta or pi); rename it.")
        taken = {
            "a variable": declared.scalars,
            "a family": declared.families,
            "a size": declared.sizes,
            "a parameter": declared.parameters,
            "a definition": declared.defines,
        }
        for what, names in taken.items():
            if name in names:
                self.fail(key, f"{name!r} is already {what}; names must be distinct.")

    def bound(self, key, text, sizes):
        """A family's bound: an integer expression of integers and sizes."""
        try:
            node = ast.parse(text.strip(), mode="eval").body
        except SyntaxError:
            self.fail(key, f"{_quote(text.strip(), 60)} is not an integer expression of sizes (N, N-1, 2*N).")
        for sub in ast.walk(node):
            if isinstance(sub, ast.Name) and sub.id not in sizes:
                self.fail(
                    key,
                    f"{_quote(sub.id, 40)} in the bound {_quote(text.strip(), 60)} is not a declared size (sizes: "
                    f"{', '.join(sizes) or 'none'}); declare it, sizes = {{ {sub.id} = 8 }}"
                    f"{_validate.did_you_mean(sub.id, sizes)}",
                )
        value = self.integer_node(key, node, text, sizes, ())
        if value is None:  # pragma: no cover - a bound of sizes alone has a value
            self.fail(key, f"{_quote(text.strip(), 60)} is not an integer expression of sizes.")
        return value

    def integer(self, key, text, sizes, indices=()):
        """An integer expression of integers, sizes and ``indices`` (+ - *), its value (None when it uses an
        index), or a failure naming ``key``."""
        try:
            node = ast.parse(text.strip(), mode="eval").body
        except SyntaxError:
            self.fail(key, f"{_quote(text.strip(), 60)} is not an integer expression of sizes (N, N-1, 2*N).")
        return self.integer_node(key, node, text, sizes, indices)

    def integer_node(self, key, node, text, sizes, indices):
        if isinstance(node, ast.Constant) and isinstance(node.value, int) and not isinstance(node.value, bool):
            if abs(node.value) > 10**9:
                self.fail(key, f"the integer {node.value} is too large.")
            return node.value
        if isinstance(node, ast.Name):
            if node.id in sizes:
                return sizes[node.id]
            if node.id in indices:
                return None
            scope = "" if not indices else f" or an index in scope ({', '.join(sorted(indices))})"
            self.fail(
                key,
                f"index {_quote(node.id, 40)} is not declared: an index is a size "
                f"({', '.join(sizes) or 'none declared'})"
                f'{scope}, bound by the rule\'s key ("p[i], s") or by sum(term, {node.id})'
                f"{_validate.did_you_mean(node.id, [*sizes, *indices])}",
            )
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            value = self.integer_node(key, node.operand, text, sizes, indices)
            return None if value is None else (-value if isinstance(node.op, ast.USub) else value)
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult)):
            left = self.integer_node(key, node.left, text, sizes, indices)
            right = self.integer_node(key, node.right, text, sizes, indices)
            if left is None or right is None:
                return None
            return {ast.Add: left + right, ast.Sub: left - right, ast.Mult: left * right}[type(node.op)]
        self.fail(key, f"{_piece(text, node)!r} is not an integer expression of sizes and indices (N, i+1, 2*N-1).")

    # -- formulas ---------------------------------------------------------------------------
    def formula(self, key, text, declared, indices):
        if not isinstance(text, str):
            self.fail(key, f"must be a formula as a string; got {_describe(text)}.")
        if len(text) > MAX_LENGTH:
            self.fail(key, f"is {len(text)} characters long; formulas are limited to {MAX_LENGTH}.")
        if not text.strip():
            self.fail(key, 'is empty; write a formula such as "p**2/2".')
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as exc:
            self.fail(key, f"is not a formula ({exc.msg}): {_quote(text)}.")
        nodes = sum(1 for _ in ast.walk(tree))
        if nodes > MAX_NODES:
            self.fail(key, f"has {nodes} syntax nodes; formulas are limited to {MAX_NODES}.")
        _Walk(self, key, text.strip(), declared).visit(tree.body, frozenset(indices))

    def matrix(self, key, value, declared):
        n = declared.n
        if isinstance(value, dict):
            if not value:
                self.fail(key, 'has no rules; give rules { "row, column" = formula } or n lists of n formulas.')
            for rule, text in value.items():
                rule_key = f'{key}["{rule}"]' if isinstance(rule, str) and len(rule) <= 60 else f"{key}[rule]"
                indices = self.rule(rule_key, rule, declared)
                self.formula(rule_key, text, declared, indices)
            return dict(value)
        shown = _shown_names(declared.names)
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            self.fail(
                key,
                f"must be n = {n} lists of {n} formulas (rows and columns in the order {shown}) or a table of rules "
                f'{{ "row, column" = formula }}; got {_describe(value)[:120]}.',
            )
        if len(value) != n:
            self.fail(key, f"must have n = {n} rows, one per coordinate ({shown}); got {len(value)} rows.")
        for i, row in enumerate(value):
            if isinstance(row, (str, bytes)) or not isinstance(row, (list, tuple)) or len(row) != n:
                got = f"{len(row)} formulas" if isinstance(row, (list, tuple)) else _describe(row)[:80]
                self.fail(f"{key}[{i}]", f"row {declared.names[i]} must have n = {n} formulas; got {got}.")
            for j, text in enumerate(row):
                self.formula(f"{key}[{i}][{j}]", text, declared, set())
        return [list(row) for row in value]

    def rule(self, key, rule, declared):
        """The indices a rule's key ``"row, column"`` binds; each part a variable or a family member."""
        if not isinstance(rule, str):
            self.fail(key, f'a rule\'s key must be a string "row, column"; got {_describe(rule)}.')
        parts = _split_top(rule)
        if len(parts) != 2:
            self.fail(key, f'a rule\'s key must be "row, column" (two coordinates); got {_quote(rule, 80)}.')
        indices = set()
        for part in parts:
            match = _DECLARATION.fullmatch(part)
            if match is None:
                self.fail(key, f"{_quote(part.strip(), 60)} is neither a variable nor a family member q[i].")
            name, bracket = match.groups()
            if bracket is None:
                if name in declared.scalars:
                    continue
                if name in declared.families:
                    self.fail(key, f"{name!r} is a family: name a member, {name}[i].")
                self.fail(key, _unknown_variable(name, declared))
            if name not in declared.families:
                if name in declared.scalars:
                    self.fail(key, f"{name!r} is a single variable, not a family: write {name} without an index.")
                self.fail(key, _unknown_variable(name, declared))
            try:
                node = ast.parse(bracket.strip(), mode="eval").body
            except SyntaxError:
                self.fail(key, f"{_quote(bracket.strip(), 60)} is not an index (i, i+1, N, 0).")
            # a name in the bracket that is no size is an index the rule binds (it runs over every value for
            # which its row and column both exist)
            for sub in ast.walk(node):
                if isinstance(sub, ast.Name) and sub.id not in declared.sizes:
                    if sub.id in RESERVED or sub.id in declared.known():
                        self.fail(key, f"{_quote(sub.id, 40)} is not an index: it names a {_kind(sub.id, declared)}.")
                    indices.add(sub.id)
            self.integer_node(key, node, bracket, declared.sizes, indices)
        return indices


class _Walk:
    """The whitelist walk of one formula's ``ast``: raises on the first node outside the grammar."""

    def __init__(self, checker: _FormulaChecker, key: str, text: str, declared: Declared) -> None:
        self.checker, self.key, self.text, self.declared = checker, key, text, declared

    def refuse(self, node, why) -> NoReturn:
        self.checker.fail(self.key, f"{why}: {_piece(self.text, node)!r}.")

    def visit(self, node, indices):
        declared = self.declared
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                self.refuse(node, "only real numbers are allowed as constants")
            if isinstance(value, int) and abs(value) > 10**15:
                self.refuse(node, "integer constant larger than 1e15")
            if isinstance(value, float) and not math.isfinite(value):
                self.refuse(node, "constant is not finite")
            return
        if isinstance(node, ast.Name):
            name = node.id
            if name in indices or name in declared.scalars or name in declared.sizes or name == "pi":
                return
            if name in declared.parameters or name in declared.defines:
                return
            if name in declared.families:
                self.refuse(node, f"{name!r} is a family: index it, {name}[i]")
            known = [*declared.known(), *indices]
            self.checker.fail(
                self.key,
                f"unknown name {_quote(name, 40)} in {_quote(self.text)} (the variables: "
                f"{_shown_names(declared.names)}; parameters, sizes and definitions are declared in [system])"
                f"{_validate.did_you_mean(name, known)}",
            )
        if isinstance(node, ast.Subscript):
            base = node.value
            if not isinstance(base, ast.Name):
                self.refuse(node, "only a family is indexed (q[i])")
            assert isinstance(base, ast.Name)  # (refuse raises)
            if base.id not in declared.families:
                if base.id in declared.scalars:
                    self.refuse(node, f"{base.id!r} is a single variable, not a family: write {base.id}")
                self.checker.fail(self.key, f"in {_quote(self.text)}: {_unknown_variable(base.id, declared)}")
            index = node.slice
            self.checker.integer_node(self.key, index, self.text, declared.sizes, indices)
            return
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return self.visit(node.operand, indices)
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, ast.BitXor):
                self.refuse(node, "`^` is not a power here (write x**2)")
            if not isinstance(node.op, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)):
                self.refuse(node, "only + - * / ** are allowed")
            self.visit(node.left, indices)
            self.visit(node.right, indices)
            if _log10_size(node) > _MAX_LOG10:
                self.refuse(node, "constant beyond 1e300")
            return
        if isinstance(node, ast.Call):
            return self.call(node, indices)
        self.refuse(node, f"{type(node).__name__.lower()} is not allowed")

    def call(self, node, indices):
        func = node.func
        if not isinstance(func, ast.Name) or func.id not in (*FUNCTION_NAMES, *SPECIAL):
            name = func.id if isinstance(func, ast.Name) else _piece(self.text, func)
            self.checker.fail(
                self.key,
                f"{_quote(str(name), 40)} in {_quote(self.text)} is not a function of the grammar "
                f"({', '.join(FUNCTION_NAMES)}, sum, prod, delta)"
                f"{_validate.did_you_mean(str(name), [*FUNCTION_NAMES, *SPECIAL])}",
            )
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            self.refuse(node, "a function takes positional arguments only")
        args = node.args
        if func.id in FUNCTION_NAMES:
            if len(args) != 1:
                self.refuse(node, f"{func.id} takes exactly one argument")
            return self.visit(args[0], indices)
        if func.id == "delta":
            if len(args) != 2:
                self.refuse(node, "delta takes two indices, delta(i, j)")
            for arg in args:
                self.checker.integer_node(self.key, arg, self.text, self.declared.sizes, indices)
            return
        if len(args) not in (2, 4) or not isinstance(args[1], ast.Name):
            self.refuse(node, f"{func.id} takes (term, index) or (term, index, first, last), the index a new name")
        index = args[1].id
        if index in RESERVED or index in self.declared.known() or index in indices:
            self.refuse(args[1], f"the index of {func.id} must be a new name; {index!r} is taken")
        for bound in args[2:]:
            self.checker.integer_node(self.key, bound, self.text, self.declared.sizes, indices)
        self.visit(args[0], indices | {index})


# -- building ------------------------------------------------------------------------------------
def available() -> bool:
    """Whether this geomint builds systems in R^n from formulas (``MetriplecticSystemN.from_expressions``
    takes ``variables``)."""
    from ..model.system_n import MetriplecticSystemN

    return "variables" in inspect.signature(MetriplecticSystemN.from_expressions).parameters


def build(source, expressions, parameters, eps, name):
    """The system: ``GenericSystem.from_expressions`` or ``MetriplecticSystemN.from_expressions`` with the keys
    as they are; the model's errors as one ``SceneError`` naming the key."""
    from ..model.system_n import GenericSystem, MetriplecticSystemN

    form = form_of(expressions)
    if not available():
        raise SceneError(
            source,
            "system.variables",
            "systems in R^n written as formulas need MetriplecticSystemN.from_expressions(variables=...) and "
            "GenericSystem.from_expressions, which this build of geomint does not have yet (the scene's formulas "
            'are valid); meanwhile name a catalogue system, catalogue = "damped_pendula".',
        )
    kwargs = {k: v for k, v in expressions.items()}
    try:
        if form == "GENERIC":
            return GenericSystem.from_expressions(**kwargs, params=dict(parameters), name=name)
        return MetriplecticSystemN.from_expressions(**kwargs, params=dict(parameters), eps=eps, name=name)
    except NotImplementedError as exc:
        raise SceneError(source, "system.variables", " ".join(str(exc).split())) from None
    except (ValueError, TypeError) as exc:
        raise SceneError(source, model_key(str(exc), expressions), " ".join(str(exc).split())) from None


def model_key(message: str, expressions: dict | None = None) -> str:
    """The scene key of a model's error: the first field it names in backticks (``L`` is not skew ...) under
    ``system.``; ``system`` if it names none."""
    for name in re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)", message):
        if name in (*COMMON, "H", "S", "P", "metric", "E", "L", "M", "grad_H", "grad_E", "grad_S"):
            return f"system.{name}"
        if name == "params":
            return "system.parameters"
    return "system"


# -- helpers ----------------------------------------------------------------------------------
_MAX_LOG10 = 300.0


def _log10_size(node) -> float:
    """log10 of the size of a constant subexpression (0 where it holds a name: its size is not constant), never
    computing the value itself: ``9**9**9**9`` is measured, not evaluated."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        value = abs(float(node.value))
        return math.log10(value) if 0.0 < value < math.inf else 0.0
    if isinstance(node, ast.UnaryOp):
        return _log10_size(node.operand)
    if isinstance(node, ast.BinOp) and _constant(node):
        left, right = _log10_size(node.left), _log10_size(node.right)
        if isinstance(node.op, ast.Pow):
            exponent = 10.0 ** min(right, 17.0)  # an exponent's own size, capped: 1e17 already overflows
            return exponent * left if left > 0 else 0.0
        if isinstance(node.op, ast.Mult):
            return left + right
        if isinstance(node.op, ast.Div):
            return left
        return max(left, right)
    return 0.0


def _constant(node) -> bool:
    return not any(isinstance(sub, (ast.Name, ast.Subscript, ast.Call)) for sub in ast.walk(node))


def _quote(text, most=200):
    """``repr(text)``, cut to ``most`` characters (a one-line error quotes it)."""
    return repr(text) if len(text) <= most else repr(text[:most]) + f"... ({len(text)} characters)"


def _piece(text, node):
    return _quote(ast.get_source_segment(text, node) or type(node).__name__, 80)[1:-1]


def _split_top(text):
    """``text`` split at the commas outside brackets."""
    parts, depth, start = [], 0, 0
    for i, c in enumerate(text):
        if c in "[(":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def _kind(name, declared):
    if name in RESERVED:
        return "function"
    for what, names in (
        ("variable", declared.scalars),
        ("family", declared.families),
        ("parameter", declared.parameters),
        ("definition", declared.defines),
    ):
        if name in names:
            return what
    return "constant"


def _unknown_variable(name, declared):
    known = [*declared.scalars, *declared.families]
    return (
        f"unknown variable {_quote(name, 40)}; the variables are {_shown_names(declared.names)}"
        f"{_validate.did_you_mean(name, known)}"
    )


def _shown_names(names, most=8):
    """``q1, q2, ..., s`` (at most ``most`` names, the count when more)."""
    names = list(names)
    if len(names) <= most:
        return ", ".join(names)
    return ", ".join(names[: most - 2]) + f", ..., {names[-1]} ({len(names)})"
