"""Systems written as formulas: a whitelist grammar, exact derivatives, generated and cached numba code.

    H = "(y**2 + z**2)/2 - r*z",  S = "x**2/2 - sigma*z",  J = ("-x", "0", "sigma")

Text becomes a system in four steps, each refusing what it cannot vouch for:

1. **Parse** (``parse``): Python's ``ast`` reads the text and a walk admits only
   numbers, ``x``, ``y``, ``z``, ``pi``, the declared parameter names,
   ``+ - * / **``, unary minus and one-argument calls of ``FUNCTIONS``.  Anything
   else (attributes, subscripts, other calls, keywords, strings, lambdas,
   comprehensions, ``__import__('os').system(...)``) raises ``ValueError``
   naming the field and the offending piece.  The sympy expression is then built
   node by node from the checked tree: sympy's ``sympify``/``parse_expr``, which
   evaluate their input, never see the text.
2. **Differentiate** with sympy: ``grad H`` and ``grad S`` are exact.
3. **Check the structure** symbolically (``check_structure``): a matrix ``P`` must be
   skew, ``P v = v x J``; Jacobi ``J . curl J = 0``; Casimir ``grad S x J = 0``.
   A failing identity raises ``ValueError`` with its simplified residual.
4. **Generate** a numba module (``compile_functions``): functions of ``(x, p)``
   returning floats and 3-tuples (or a 3x3 array for ``P``), parameters read as
   ``p[i]``, written to ``<cache>/geomint_expr_<hash>.py`` and decorated with
   ``numba.njit(cache=True)``, so a new process loads the machine code from disk.
   ``<cache>`` is ``<cache root>/expressions``, the cache root of ``geomint._cache``
   (``$GEOMINT_CACHE_DIR``, else ``$XDG_CACHE_HOME/geomint``, default ``~/.cache/geomint``).

``MetriplecticSystem.from_expressions`` is the public entry; it hands the
generated functions to the one public constructor.

Example
-------
>>> import geomint
>>> lorenz = geomint.MetriplecticSystem.from_expressions(
...     H="(y**2 + z**2)/2 - r*z", S="x**2/2 - sigma*z", J=("-x", "0", "sigma"),
...     params={"sigma": 10.0, "r": 28.0}, eps=0.1, name="lorenz_nevir")
>>> lorenz.grad_H([1.0, 2.0, 3.0]).tolist()
[0.0, 2.0, -25.0]
"""

from __future__ import annotations

import ast
import keyword
import math
from typing import TYPE_CHECKING, Any

import sympy
from sympy.printing.pycode import PythonCodePrinter

from .expressions_cache import cache_directory, compile_functions  # noqa: F401  # re-exported (their home before)

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping, Sequence

#: function name in a formula -> (sympy function, how the generated code computes it)
FUNCTIONS = {
    "exp": sympy.exp,
    "log": sympy.log,
    "sqrt": sympy.sqrt,
    "abs": sympy.Abs,
    "sin": sympy.sin,
    "cos": sympy.cos,
    "tan": sympy.tan,
    "sinh": sympy.sinh,
    "cosh": sympy.cosh,
    "tanh": sympy.tanh,
    "asin": sympy.asin,
    "acos": sympy.acos,
    "atan": sympy.atan,
    "asinh": sympy.asinh,
    "acosh": sympy.acosh,
    "atanh": sympy.atanh,
}
COORDINATES = ("x", "y", "z")
CONSTANTS = {"pi": sympy.pi}
MAX_LENGTH = 2000
MAX_NODES = 400
_MAX_LOG10 = 300.0  # a constant power beyond 1e300 is refused (it would overflow float64 or hang sympy)
_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_GRAMMAR = (
    f"numbers, {', '.join(COORDINATES)}, pi, parameter names, + - * / **, unary -, "
    f"and the functions {', '.join(FUNCTIONS)}"
)
_SYMBOLS = {name: sympy.Symbol(name, real=True) for name in COORDINATES}
_GENERATOR_VERSION = "1"


# -- 1. parsing ---------------------------------------------------------------------------
def parse(field: str, text: str, parameters: Iterable[str] = ()) -> sympy.Expr:
    """The sympy expression of ``text``, admitted by the whitelist grammar.

    Parameters
    ----------
    field : str
        What the text is (``"H"``, ``"J[2]"``, ``"system.S"``); errors name it.
    text : str
        The formula, e.g. ``"a*cosh(x) + exp(z) - z"``.
    parameters : sequence of str
        Names the formula may use besides ``x, y, z, pi``.

    Raises ``ValueError`` naming ``field`` and the offending piece for anything
    outside the grammar, before sympy sees anything.

    >>> parse("H", "x**2/2 + a*cosh(y)", ["a"])
    a*cosh(y) + x**2/2
    """
    if not isinstance(text, str):
        raise ValueError(f"`{field}` must be a formula as a string; got {text!r} ({type(text).__name__}).")
    if len(text) > MAX_LENGTH:
        raise ValueError(f"`{field}` is {len(text)} characters long; formulas are limited to {MAX_LENGTH}.")
    if not text.strip():
        raise ValueError(f'`{field}` is empty; write a formula such as "x**2/2".')
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ValueError(f"`{field}` is not a formula ({exc.msg}): {text!r}. Allowed: {_GRAMMAR}.") from None
    nodes = sum(1 for _ in ast.walk(tree))
    if nodes > MAX_NODES:
        raise ValueError(f"`{field}` has {nodes} syntax nodes; formulas are limited to {MAX_NODES}.")
    symbols = {**_SYMBOLS, **CONSTANTS, **{name: sympy.Symbol(name, real=True) for name in parameters}}
    return _Builder(field, text, symbols).build(tree.body)


class _Builder:
    """Builds a sympy expression from a checked ``ast`` tree, refusing every other node."""

    def __init__(self, field, text, symbols):
        self.field, self.text, self.symbols = field, text, symbols

    def refuse(self, node, why):
        piece = ast.get_source_segment(self.text.strip(), node) or type(node).__name__
        raise ValueError(f"`{self.field}`: {why}: {piece!r}. Formulas may use {_GRAMMAR}.")

    def build(self, node):
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            if node.id not in self.symbols:
                self.refuse(node, "unknown name (declare parameters in `params`; in a scene file, `parameters`)")
            return self.symbols[node.id]
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = self.build(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return self.binary(node)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitXor):
            self.refuse(node, "`^` is not a power here (write x**2)")
        if isinstance(node, ast.Call):
            return self.call(node)
        self.refuse(node, f"{type(node).__name__.lower()} is not allowed")

    def number(self, node):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.refuse(node, "only real numbers are allowed as constants")
        if isinstance(value, int):
            if abs(value) > 10**15:
                self.refuse(node, "integer constant larger than 1e15")
            return sympy.Integer(value)
        if not math.isfinite(value):
            self.refuse(node, "constant is not finite")
        return sympy.Float(value)

    def binary(self, node):
        left, right = self.build(node.left), self.build(node.right)
        if isinstance(node.op, ast.Pow):
            if (
                left.is_Number
                and right.is_Number
                and left != 0
                and abs(float(right)) * abs(math.log10(abs(float(left)))) > _MAX_LOG10
            ):
                self.refuse(node, "constant power beyond 1e300")
            return sympy.Pow(left, right)
        if isinstance(node.op, ast.Div) and right == 0:
            self.refuse(node, "division by zero")
        return {
            ast.Add: lambda: left + right,
            ast.Sub: lambda: left - right,
            ast.Mult: lambda: left * right,
            ast.Div: lambda: left / right,
        }[type(node.op)]()

    def call(self, node):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            self.refuse(node.func, "not a whitelisted function")
        if node.keywords or len(node.args) != 1 or isinstance(node.args[0], ast.Starred):
            self.refuse(node, "a function takes exactly one argument, without keywords")
        return FUNCTIONS[node.func.id](self.build(node.args[0]))


def check_parameters(params: Mapping[str, float], field: str = "params") -> dict[str, float]:
    """``{name: float}`` with names that are identifiers and not x, y, z, pi or a function name.

    ``field`` names the argument in errors.

    >>> check_parameters({"a": 1})
    {'a': 1.0}
    """
    if not isinstance(params, dict):
        raise ValueError(f"`{field}` must be a dict {{name: value}}; got {params!r} ({type(params).__name__}).")
    reserved = set(COORDINATES) | set(CONSTANTS) | set(FUNCTIONS)
    out = {}
    for name, value in params.items():
        if (
            not isinstance(name, str)
            or not name.isidentifier()
            or name.startswith("_")
            or name in reserved
            or keyword.iskeyword(name)
            or len(name) > 50
        ):
            raise ValueError(
                f"`{field}` name {name!r} must be an identifier of at most 50 characters, not starting "
                f"with `_`, not a Python keyword and not one of {sorted(reserved)}; rename it, e.g. `a`, "
                "`sigma`, `r2`."
            )
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"`{field}.{name}` must be a finite real number; got {value!r}.")
        out[name] = float(value)
    return out


# -- 2 and 3. derivatives and the structure -----------------------------------------------
def gradient(expression: sympy.Expr) -> tuple[sympy.Expr, ...]:
    """``(d/dx, d/dy, d/dz)`` of a sympy expression, exact.

    >>> gradient(parse("F", "x*y + z**2"))
    (y, x, 2*z)
    """
    return tuple(sympy.diff(expression, _SYMBOLS[c]) for c in COORDINATES)


def axial_of(P: Sequence[Sequence[Any]]) -> tuple[Any, Any, Any]:
    """The axial vector ``J`` of a skew 3x3 ``P``: ``P v = v x J`` means ``J = (P[1][2], P[2][0], P[0][1])``."""
    return (P[1][2], P[2][0], P[0][1])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _curl(J):
    x, y, z = (_SYMBOLS[c] for c in COORDINATES)
    return (
        sympy.diff(J[2], y) - sympy.diff(J[1], z),
        sympy.diff(J[0], z) - sympy.diff(J[2], x),
        sympy.diff(J[1], x) - sympy.diff(J[0], y),
    )


def _residual(expressions, values):
    """The simplified residuals; those that do not vanish identically are retried at the parameter values."""
    residual = [sympy.simplify(e) for e in expressions]
    if any(r != 0 for r in residual) and values:
        exact = {sympy.Symbol(k, real=True): sympy.Rational(v) for k, v in values.items()}
        if all(sympy.simplify(r.subs(exact)) == 0 for r in residual):
            return [sympy.Integer(0)] * len(residual)
    return residual


def check_structure(
    grad_S: Sequence[Any],
    J: Sequence[Any] | None = None,
    P: Sequence[Sequence[Any]] | None = None,
    values: Mapping[str, float] | None = None,
    prefix: str = "",
) -> None:
    """Refuse a Poisson tensor that is not one, or an S that is not its Casimir.

    Checks symbolically (``sympy.simplify`` of each residual; an identity that
    holds only at the given parameter ``values`` is accepted):

    - ``P + P^T = 0`` (when ``P`` is given; then ``J = axial_of(P)``),
    - Jacobi ``J . curl J = 0``,
    - Casimir ``grad S x J = 0``.

    Raises ``ValueError`` naming the identity and showing its residual;
    ``prefix`` goes before the names in messages (``"system."`` in scenes).

    >>> x, y, z = sympy.symbols("x y z", real=True)
    >>> check_structure((0, 0, z), J=(x, y, 0))
    Traceback (most recent call last):
    ...
    ValueError: `S` is not a Casimir of J: grad S x J = 0 fails; the residual simplifies to [-y*z, x*z, 0]. ...
    """
    values = values or {}
    if P is not None:
        skew = _residual([P[i][j] + P[j][i] for i in range(3) for j in range(i, 3)], values)
        if any(r != 0 for r in skew):
            raise ValueError(
                f"`{prefix}P` is not skew: P + P^T = 0 fails; the residual (upper triangle, row by row) "
                f"simplifies to {skew}. Write P with P[j][i] = -P[i][j] and a zero diagonal."
            )
        J = axial_of(P)
    # with P given, J is its axial vector (P v = v x J): the messages say so
    of_p = f", the axial vector of `{prefix}P` (P v = v x J)," if P is not None else ""
    given = f"J{of_p}" if P is not None else f"`{prefix}J`"
    jacobi = _residual([sum(a * b for a, b in zip(J, _curl(J)))], values)[0]  # pyright: ignore[reportArgumentType]  # J or P given
    if jacobi != 0:
        raise ValueError(
            f"{given} fails Jacobi: J . curl J = 0 does not hold; the residual simplifies to {jacobi}. "
            "A J parallel to a gradient, J = f grad C, always satisfies it."
        )
    casimir = _residual(_cross(grad_S, J), values)
    if any(r != 0 for r in casimir):
        raise ValueError(
            f"`{prefix}S` is not a Casimir of J{of_p.rstrip(',')}: grad S x J = 0 fails; the residual simplifies "
            f"to {casimir}. J must be parallel to grad S everywhere."
        )


# -- 4. code generation and the disk cache ------------------------------------------------
class _NumbaPrinter(PythonCodePrinter):
    """Python source for numba: coordinates as ``x[i]``, parameters as ``p[i]``, ``math`` functions.

    Integers print as floats (``2.0``) except as exponents, so every value is a
    float64 and ``y**2`` stays an integer power (numba multiplies it out);
    rationals print as their nearest float (``0.5``).
    """

    def __init__(self, parameters):
        super().__init__({"fully_qualified_modules": True, "standard": "python3"})
        self.names = {
            **{c: f"x[{i}]" for i, c in enumerate(COORDINATES)},
            **{name: f"p[{i}]" for i, name in enumerate(parameters)},
        }

    def _print_Symbol(self, expr):
        return self.names[expr.name]

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"

    def _print_Rational(self, expr):
        return repr(expr.p / expr.q)  # int / int is correctly rounded

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Pow(self, expr, rational=False):
        if expr.exp.is_Integer and expr.exp > 0:
            return f"{self.parenthesize(expr.base, sympy.printing.precedence.PRECEDENCE['Pow'])}**{int(expr.exp)}"  # pyright: ignore[reportAttributeAccessIssue]
        return super()._print_Pow(expr, rational=rational)

    def _print_sign(self, expr):
        return f"numpy.sign({self._print(expr.args[0])})"


def source(
    H: sympy.Expr,
    grad_H: Sequence[sympy.Expr],
    S: sympy.Expr,
    grad_S: Sequence[sympy.Expr],
    poisson: Sequence[Any],
    poisson_form: str,
    parameters: Sequence[str],
) -> str:
    """The text of the generated module: functions ``H, grad_H, S, grad_S`` and ``J`` or ``P``.

    ``poisson`` is the axial vector (3 expressions) or the matrix (3x3) as
    ``poisson_form`` says (``"axial"`` / ``"matrix"``).
    """
    printer = _NumbaPrinter(parameters)
    code = printer.doprint
    vector = lambda v: "(" + ", ".join(code(c) for c in v) + ")"  # noqa: E731  # pyright: ignore[reportCallIssue, reportArgumentType]  # doprint gives str here
    lines = [
        f"# generated by geomint.expressions (generator {_GENERATOR_VERSION}); parameters p = {list(parameters)}",
        "import math",
        "import numpy",
        "from numba import njit",
        "",
    ]
    bodies = {"H": code(H), "grad_H": vector(grad_H), "S": code(S), "grad_S": vector(grad_S)}
    if poisson_form == "axial":
        bodies["J"] = vector(poisson)
    else:
        bodies["P"] = "numpy.array([" + ", ".join(f"[{', '.join(code(c) for c in row)}]" for row in poisson) + "])"  # pyright: ignore[reportCallIssue, reportArgumentType]
    for name, body in bodies.items():
        lines += ["", "@njit(cache=True)", f"def {name}(x, p):", f"    return {body}", ""]
    return "\n".join(lines)


def build(
    H: str,
    S: str,
    J: Sequence[str] | None = None,
    P: Sequence[Sequence[str]] | None = None,
    params: Mapping[str, float] | None = None,
    eps: float = 1.0,
    name: str = "expressions",
    prefix: str = "",
) -> dict[str, Any]:
    """The keyword arguments of ``MetriplecticSystem`` for a system given as formulas.

    Parameters
    ----------
    H, S : str
        Energy and Casimir, e.g. ``"(y**2 + z**2)/2 - r*z"``.
    J : 3 strings, optional
        Axial vector of the Poisson tensor, ``P v = v x J``.
    P : 3x3 strings, optional
        The Poisson tensor as a skew matrix (give exactly one of ``J`` and ``P``).
    params : dict {name: float}
        Parameters the formulas use; they reach the code as ``p[i]`` in this
        order, so one compilation serves every value.
    eps, name
        Passed on.
    prefix : str
        Goes before field names in errors (``"system."`` in scenes).

    Returns a dict for ``MetriplecticSystem(**kwargs)``.
    """
    values = check_parameters({} if params is None else params, f"{prefix}parameters" if prefix else "params")
    H_expr, S_expr, poisson = parse_system(H, S, J, P, list(values), prefix)
    form = "axial" if J is not None else "matrix"
    grad_H, grad_S = gradient(H_expr), gradient(S_expr)
    check_structure(
        grad_S,
        J=poisson if form == "axial" else None,
        P=poisson if form == "matrix" else None,
        values=values,
        prefix=prefix,
    )
    module = compile_functions(source(H_expr, grad_H, S_expr, grad_S, poisson, form, list(values)))
    kwargs = {
        "H": module.H,
        "grad_H": module.grad_H,
        "S": module.S,
        "grad_S": module.grad_S,
        "eps": eps,
        "params": list(values.values()),
        "name": name,
    }
    kwargs["J" if form == "axial" else "P"] = module.J if form == "axial" else module.P
    return kwargs


def parse_system(
    H: str,
    S: str,
    J: Sequence[str] | None,
    P: Sequence[Sequence[str]] | None,
    parameters: Sequence[str],
    prefix: str = "",
) -> tuple[sympy.Expr, sympy.Expr, tuple[Any, ...]]:
    """``(H, S, J or P)`` as sympy expressions (grammar only: no derivatives, no checks).

    Exactly one of ``J`` (3 formulas) and ``P`` (3x3 formulas) is given;
    errors name the field with ``prefix`` before it (``system.J[1]``).
    """
    if (J is None) == (P is None):
        raise ValueError(
            f"give exactly one of `{prefix}J` (3 formulas, axial vector) and `{prefix}P` (3x3 formulas, skew matrix)."
        )
    H_expr, S_expr = parse(f"{prefix}H", H, parameters), parse(f"{prefix}S", S, parameters)
    if J is not None:
        return (
            H_expr,
            S_expr,
            tuple(parse(f"{prefix}J[{i}]", c, parameters) for i, c in enumerate(_triple(f"{prefix}J", J))),
        )
    rows = _triple(f"{prefix}P", P)
    return (
        H_expr,
        S_expr,
        tuple(
            tuple(parse(f"{prefix}P[{i}][{j}]", c, parameters) for j, c in enumerate(_triple(f"{prefix}P[{i}]", row)))
            for i, row in enumerate(rows)
        ),
    )


def _triple(field, value):
    if isinstance(value, str) or not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"`{field}` must be a list of 3 formulas; got {value!r}.")
    return value
