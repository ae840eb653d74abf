"""The symbolic half of systems in R^n written as formulas (``expressions_n``): parsing, rules, exact
derivatives over indexed forms, the structure checks and the generated numba source.

``expressions_n`` declares the variables and keeps the disk cache; it imports this module (and sympy) only
for formulas it has not generated before.  The grammar is described there.
"""

from __future__ import annotations

import ast
import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import sympy
from sympy import Indexed, KroneckerDelta, Product, Sum

from . import expressions as _expressions
from .expressions_variables import FUNCTION_NAMES, RESERVED, SPECIAL, Coordinates, check_name, listed

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

if set(FUNCTION_NAMES) != set(_expressions.FUNCTIONS):  # pragma: no cover - a function added to one list only
    raise ImportError("expressions_n.FUNCTION_NAMES must name expressions.FUNCTIONS")
#: symbolic checks materialize the entries the rules give; beyond this many terms, the numeric checks alone
MAX_CHECKED_TERMS = 200_000
#: residuals that do not cancel on sight are simplified (or evaluated at the samples) one by one; beyond this
#: many, the symbolic checks stop and the constructor's numeric ones remain
MAX_HARD_RESIDUALS = 300
_RESERVED = RESERVED
_SPECIAL = SPECIAL
_GRAMMAR = (
    "numbers, the variables (a family indexed: q[i]), parameters, sizes, definitions, pi, + - * / **, unary -, "
    "sum(term, i[, first, last]), prod(term, i[, first, last]), delta(i, j) and the functions "
    + ", ".join(_expressions.FUNCTIONS)
)


# -- 2. parsing ---------------------------------------------------------------------------
class Scope:
    """What a formula may name: coordinates, parameters, sizes, definitions and the indices bound around it."""

    def __init__(self, coords: Coordinates, parameters: Sequence[str], defined: Mapping[str, Any] | None = None):
        self.coords = coords
        self.parameters = {name: sympy.Symbol(name, real=True) for name in parameters}
        self.defined = dict(defined or {})

    def taken(self) -> dict[str, str]:
        out = {name: "a variable" for name in self.coords.scalars}
        out.update({name: "a family of variables" for name in self.coords.families})
        out.update({name: "a size" for name in self.coords.sizes})
        out.update({name: "a parameter" for name in self.parameters})
        out.update({name: "a definition" for name in self.defined})
        return out


def parse(field_name: str, text: str, scope: Scope, indices: Mapping[str, Any] | None = None) -> Any:
    """The sympy expression of ``text`` (whitelist grammar), with ``indices`` (name -> symbol) bound around it.

    >>> scope = Scope(Coordinates(("q[3]", "s"), None), ["a"])
    >>> parse("E", "sum(q[i]**2, i) + a*s", scope)
    a*s + Sum(q[i]**2, (i, 0, 2))
    """
    tree = _expressions_tree(field_name, text)
    return _Builder(field_name, text, scope, dict(indices or {})).build(tree.body)


def _expressions_tree(field_name, text):
    """``text`` as an ``ast`` expression after the R^3 checks of type, length, emptiness and size."""
    if not isinstance(text, str):
        raise ValueError(f"`{field_name}` must be a formula as a string; got {text!r} ({type(text).__name__}).")
    if len(text) > _expressions.MAX_LENGTH:
        raise ValueError(
            f"`{field_name}` is {len(text)} characters long; formulas are limited to {_expressions.MAX_LENGTH}."
        )
    if not text.strip():
        raise ValueError(f'`{field_name}` is empty; write a formula such as "p**2/2".')
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ValueError(f"`{field_name}` is not a formula ({exc.msg}): {text!r}. Allowed: {_GRAMMAR}.") from None
    nodes = sum(1 for _ in ast.walk(tree))
    if nodes > _expressions.MAX_NODES:
        raise ValueError(
            f"`{field_name}` has {nodes} syntax nodes; formulas are limited to {_expressions.MAX_NODES} (use sums)."
        )
    return tree


class _Builder(_expressions._Builder):
    """The R^3 builder with names resolved in a ``Scope``, family members ``q[i]``, ``sum``, ``prod`` and
    ``delta``; every other node is refused as there."""

    def __init__(self, field_name, text, scope, indices):
        super().__init__(field_name, text, {})
        self.scope, self.indices = scope, indices

    def refuse(self, node, why):
        piece = ast.get_source_segment(self.text.strip(), node) or type(node).__name__
        if "not allowed" in why or "whitelisted" in why or "exactly one argument" in why:
            why += f" (formulas may use {_GRAMMAR})"
        raise ValueError(f"`{self.field}`: {why}: {piece!r}.")

    def build(self, node):
        if isinstance(node, ast.Name):
            return self.name(node)
        if isinstance(node, ast.Subscript):
            return self.member(node)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _SPECIAL:
            return self.special(node)
        return super().build(node)

    def name(self, node):
        name, scope = node.id, self.scope
        if name in self.indices:
            return self.indices[name]
        if name in scope.coords.scalars:
            return scope.coords.scalars[name].symbol
        if name in scope.coords.families:
            family = scope.coords.families[name]
            self.refuse(node, f"`{name}` is a family of {family.hi - family.lo + 1} variables: index it, {name}[i]")
        if name in scope.parameters:
            return scope.parameters[name]
        if name in scope.coords.sizes:
            return sympy.Integer(scope.coords.sizes[name])
        if name in scope.defined:
            return scope.defined[name]
        if name in _expressions.CONSTANTS:
            return _expressions.CONSTANTS[name]
        hint = ""
        for family in scope.coords.families.values():
            if name.startswith(family.name) and name[len(family.name) :].isdigit():
                hint = f"; a member of a family is written {family.name}[{name[len(family.name) :]}]"
        self.refuse(
            node,
            f"unknown name (variables: {scope.coords.shown}; params: {listed(scope.parameters)}; sizes: "
            f"{listed(scope.coords.sizes)}; indices here: {listed(self.indices)}){hint}",
        )

    def member(self, node):
        coords = self.scope.coords
        if not isinstance(node.value, ast.Name) or node.value.id not in coords.families:
            what = node.value.id if isinstance(node.value, ast.Name) else None
            taken = self.scope.taken()
            if what in coords.scalars:
                why = f"`{what}` is a single variable, not a family: write {what}"
            elif what in taken:
                why = f"`{what}` is {taken[what]}, not a family of variables"
            elif what is not None:
                why = f"unknown family `{what}` (families: {listed(coords.families)})"
            else:
                why = f"only a family of variables can be indexed (families: {listed(coords.families)})"
            self.refuse(node, why)
        family = coords.families[node.value.id]
        index = self.index(node.slice)
        if not index.free_symbols and not family.lo <= int(index) <= family.hi:
            self.refuse(node, f"outside {family.name}'s range {family.lo}..{family.hi}")
        return family.base[index]

    def index(self, node, single=True):
        """An index: an integer expression of sizes, integers and at most one bound index (coefficient 1)."""
        value = self._index(node)
        if single:
            coefficients = {s: c for s, c in _coefficients(value).items() if s != 1}
            if len(coefficients) > 1 or any(c != 1 for c in coefficients.values()):
                self.refuse(node, "an index is one index plus a constant (i, i+1, N-1; not 2*i or N-i)")
        return value

    def _index(self, node):
        if isinstance(node, ast.Constant) and isinstance(node.value, int) and not isinstance(node.value, bool):
            if abs(node.value) > 10**9:
                self.refuse(node, "index too large")
            return sympy.Integer(node.value)
        if isinstance(node, ast.Name):
            if node.id in self.indices:
                return self.indices[node.id]
            if node.id in self.scope.coords.sizes:
                return sympy.Integer(self.scope.coords.sizes[node.id])
            return self.undeclared(node)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -self._index(node.operand)
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
            left, right = self._index(node.left), self._index(node.right)
            return left + right if isinstance(node.op, ast.Add) else left - right
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
            left, right = self._index(node.left), self._index(node.right)
            if left.free_symbols and right.free_symbols:
                self.refuse(node, "an index is linear in the indices")
            return left * right
        self.refuse(node, "an index is an integer expression of sizes and indices (i, i+1, N-1, 0)")

    def undeclared(self, node):
        name = node.id
        taken = self.scope.taken()
        if name in taken:
            self.refuse(node, f"`{name}` is {taken[name]}, not an index")
        self.refuse(
            node,
            f"index `{name}` is not declared: sum over it (sum(..., {name})), or bind it in a matrix key "
            f"('q[{name}], p[{name}]')",
        )

    def special(self, node):
        name = node.func.id
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            self.refuse(node, f"{name}(...) takes positional arguments only")
        if name == "delta":
            if len(node.args) != 2:
                self.refuse(node, "delta takes two indices: delta(i, j)")
            return KroneckerDelta(self.index(node.args[0]), self.index(node.args[1]))
        if len(node.args) not in (2, 4):
            self.refuse(node, f"write {name}(term, i) or {name}(term, i, first, last)")
        target = node.args[1]
        if not isinstance(target, ast.Name):
            self.refuse(target, f"the index of {name}(term, i) is a name")
        index_name = target.id
        taken = self.scope.taken()
        if index_name in self.indices or index_name in taken or index_name in _RESERVED or index_name.startswith("_"):
            why = "already an index here" if index_name in self.indices else taken.get(index_name, "reserved")
            self.refuse(target, f"`{index_name}` cannot be the index of {name}(...): it is {why}")
        symbol = sympy.Symbol(index_name, integer=True)
        bounds = None
        if len(node.args) == 4:
            bounds = tuple(self.bound(a) for a in node.args[2:])
        self.indices[index_name] = symbol
        try:
            body = self.build(node.args[0])
        finally:
            del self.indices[index_name]
        lo, hi = self.reduction_range(node, name, symbol, body, bounds)
        if name == "sum":
            return _sum(body, (symbol, lo, hi))
        if symbol not in _symbols(body):
            return body ** (hi - lo + 1)
        return Product(body, (symbol, lo, hi))

    def bound(self, node):
        value = self._index(node)
        if value.free_symbols:
            self.refuse(node, "the bounds of a sum are integers or sizes (1, N, N-1), not indices")
        return int(value)

    def reduction_range(self, node, name, symbol, body, bounds):
        """The inclusive range of ``symbol``: ``bounds``, checked against the members it indexes, or theirs."""
        members = {}
        for ref in sorted(body.atoms(Indexed), key=str):
            index = ref.indices[0]
            if symbol in index.free_symbols:
                family = self.scope.coords.families[ref.base.name]
                shift = int(index - symbol)
                members[str(ref)] = (family.lo - shift, family.hi - shift, family)
        label = f"{name}(..., {symbol})"
        if bounds is None:
            if not members:
                self.refuse(
                    node,
                    f"the range of `{symbol}` in {label} cannot be inferred: no variable is indexed by it; give it, "
                    f"{name}(..., {symbol}, first, last)",
                )
            ranges = {(lo, hi) for lo, hi, _ in members.values()}
            if len(ranges) > 1:
                shown = "; ".join(f"{ref} needs {symbol} in {lo}..{hi}" for ref, (lo, hi, _) in members.items())
                self.refuse(
                    node,
                    f"the range of `{symbol}` in {label} is ambiguous ({shown}): give it, "
                    f"{name}(..., {symbol}, first, last)",
                )
            return ranges.pop()
        lo, hi = bounds
        if hi < lo:
            self.refuse(node, f"the range {lo}..{hi} of `{symbol}` is empty")
        for ref, (first, last, family) in members.items():
            if lo < first or hi > last:
                bad = lo if lo < first else hi
                self.refuse(node, f"{ref} leaves {family.name}'s range {family.lo}..{family.hi} at {symbol} = {bad}")
        return lo, hi


def _coefficients(value):
    """``{symbol: coefficient, 1: constant}`` of a linear integer expression."""
    return {k: int(v) for k, v in sympy.expand(value).as_coefficients_dict().items()}


def _symbols(expr):
    """Every symbol in ``expr``, bound ones and those inside indices included."""
    return expr.atoms(sympy.Symbol)


def _definitions(define, scope):
    """``{name: expression}`` of ``define`` (in order; each may use the earlier ones)."""
    if define is None:
        return {}
    if not isinstance(define, dict):
        raise ValueError(f'`define` must be a dict {{name: formula}}, e.g. {{"T": "T0*exp(s/c)"}}; got {define!r}.')
    for name, text in define.items():
        check_name("define", name, scope.taken())
        scope.defined[name] = parse(f"define.{name}", text, scope)
    return scope.defined


# -- 3. matrices given by rules ------------------------------------------------------------
@dataclass
class Rule:
    """``out[positions] += value`` for every value of ``loops`` (``[(symbol, first, last), ...]``, nested in order)."""

    loops: list
    positions: tuple
    value: Any
    source: str  # the key (or entry) it came from, for messages


def matrix_rules(field_name: str, spec: Any, scope: Scope) -> list[Rule]:
    """The rules of a matrix given as n lists of n formulas or as ``{"row, column": formula}``."""
    coords = scope.coords
    if isinstance(spec, dict):
        rules = []
        for key, text in spec.items():
            rules.extend(_key_rules(field_name, key, text, scope))
        return rules
    shape = f"a dict of rules {{'row, column': formula}} or an n x n = {coords.n} x {coords.n} list of formulas"
    if isinstance(spec, (str, bytes)) or not isinstance(spec, (list, tuple)):
        raise ValueError(f"`{field_name}` must be {shape}; got {type(spec).__name__}.")
    if len(spec) != coords.n:
        raise ValueError(
            f"`{field_name}` must be {shape} (one row per variable: {', '.join(coords.names[:6])}"
            f"{', ...' if coords.n > 6 else ''}); got {len(spec)} rows."
        )
    rules = []
    for r, row in enumerate(spec):
        if isinstance(row, (str, bytes)) or not isinstance(row, (list, tuple)) or len(row) != coords.n:
            got = f"{len(row)} formulas" if isinstance(row, (list, tuple)) else repr(row)
            raise ValueError(
                f"`{field_name}` row {r} ({coords.names[r]}) must hold n = {coords.n} formulas; got {got}."
            )
        for c, text in enumerate(row):
            where = f"{field_name}[{coords.names[r]}, {coords.names[c]}]"
            value = parse(where, text, scope)
            if value != 0:
                rules.append(Rule([], (sympy.Integer(r), sympy.Integer(c)), value, where))
    return rules


def _key_rules(field_name, key, text, scope):
    coords = scope.coords
    where = f"{field_name}[{key!r}]"
    form = "'row, column' with two variables, e.g. 'q[i], p[i]' or 's, s'"
    if not isinstance(key, str):
        raise ValueError(f"`{field_name}`: the key {key!r} must be {form}.")
    try:
        tree = ast.parse(key.strip(), mode="eval").body
    except SyntaxError:
        raise ValueError(f"`{where}`: the key must be {form}.") from None
    if not isinstance(tree, ast.Tuple) or len(tree.elts) != 2:
        raise ValueError(f"`{where}`: the key must be {form}.")
    declared: dict[str, Any] = {}
    builder = _Builder(where, key, scope, declared)
    refs = [_key_reference(builder, element, declared, where) for element in tree.elts]
    # each index runs where its row and its column exist
    domain = {}
    for name, symbol in declared.items():
        lo, hi = -math.inf, math.inf
        for ref in refs:
            if isinstance(ref, Indexed) and symbol in ref.indices[0].free_symbols:
                family = coords.families[ref.base.name]  # pyright: ignore[reportAttributeAccessIssue]  # a Symbol
                shift = int(ref.indices[0] - symbol)
                lo, hi = max(lo, family.lo - shift), min(hi, family.hi - shift)
        if hi < lo:
            raise ValueError(f"`{where}`: the key has no entries: no `{name}` gives both a row and a column.")
        domain[symbol] = (int(lo), int(hi))
    value = parse(where, text, scope, declared)
    for ref in sorted(value.atoms(Indexed), key=str):  # members indexed by key indices stay in range
        ref: Any
        index = ref.indices[0]
        inside = index.free_symbols & set(domain)
        if inside:
            (symbol,) = inside
            family = coords.families[ref.base.name]
            lo, hi = domain[symbol]
            shift = int(index - symbol)
            if lo + shift < family.lo or hi + shift > family.hi:
                bad = lo if lo + shift < family.lo else hi
                raise ValueError(
                    f"`{where}`: {ref} leaves {family.name}'s range {family.lo}..{family.hi} at {symbol} = {bad} "
                    f"(the key runs {symbol} over {lo}..{hi})."
                )
    rules = []
    for term in sympy.Add.make_args(value):
        rule = _reduce_deltas(term, refs, dict(domain), coords, key)
        if rule is not None and rule.value != 0:
            rules.append(rule)
    return rules


def _key_reference(builder, node, declared, where):
    coords = builder.scope.coords
    if isinstance(node, ast.Name):
        if node.id in coords.scalars:
            return coords.scalars[node.id].symbol
        if node.id in coords.families:
            raise ValueError(f"`{where}`: `{node.id}` is a family: index it in the key, {node.id}[i].")
        raise ValueError(f"`{where}`: `{node.id}` is not a variable (variables: {coords.shown}).")
    if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name):
        if node.value.id not in coords.families:
            what = "a single variable, not a family" if node.value.id in coords.scalars else "not a variable"
            raise ValueError(f"`{where}`: `{node.value.id}` is {what} (variables: {coords.shown}).")
        for name_node in ast.walk(node.slice):  # a new name in a key's index declares that index
            if isinstance(name_node, ast.Name) and name_node.id not in declared and name_node.id not in coords.sizes:
                taken = builder.scope.taken()
                if name_node.id in taken or name_node.id in _RESERVED or name_node.id.startswith("_"):
                    why = taken.get(name_node.id, "reserved")
                    raise ValueError(f"`{where}`: `{name_node.id}` cannot be an index: it is {why}.")
                declared[name_node.id] = sympy.Symbol(name_node.id, integer=True)
        return builder.member(node)
    raise ValueError(f"`{where}`: the key must be 'row, column' with two variables, e.g. 'q[i], p[i]' or 's, s'.")


def _bound_deltas(term):
    """The deltas inside a Sum or Product of ``term`` (their indices may be bound there)."""
    return {d for node in _outer_reductions(term) for d in node.atoms(KroneckerDelta)}


def _reduce_deltas(term, refs, domain, coords, key):
    """One term of a rule as a ``Rule``, each ``delta`` of key indices resolved by eliminating an index."""
    refs = list(refs)
    while True:
        deltas = [  # of key indices only: a delta of an index bound by a sum inside stays a test in its loop
            d
            for d in term.atoms(KroneckerDelta)
            if d.free_symbols & set(domain) and d.free_symbols <= set(domain) and d not in _bound_deltas(term)
        ]
        if not deltas:
            break
        delta = sorted(deltas, key=str)[0]
        difference = delta.args[0] - delta.args[1]
        coefficients = _coefficients(difference)
        # eliminate the last declared index with coefficient +-1 (the column's, where there is a choice)
        candidates = [s for s in reversed(list(domain)) if coefficients.get(s, 0) in (1, -1)]
        if not candidates:
            break  # not reducible: printed as a test inside the loop
        symbol = candidates[0]
        solution = sympy.expand(symbol - difference / coefficients[symbol])  # symbol = solution
        lo, hi = domain.pop(symbol)
        rest = solution.free_symbols & set(domain)
        if not rest:  # symbol = a constant
            if not lo <= int(solution) <= hi:
                return None
        else:
            (other,) = rest
            scale, shift = _coefficients(solution).get(other, 0), _coefficients(solution).get(1, 0)
            first, last = sorted(((lo - shift) * scale, (hi - shift) * scale))  # other = scale (symbol - shift)
            olo, ohi = domain[other]
            domain[other] = (max(olo, first), min(ohi, last))
            if domain[other][0] > domain[other][1]:
                return None
        term = term.xreplace({symbol: solution})
        refs = [r.xreplace({symbol: solution}) for r in refs]
    positions = tuple(sympy.expand(sympy.sympify(coords.position(r))) for r in refs)
    loops = [(s, lo, hi) for s, (lo, hi) in domain.items() if s in set().union(*(p.free_symbols for p in positions))]
    unused = [s for s in domain if s not in {loop[0] for loop in loops}]
    for s in unused:  # an index the positions do not use (reduced away): the term repeats over its range
        lo, hi = domain[s]
        term = Sum(term, (s, lo, hi)) if s in _symbols(term) else (hi - lo + 1) * term
    return Rule(loops, positions, term, key)


# -- 4. derivatives over indexed forms -----------------------------------------------------
@dataclass
class _Term:
    """A piece of ``dF/dtarget``: ``value`` where the target index equals ``eq`` (a pending Kronecker delta) or
    lies in ``span`` (inclusive), or everywhere for a scalar target (both None)."""

    eq: Any
    span: tuple | None
    value: Any


def _outer_reductions(expr):
    """The Sum and Product nodes of ``expr`` not inside another."""
    found = []
    stack = [expr]
    while stack:
        node = stack.pop()
        if isinstance(node, (Sum, Product)):
            if node not in found:
                found.append(node)
            continue
        stack.extend(node.args)
    return found


def _split(node):
    """``(body, (i, lo, hi))`` of a Sum or Product, its outermost index first: sympy merges nested sums into one
    node with several limits, ``Sum(f, (j, ..), (i, ..))`` being the sum over i of the sum over j."""
    *inner, outer = node.limits
    body = type(node)(node.function, *inner) if inner else node.function
    return body, (outer[0], int(outer[1]), int(outer[2]))


_counter = itertools.count()


def _fresh(kind="real"):
    name = f"_d{next(_counter)}"
    return sympy.Symbol(name, integer=True) if kind == "integer" else sympy.Symbol(name, real=True)


def _derivative(expr, target, k):
    """``d expr / d target`` as ``_Term``s: ``target`` is a scalar's symbol (``k`` None) or an ``IndexedBase``
    whose member ``target[k]`` is differentiated against (k a fresh integer symbol)."""
    reductions = _outer_reductions(expr)
    atoms = {node: _fresh() for node in reductions}
    shell = expr.xreplace(atoms)
    if k is None:
        references = {target: target} if target in shell.free_symbols else {}
    else:
        references = {ref: _fresh() for ref in shell.atoms(Indexed) if ref.base == target}
    shell = shell.xreplace({ref: d for ref, d in references.items() if ref is not d})
    back = {d: node for node, d in atoms.items()}
    back.update({d: ref for ref, d in references.items() if ref is not d})
    terms = []
    for ref, d in references.items():
        outer = sympy.diff(shell, d).xreplace(back)
        if outer != 0:
            terms.append(_Term(None if k is None else ref.indices[0], None, outer))
    for node, d in atoms.items():
        outer = sympy.diff(shell, d).xreplace(back)
        if outer == 0:
            continue
        for term in _reduction_derivative(node, target, k):
            terms.append(_Term(term.eq, term.span, outer * term.value))
    return terms


def _reduction_derivative(node, target, k):
    body, (i, lo, hi) = _split(node)
    out = []
    for term in _derivative(body, target, k):
        if term.eq is not None and i in term.eq.free_symbols:
            shift = int(term.eq - i)  # the member target[i + shift] is target[k]: i = k - shift
            where = k - shift
            value = term.value.xreplace({i: where})
            if isinstance(node, Product):
                value = value * _product_without(body, i, lo, hi, where)
            out.append(_Term(None, (lo + shift, hi + shift), value))
        elif isinstance(node, Product):
            j = _fresh("integer")
            others = _product_without(body.xreplace({i: j}), j, lo, hi, i)
            out.append(_Term(term.eq, term.span, _sum(term.value * others, (i, lo, hi))))
        else:
            out.append(_Term(term.eq, term.span, _sum(term.value, (i, lo, hi))))
    return out


def _sum(value, limit):
    """``Sum(value, limit)`` with the factors that do not depend on the index taken out (computed once)."""
    i, lo, hi = limit
    if i not in _symbols(value):
        return (hi - lo + 1) * value
    constant, varying = value.as_independent(i, as_Add=False)
    return constant * Sum(varying, limit)


def _product_without(body, i, lo, hi, where):
    """``prod over i != where of body`` as a Product whose factor at ``i = where`` is 1."""
    return Product(body * (1 - KroneckerDelta(i, where)) + KroneckerDelta(i, where), (i, lo, hi))


def gradient_rules(F: sympy.Expr, coords: Coordinates) -> list[Rule]:
    """The rules of ``grad F``: one per scalar variable with a nonzero derivative, a loop over each family's
    members (or single members) where F depends on them."""
    rules = []
    for scalar in coords.scalars.values():
        for term in _derivative(F, scalar.symbol, None):
            rules.append(Rule([], (sympy.Integer(scalar.offset),), term.value, scalar.name))
    for family in coords.families.values():
        k = _fresh("integer")
        for term in _derivative(F, family.base, k):
            if term.span is None:  # a member named by a constant index, q[3]
                if term.eq is None or term.eq.free_symbols:
                    raise AssertionError(f"unresolved derivative {term}")  # pragma: no cover - F is closed
                where = int(term.eq)
                rules.append(
                    Rule([], (sympy.Integer(family.position(where)),), term.value.xreplace({k: where}), family.name)
                )
            else:
                lo, hi = max(term.span[0], family.lo), min(term.span[1], family.hi)
                if lo <= hi:
                    rules.append(Rule([(k, lo, hi)], (sympy.expand(family.position(k)),), term.value, family.name))
    return [rule for rule in rules if rule.value != 0]


# -- 5. the structure, checked on the entries ----------------------------------------------
class _Entries:
    """The nonzero entries of a vector or matrix given by rules, concrete (``q[3] -> q3``, sums unrolled)."""

    def __init__(self, rules, concrete):
        self.values: dict[tuple, Any] = {}
        self.sources: dict[tuple, str] = {}
        for rule in rules:
            symbols = [s for s, _, _ in rule.loops]
            for point in itertools.product(*(range(lo, hi + 1) for _, lo, hi in rule.loops)):
                at = dict(zip(symbols, (sympy.Integer(v) for v in point)))
                position = tuple(int(p.xreplace(at)) for p in rule.positions)
                value = _unrolled(rule.value.xreplace(at)).xreplace(concrete)
                self.values[position] = self.values.get(position, 0) + value
                self.sources.setdefault(position, rule.source)

    def get(self, position):
        return self.values.get(position, sympy.Integer(0))


def _unrolled(expr):
    """``expr`` with every Sum and Product (concrete bounds) written out."""
    for node in _outer_reductions(expr):
        body, (i, lo, hi) = _split(node)
        parts = [_unrolled(body.xreplace({i: sympy.Integer(v)})) for v in range(int(lo), int(hi) + 1)]
        expr = expr.xreplace({node: sympy.Add(*parts) if isinstance(node, Sum) else sympy.Mul(*parts)})
    return expr


def _work(rules):
    """The number of terms materializing ``rules`` writes out (loops times the sums inside)."""
    total = 0
    for rule in rules:
        count = math.prod(hi - lo + 1 for _, lo, hi in rule.loops)
        total += count * _unrolled_size(rule.value)
    return total


def _unrolled_size(expr):
    size = 1
    for node in _outer_reductions(expr):
        body, (_, lo, hi) = _split(node)
        size += (hi - lo + 1) * _unrolled_size(body)
    return size


class _OverBudget(Exception):
    """More residuals need sympy's or the samples' attention than ``MAX_HARD_RESIDUALS``."""


class _Checker:
    """Decides whether residuals vanish: sympy first, the sample points where sympy cannot tell."""

    def __init__(self, coords, values, samples):
        self.coords, self.values = coords, values
        self.exact = {sympy.Symbol(k, real=True): sympy.Rational(v) for k, v in values.items()}
        self.points, self.fine_points = (
            [
                {
                    **{s: sympy.Float(v, digits) for s, v in zip(coords.symbols, row)},
                    **{sympy.Symbol(k, real=True): sympy.Float(v, digits) for k, v in values.items()},
                }
                for row in samples
            ]
            for digits in (30, 60)
        )
        #: an identity was accepted at the parameter values only (exactly, or at the samples)
        self.used_values = False
        #: residuals that do not vanish on sight still to be examined (simplify, samples) before giving up
        self.budget = MAX_HARD_RESIDUALS

    def residual(self, expr):
        """None where ``expr`` vanishes, else its (simplified) form for the message."""
        if expr == 0:
            return None
        self.budget -= 1
        if self.budget < 0:
            raise _OverBudget
        expanded = sympy.expand(expr) if sympy.count_ops(expr) <= 20_000 else expr
        if expanded == 0:
            return None
        shown = expanded
        if sympy.count_ops(expanded) <= 300:
            shown = sympy.simplify(expanded)
            if shown == 0:
                return None
            if self.exact and sympy.simplify(shown.xreplace(self.exact)) == 0:
                self.used_values = True
                return None  # holds at the given parameter values
        if self.nonzero_at_samples(expr):
            return shown
        self.used_values = self.used_values or bool(self.values)
        return None

    def nonzero_at_samples(self, expr):
        """True where ``expr`` differs from 0 at a sample point (no finite point: True, sympy's verdict stands).

        Evaluated twice, with 30 and with 60 digits: the rounding of an identity shrinks by some 30 orders of
        magnitude, a nonzero residual stays where it is, whatever the size of the terms that cancel."""
        finite = False
        for coarse, fine in zip(self.points, self.fine_points):
            try:
                low = complex(expr.xreplace(coarse).evalf(30))  # pyright: ignore[reportAttributeAccessIssue]
                high = complex(expr.xreplace(fine).evalf(60))  # pyright: ignore[reportAttributeAccessIssue]
            except (TypeError, ValueError, ZeroDivisionError, OverflowError):
                continue
            if not all(math.isfinite(v) for v in (low.real, low.imag, high.real, high.imag)):
                continue
            finite = True
            if low != 0 and high != 0 and abs(high) > 1e-10 * abs(low):
                return True
        return not finite


def _shown(expr):
    text = str(expr)
    return text if len(text) <= 300 else text[:300] + " ..."


def check_structure(
    coords: Coordinates,
    poisson: tuple[str, list[Rule]],
    metric: tuple[str, list[Rule]] | None,
    grad_H: tuple[str, list[Rule]],
    grad_S: list[Rule],
    values: Mapping[str, float],
    samples: Any,
) -> tuple[str, bool]:
    """Check skewness, the Casimir, symmetry and ``metric grad H = 0`` on the entries; returns ``("symbolic",
    used)`` or ``("numeric", False)`` (too many terms: the constructor's numeric checks at the samples remain),
    ``used`` True where an identity was accepted only at the parameter values.

    ``poisson`` and ``metric`` are ``(name, rules)``; ``grad_H`` is ``(the energy's name, rules)``.
    """
    everything = poisson[1] + (metric[1] if metric else []) + grad_H[1] + grad_S
    if _work(everything) > MAX_CHECKED_TERMS:
        return "numeric", False
    try:
        return _check_entries(coords, poisson, metric, grad_H, grad_S, values, samples)
    except _OverBudget:
        return "numeric", False


def _check_entries(coords, poisson, metric, grad_H, grad_S, values, samples):
    concrete = coords.concrete()
    names = coords.names
    check = _Checker(coords, values, samples)
    P_name, P = poisson[0], _Entries(poisson[1], concrete)
    for r, c in sorted(P.values):
        if (c, r) in P.values and (c, r) < (r, c):
            continue
        residual = check.residual(P.get((r, c)) + P.get((c, r)))
        if residual is not None:
            raise ValueError(
                f"`{P_name}` is not skew: {P_name}[{names[r]}, {names[c]}] + {P_name}[{names[c]}, {names[r]}] = "
                f"{_shown(residual)} (rule {P.sources[(r, c)]!r}); write the transposed entry with the opposite sign."
            )
    gS = _Entries(grad_S, concrete)
    _require_null(check, P_name, P, gS, "grad S", "S must be a Casimir of it", names)
    if metric is None:
        return "symbolic", check.used_values
    M_name, M = metric[0], _Entries(metric[1], concrete)
    for r, c in sorted(M.values):
        if r >= c and (c, r) in M.values:
            continue
        residual = check.residual(M.get((r, c)) - M.get((c, r)))
        if residual is not None:
            raise ValueError(
                f"`{M_name}` is not symmetric: {M_name}[{names[r]}, {names[c]}] - {M_name}[{names[c]}, {names[r]}] = "
                f"{_shown(residual)} (rule {M.sources[(r, c)]!r}); give the transposed entry too."
            )
    energy, gH = grad_H[0], _Entries(grad_H[1], concrete)
    _require_null(check, M_name, M, gH, f"grad {energy}", f"{energy} must be conserved", names)
    return "symbolic", check.used_values


def _require_null(check, name, A, v, vector, why, names):
    rows: dict[int, list] = {}
    sources: dict[int, list] = {}
    for (r, c), value in A.values.items():
        if (c,) in v.values:
            rows.setdefault(r, []).append(value * v.values[(c,)])
            if A.sources[(r, c)] not in sources.setdefault(r, []):
                sources[r].append(A.sources[(r, c)])
    for r in sorted(rows):
        residual = check.residual(sympy.Add(*rows[r]))
        if residual is not None:
            rules = ", ".join(repr(source) for source in sources[r])
            raise ValueError(
                f"`{name}` does not annihilate {vector} ({why}): ({name} {vector})[{names[r]}] = {_shown(residual)} "
                f"(rule{'s' if len(sources[r]) > 1 else ''} {rules})."
            )


# -- 6. code generation -----------------------------------------------------------------------
class _Printer(_expressions._NumbaPrinter):
    """Coordinates as ``x[...]`` (families at their offsets), parameters ``p[i]``, loop indices and temporaries
    by their generated names, ``delta`` as a test."""

    def __init__(self, coords, parameters):
        super().__init__(parameters)
        self.coords = coords
        self.names = {name: f"x[{s.offset}]" for name, s in coords.scalars.items()}
        self.names.update({name: f"p[{i}]" for i, name in enumerate(parameters)})
        self.locals: dict[Any, str] = {}

    def _print_Symbol(self, expr):
        if expr in self.locals:
            return self.locals[expr]
        if expr.is_integer:  # an index as a number
            raise KeyError(f"index {expr} outside its loop")  # pragma: no cover - the parser binds every index
        return self.names[expr.name]

    def _print_Indexed(self, expr):
        return f"x[{self.integer(self.coords.position(expr))}]"

    def _print_KroneckerDelta(self, expr):
        return f"(1.0 if {self.integer(expr.args[0])} == {self.integer(expr.args[1])} else 0.0)"

    def _print_Sum(self, expr):  # pragma: no cover - the emitter replaces every sum by a temporary
        raise AssertionError("a sum reached the printer")

    _print_Product = _print_Sum

    def integer(self, value):
        """An integer expression of loop indices, as integer arithmetic."""
        parts = []
        constant = 0
        for symbol, c in _coefficients(sympy.sympify(value)).items():
            if symbol == 1:
                constant = c
                continue
            name = self.locals[symbol]
            parts.append(name if c == 1 else f"-{name}" if c == -1 else f"{c}*{name}")
        if constant or not parts:
            parts.append(str(constant))
        return " + ".join(parts).replace("+ -", "- ")

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"


class _Emitter:
    """The body of one generated function: nested blocks of statements, sums computed where they belong."""

    def __init__(self, printer):
        self.printer = printer
        self.top: list = []
        self.count = 0
        self.memo: dict[Any, Any] = {}

    def temporary(self):
        self.count += 1
        return f"_t{self.count}"

    def loop_name(self, symbol):
        self.count += 1
        name = f"_i{self.count}_{symbol.name.lstrip('_')}"
        self.printer.locals[symbol] = name
        return name

    def lower(self, expr, stack):
        """``expr`` with each outer Sum/Product replaced by a temporary computed in the innermost block of
        ``stack`` (``[(loop symbol or None, block)]``) whose index it uses."""
        replacements = {}
        for node in _outer_reductions(expr):
            uses = _symbols(node)
            depth = max((d for d, (s, _) in enumerate(stack) if s is not None and s in uses), default=0)
            if depth == 0 and node in self.memo:
                replacements[node] = self.memo[node]
                continue
            name = self.temporary()
            symbol = sympy.Symbol(name, real=True)
            self.printer.locals[symbol] = name
            block = stack[depth][1]
            body, (i, lo, hi) = _split(node)
            initial, operation = ("0.0", "+=") if isinstance(node, Sum) else ("1.0", "*=")
            block.append(f"{name} = {initial}")
            inner: list = []
            header = f"for {self.loop_name(i)} in range({int(lo)}, {int(hi) + 1}):"
            value = self.lower(body, stack[: depth + 1] + [(i, inner)])
            inner.append(f"{name} {operation} {self.printer.doprint(value)}")
            block.append((header, inner))
            if depth == 0:
                self.memo[node] = symbol
            replacements[node] = symbol
        return expr.xreplace(replacements)

    def rules(self, rules, target):
        """``target[positions] += value`` for every rule, rules over the same ranges in one loop nest."""
        groups: dict[tuple, list] = {}
        for rule in rules:
            groups.setdefault(tuple((lo, hi) for _, lo, hi in rule.loops), []).append(rule)
        for ranges, members in groups.items():
            shared = [sympy.Symbol(f"_l{d}", integer=True) for d in range(len(ranges))]
            stack: list = [(None, self.top)]
            headers = []
            for symbol, (lo, hi) in zip(shared, ranges):
                headers.append(f"for {self.loop_name(symbol)} in range({lo}, {hi + 1}):")
                stack.append((symbol, []))
            for rule in members:
                rename = {s: t for (s, _, _), t in zip(rule.loops, shared)}
                value = self.lower(rule.value.xreplace(rename), stack)
                where = ", ".join(self.printer.integer(p.xreplace(rename)) for p in rule.positions)
                stack[-1][1].append(f"{target}[{where}] += {self.printer.doprint(value)}")
            # each loop joins its block once its body is complete: what was hoisted into a block comes first
            for depth in range(len(headers), 0, -1):
                stack[depth - 1][1].append((headers[depth - 1], stack[depth][1]))

    def text(self, name, result, prelude=()):
        lines = ["", "@njit(cache=True)", f"def {name}(x, p):", *(f"    {line}" for line in prelude)]

        def render(block, indent):
            for item in block:
                if isinstance(item, tuple):
                    lines.append(" " * indent + item[0])
                    render(item[1], indent + 4)
                else:
                    lines.append(" " * indent + item)

        render(self.top, 4)
        lines.append(f"    return {result}")
        return "\n".join(lines) + "\n"


def _scalar_source(name, expr, printer):
    emitter = _Emitter(printer)
    value = emitter.lower(expr, [(None, emitter.top)])
    return emitter.text(name, printer.doprint(value))


def _array_source(name, rules, shape, printer):
    emitter = _Emitter(printer)
    emitter.rules(rules, "out")
    return emitter.text(name, "out", [f"out = numpy.zeros({shape})"])


def source(coords, parameters, H, grad_H, S, grad_S, P, M) -> str:
    """The generated module: ``H, grad_H, S, grad_S, P`` and ``M`` (the metric, when given) of ``(x, p)``."""
    printer = _Printer(coords, parameters)
    n = coords.n
    parts = [
        f"# generated by geomint.model.expressions_symbolic; n = {n}; parameters p = {list(parameters)}",
        "import math",
        "import numpy",
        "from numba import njit",
        "",
        _scalar_source("H", H, printer),
        _array_source("grad_H", grad_H, n, printer),
        _scalar_source("S", S, printer),
        _array_source("grad_S", grad_S, n, printer),
        _array_source("P", P, f"({n}, {n})", printer),
    ]
    if M is not None:
        parts.append(_array_source("M", M, f"({n}, {n})", printer))
    text = "\n".join(parts)
    check_generated(text)
    return text


_ALLOWED_CALLS = {"range", "abs", "njit"}
_ALLOWED_NAMES = {"x", "p", "out", "math", "numpy", "njit", "range", "abs"}


def check_generated(text: str) -> None:
    """The generated source uses only what the generator writes: ``x``, ``p``, ``out``, loop indices and
    temporaries (``_...``), ``math.<function>``, ``numpy.zeros``/``numpy.sign``, ``range``, ``abs``; no
    strings but none, no attribute of anything but ``math`` and ``numpy``.  A violation is a bug of the
    generator: ``AssertionError``."""
    tree = ast.parse(text)
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and not (node.id in _ALLOWED_NAMES or node.id.startswith("_")):
            raise AssertionError(f"generated code names {node.id!r}")
        if isinstance(node, ast.Attribute) and not (
            isinstance(node.value, ast.Name) and node.value.id in ("math", "numpy") and not node.attr.startswith("_")
        ):
            raise AssertionError(f"generated code reads an attribute {ast.dump(node)[:80]}")
        if isinstance(node, ast.Constant) and isinstance(node.value, (str, bytes)):
            raise AssertionError("generated code holds a string")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id not in _ALLOWED_CALLS:
            raise AssertionError(f"generated code calls {node.func.id!r}")
        if isinstance(node, (ast.Lambda, ast.ClassDef, ast.Global, ast.Nonlocal, ast.With, ast.Try, ast.Delete)):
            raise AssertionError(f"generated code holds a {type(node).__name__}")


def generate(
    form_names: tuple[str, str, str],
    coords: Coordinates,
    values: Mapping[str, float],
    define: Any,
    energy: str,
    S: str,
    poisson: Any,
    metric: Any,
    samples: Any,
    check: bool,
) -> tuple[str, str, bool]:
    """``(source, checks, used_values)`` for formulas: parsed, differentiated, checked (unless ``check`` is
    False: ``checks`` is then ``"skipped"``) and generated.  ``form_names`` are the names of the energy, the
    Poisson matrix and the metric (``("E", "L", "M")`` for GENERIC).  ``used_values``: an identity held only at
    the parameter values."""
    E_name, P_name, M_name = form_names
    scope = Scope(coords, list(values))
    _definitions(define, scope)
    H_expr, S_expr = parse(E_name, energy, scope), parse("S", S, scope)
    P_rules = matrix_rules(P_name, poisson, scope)
    M_rules = None if metric is None else matrix_rules(M_name, metric, scope)
    grad_H, grad_S = gradient_rules(H_expr, coords), gradient_rules(S_expr, coords)
    checks, used_values = "skipped", False
    if check:
        from .checks import check_samples

        checks, used_values = check_structure(
            coords,
            (P_name, P_rules),
            None if M_rules is None else (M_name, M_rules),
            (E_name, grad_H),
            grad_S,
            values,
            check_samples(samples, coords.n),
        )
    text = source(coords, list(values), H_expr, grad_H, S_expr, grad_S, P_rules, M_rules)
    return text, checks, used_values
