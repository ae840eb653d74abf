"""The variables of a system in R^n written as formulas: single names and indexed families, and sizes.

``Coordinates(("q[1..N]", "p[1..N]", "s"), {"N": 128})`` orders the coordinates (q1 ... q128, p1 ... p128, s),
places each at its index in the state and names it.  No sympy is imported unless a symbol is asked for: a
system found in the disk cache is built without it (``expressions_n``).

>>> c = Coordinates(("q[1..N]", "p[N]", "s"), {"N": 2})
>>> c.names, c.n, c.families["p"].position(1)
(['q1', 'q2', 'p0', 'p1', 's'], 5, 3)
"""

from __future__ import annotations

import ast
import functools
import keyword
import re
from dataclasses import dataclass
from typing import Any

from .. import _validate

#: a size beyond this is refused (the kernels hold dense (n, n) matrices)
MAX_SIZE = 100_000
#: the functions of the grammar (``expressions.FUNCTIONS``, named here so that a cached system imports no sympy)
FUNCTION_NAMES = (
    "exp", "log", "sqrt", "abs", "sin", "cos", "tan", "sinh", "cosh", "tanh",
    "asin", "acos", "atan", "asinh", "acosh", "atanh",
)  # fmt: skip
SPECIAL = ("sum", "prod", "delta")
RESERVED = set(FUNCTION_NAMES) | {"pi"} | set(SPECIAL)
_NAME = re.compile(r"\s*([A-Za-z][A-Za-z0-9_]*)\s*(?:\[(.*)\])?\s*", re.DOTALL)


# -- 1. declarations ----------------------------------------------------------------------
@dataclass(frozen=True)
class Family:
    """A family of variables ``name[lo] ... name[hi]``, stored at ``x[offset] ... x[offset + hi - lo]``."""

    name: str
    lo: int
    hi: int
    offset: int

    @functools.cached_property
    def base(self) -> Any:
        """The sympy ``IndexedBase`` of the family (real members)."""
        import sympy

        return sympy.IndexedBase(self.name, real=True)

    def position(self, index):
        """The coordinate of ``name[index]`` (an integer, or a sympy expression of loop indices)."""
        return self.offset + index - self.lo

    def label(self, k: int) -> str:
        return f"{self.name}{k}" if k >= 0 else f"{self.name}m{-k}"

    @property
    def shown(self) -> str:
        return f"{self.name}[{self.lo}..{self.hi}]"


@dataclass(frozen=True)
class Scalar:
    """A single variable, stored at ``x[offset]``."""

    name: str
    offset: int

    @functools.cached_property
    def symbol(self) -> Any:
        import sympy

        return sympy.Symbol(self.name, real=True)


class Coordinates:
    """The declared variables and sizes: the coordinates' order, names and positions."""

    def __init__(self, variables: Any, sizes: Any) -> None:
        self.sizes = _check_sizes(sizes)
        if isinstance(variables, (str, bytes)) or not isinstance(variables, (list, tuple)) or not variables:
            raise ValueError(
                '`variables` must be a list of names, one per coordinate or family: ("q", "p", "s") or '
                f'("q[1..N]", "p[1..N]", "s") with sizes={{"N": 128}}; got {variables!r}.'
            )
        self.scalars: dict[str, Scalar] = {}
        self.families: dict[str, Family] = {}
        self.names: list[str] = []
        for text in variables:
            if not isinstance(text, str):
                raise ValueError(f"`variables`: {text!r} is not a name; write names as strings, e.g. 'q' or 'q[1..N]'.")
            if len(text) > 100:
                raise ValueError(f"`variables`: {text[:40]!r}... is {len(text)} characters long; at most 100.")
            match = _NAME.fullmatch(text)
            if match is None:
                raise ValueError(
                    f"`variables`: {text!r} is neither a name (an identifier) nor a family 'q[N]' or 'q[1..N]'."
                )
            name, bracket = match.groups()
            self._check_new(name, text)
            if bracket is None:
                self.scalars[name] = Scalar(name, len(self.names))
                self.names.append(name)
                continue
            if ".." in bracket:
                first, last = bracket.split("..", 1)
                lo, hi = self.integer(f"variables {text!r}", first), self.integer(f"variables {text!r}", last)
            else:
                lo, hi = 0, self.integer(f"variables {text!r}", bracket) - 1
            if hi < lo:
                raise ValueError(f"`variables`: the family {text!r} is empty ({name}[{lo}..{hi}]).")
            if hi - lo + 1 > MAX_SIZE:
                raise ValueError(f"`variables`: the family {text!r} has {hi - lo + 1} members; at most {MAX_SIZE}.")
            family = Family(name, lo, hi, len(self.names))
            self.families[name] = family
            self.names.extend(family.label(k) for k in range(lo, hi + 1))
        repeated = _validate.repeated(self.names)
        if repeated:
            raise ValueError(
                f"`variables`: the coordinate name {repeated[0][0]!r} is given twice (a family q[..] names its members "
                "q0, q1, ...: rename the single variable)."
            )
        self.n = len(self.names)
        if self.n < 2:
            raise ValueError(f"`variables` must declare at least 2 coordinates; got {self.names}.")

    @functools.cached_property
    def symbols(self) -> list:
        """A sympy symbol per coordinate, named as ``names`` (the entries the checks materialize)."""
        import sympy

        return [sympy.Symbol(name, real=True) for name in self.names]

    def _check_new(self, name, text):
        if len(name) > 50:
            raise ValueError(f"`variables`: the name {name[:20]!r}... is longer than 50 characters.")
        if keyword.iskeyword(name) or name in RESERVED or name in self.sizes or name.startswith("_"):
            raise ValueError(
                f"`variables`: {text!r}: the name {name!r} is reserved (a keyword, function, size or starting with "
                "`_`); rename it."
            )
        if name in self.scalars or name in self.families:
            raise ValueError(f"`variables`: {name!r} is declared twice.")

    def integer(self, what: str, text: str) -> int:
        """An integer expression of integers and sizes (``N``, ``2*N - 1``), or a ValueError naming ``what``."""
        try:
            tree = ast.parse(text.strip(), mode="eval").body
        except SyntaxError:
            raise ValueError(
                f"`{what}`: {text.strip()!r} is not an integer expression of sizes (N, N-1, 2*N)."
            ) from None
        value = _integer_value(tree, self.sizes)
        if value is None:
            raise ValueError(
                f"`{what}`: {text.strip()!r} is not an integer expression of sizes (N, N-1, 2*N); sizes: "
                f"{listed(self.sizes)}."
            )
        return value

    @property
    def shown(self) -> str:
        parts = [f.shown for f in self.families.values()] + list(self.scalars)
        return ", ".join(parts)

    def reference(self, name, index=None):
        """The sympy object of ``name`` (a scalar) or ``name[index]`` (a member of a family)."""
        return self.scalars[name].symbol if index is None else self.families[name].base[index]

    def position(self, ref):
        """The coordinate of a reference (a scalar's symbol or an ``Indexed``): an int or a loop-index expression."""
        if hasattr(ref, "indices"):  # a sympy Indexed
            return self.families[ref.base.name].position(ref.indices[0])
        return self.scalars[ref.name].offset

    def concrete(self):
        """``{sympy reference: coordinate symbol}`` for every coordinate (``q[3] -> q3``)."""
        out = {}
        for scalar in self.scalars.values():
            out[scalar.symbol] = self.symbols[scalar.offset]
        for family in self.families.values():
            for k in range(family.lo, family.hi + 1):
                out[family.base[k]] = self.symbols[family.position(k)]
        return out


def _integer_value(node, sizes):
    """The value of an integer expression of ints and ``sizes`` (``+ - *``, unary -), or None."""
    if isinstance(node, ast.Constant) and isinstance(node.value, int) and not isinstance(node.value, bool):
        return node.value if abs(node.value) <= 10**9 else None
    if isinstance(node, ast.Name):
        return sizes.get(node.id)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        value = _integer_value(node.operand, sizes)
        return None if value is None else -value
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult)):
        left, right = _integer_value(node.left, sizes), _integer_value(node.right, sizes)
        if left is None or right is None:
            return None
        value = (
            left + right
            if isinstance(node.op, ast.Add)
            else left - right
            if isinstance(node.op, ast.Sub)
            else left * right
        )
        return value if abs(value) <= 10**9 else None
    return None


def check_name(field_name, name, taken):
    if (
        not isinstance(name, str)
        or not name.isidentifier()
        or name.startswith("_")
        or keyword.iskeyword(name)
        or len(name) > 50
        or name in RESERVED
    ):
        raise ValueError(
            f"`{field_name}` name {name!r} must be an identifier of at most 50 characters, not starting with `_`, not "
            f"a Python keyword nor one of sum, prod, delta, pi or a function name; rename it (e.g. `a`, `gamma`)."
        )
    if name in taken:
        raise ValueError(f"`{field_name}` name {name!r} is already {taken[name]}; rename it.")


def _check_sizes(sizes):
    if sizes is None:
        return {}
    if not isinstance(sizes, dict):
        raise ValueError(f'`sizes` must be a dict {{name: integer}}, e.g. {{"N": 128}}; got {sizes!r}.')
    out = {}
    for name, value in sizes.items():
        check_name("sizes", name, {})
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SIZE:
            raise ValueError(f"`sizes.{name}` must be an integer in 0..{MAX_SIZE}; got {value!r}.")
        out[name] = int(value)
    return out


def listed(mapping):
    return ", ".join(mapping) if mapping else "none"
