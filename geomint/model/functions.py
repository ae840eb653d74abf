"""The user's numba functions: their types checked, their shapes probed, handed to kernels as first-class functions.

Every user function has the signature ``(x, params)`` with ``x`` and
``params`` contiguous float64 arrays.  A function is compiled for that
signature once, here; its return type decides the compiled kernel variant
(3-tuples or arrays, an axial vector ``J`` or a matrix ``P``).  What numba
compiles for a function a later process can name again (a module-level
function, ``geomint.model.identity``) is kept in geomint's cache folder
(:func:`compiled`): that process loads it instead of compiling it again.  Under
``NUMBA_DISABLE_JIT=1`` plain Python functions are taken as they are.

In R^n (``dim`` given) vectors are float64 arrays of length n and matrices
(n, n) float64 arrays; the messages then show examples for any n.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numba
import numpy as np
from numba.core.dispatcher import Dispatcher
from numba.core.errors import NumbaWarning

from .._cache import CACHE, keep_compiled
from .checks import SAMPLES
from .identity import function_key, unseen_part

if TYPE_CHECKING:
    import numpy.typing as npt

_VECTOR = numba.types.float64[::1]
SIGNATURE = (_VECTOR, _VECTOR)
#: an operator given as an action: ``(x, v, params) -> P(x) v``
ACTION_SIGNATURE = (_VECTOR, _VECTOR, _VECTOR)
_SCALAR_TYPES = (numba.types.float64,)
_VECTOR_FORMS = {
    numba.types.UniTuple(numba.types.float64, 3): "tuple",
    numba.types.float64[::1]: "array",
}
_MATRIX_TYPE = numba.types.float64[:, ::1]
#: per user function: what it returns and the body of an example (the relaxing rigid body's)
_EXAMPLES = {
    "H": ("a float", "0.5 * (params[0] * x[0]**2 + params[1] * x[1]**2 + params[2] * x[2]**2)"),
    "grad_H": (
        "a 3-tuple of floats (fastest) or a float64 array",
        "(params[0] * x[0], params[1] * x[1], params[2] * x[2])",
    ),
    "S": ("a float", "0.5 * (x[0]**2 + x[1]**2 + x[2]**2)"),
    "grad_S": ("a 3-tuple of floats (fastest) or a float64 array", "(x[0], x[1], x[2])"),
    "J": ("a 3-tuple of floats (fastest) or a float64 array", "(x[0], x[1], x[2])"),
    "P": ("a (3, 3) float64 array", "np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])"),
}


_SQUARE = "np.zeros((x.shape[0], x.shape[0]))"
#: the same for a system in R^n (``dim`` given): arrays of any length n, and GENERIC's names
_EXAMPLES_N = {
    "H": ("a float", "0.5 * np.sum(x * x)"),
    "E": ("a float", "0.5 * np.sum(x * x)"),
    "S": ("a float", "0.5 * x[0] * x[0]"),
    "grad_H": ("a contiguous float64 array of length n", "x.copy()"),
    "grad_E": ("a contiguous float64 array of length n", "x.copy()"),
    "grad_S": ("a contiguous float64 array of length n", "np.zeros(x.shape[0])"),
    "P": ("an (n, n) contiguous float64 array", _SQUARE),
    "L": ("an (n, n) contiguous float64 array", _SQUARE),
    "M": ("an (n, n) contiguous float64 array", _SQUARE),
    "metric": ("an (n, n) contiguous float64 array", _SQUARE),
}
_ACTION_EXAMPLE = "np.zeros(x.shape[0])  # P(x) v, without forming P"


def _how_to_jit(name, dim=None):
    """How to write the user function ``name`` (``H``, ``grad_H``, ``S``, ``grad_S``, ``J``, ``P``; in R^n,
    ``dim`` given, also ``E``, ``grad_E``, ``L``, ``M``, ``metric``) for numba, with an example of that very
    function."""
    table = _EXAMPLES if dim is None else _EXAMPLES_N
    returns, body = table.get(name, table["grad_H"])
    return (
        f"Write it as a numba function of (x, params), e.g.\n    @numba.njit\n    def {name}(x, params):\n"
        f"        return {body}\nwith x and params float64 arrays; `{name}` returns {returns}."
    )


@dataclass(frozen=True)
class ModelFunctions:
    """The jitted user functions of a system, all of signature ``(x, params)``.

    ``poisson`` is ``J`` (axial vector) or ``P`` (3x3 matrix) as given.
    ``vector_form`` is ``"tuple"`` or ``"array"`` (``"python"`` under
    ``NUMBA_DISABLE_JIT=1``); ``poisson_form`` is
    ``"axial"`` or ``"matrix"``.
    """

    H: Callable
    grad_H: Callable
    S: Callable
    grad_S: Callable
    poisson: Callable
    vector_form: str
    poisson_form: str


def _how_to_jit_action(name):
    return (
        f"Write it as a numba function of (x, v, params), e.g.\n    @numba.njit\n    def {name}(x, v, params):\n"
        f"        return {_ACTION_EXAMPLE}\nwith x, v and params float64 arrays; `{name}` returns a contiguous "
        "float64 array of length n."
    )


def compiled(fn: Dispatcher, signature: tuple) -> Any:
    """``fn``'s compilation for ``signature`` (numba's ``CompileResult``).  Where a later process can name ``fn``
    again (``identity.function_key``), numba keeps the code in geomint's cache folder (``_cache.keep_compiled``)
    and that process loads it: tens of milliseconds a function saved, a tenth of a second or more for the first
    one of a process.  Where numba cannot keep it (a function holding a ctypes pointer, a large array), it is
    compiled in every process as before, without numba's warning: the user did not ask for a cache."""
    key = function_key(fn)
    if key is not None:
        keep_compiled(fn, unseen_part(key))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Cannot cache compiled function", category=NumbaWarning)
        fn.compile(signature)
    return fn.overloads[signature]


def _compiled_return_type(name, fn, dim=None, signature=SIGNATURE):
    action = signature is ACTION_SIGNATURE
    how = _how_to_jit_action(name) if action else _how_to_jit(name, dim)
    arguments = "(x, v, params)" if action else "(x, params)"
    if numba.config.DISABLE_JIT:  # pyright: ignore[reportPrivateImportUsage, reportAttributeAccessIssue]
        if not callable(fn):
            raise TypeError(f"`{name}` must be a function of {arguments}; got {type(fn).__name__}.")
        return None
    if not isinstance(fn, Dispatcher):
        raise TypeError(f"`{name}` must be a numba-jitted function; got {fn!r}. {how}")
    try:
        result = compiled(fn, signature)
    except Exception as exc:
        raise TypeError(
            f"`{name}` does not compile for {arguments} with float64 arrays: "
            f"{type(exc).__name__}: {str(exc).splitlines()[0]}. {how}"
        ) from exc
    return result.signature.return_type


def scalar_function(name: str, fn: Any, dim: int | None = None) -> Any:
    """``fn`` if it compiles for ``(x, params)`` and returns a float64, else a ``TypeError`` saying how to write it
    (for a system in R^dim when ``dim`` is given)."""
    rtype = _compiled_return_type(name, fn, dim)
    if rtype is not None and rtype not in _SCALAR_TYPES:
        raise TypeError(f"`{name}` must return a float64; it returns {rtype}. {_how_to_jit(name, dim)}")
    return fn


def vector_function(name: str, fn: Any) -> str:
    """The vector form ``fn`` returns (``"tuple"``, ``"array"``, or ``"python"`` without numba), else a
    ``TypeError``."""
    rtype = _compiled_return_type(name, fn)
    if rtype is None:  # NUMBA_DISABLE_JIT=1: plain Python, any sequence of 3 floats will do
        return "python"
    if rtype not in _VECTOR_FORMS:
        raise TypeError(
            f"`{name}` must return a 3-tuple of floats or a contiguous float64 array; it returns {rtype}. "
            f"{_how_to_jit(name)}"
        )
    return _VECTOR_FORMS[rtype]


def array_function(name: str, fn: Any, dim: int) -> Any:
    """``fn`` if it compiles for ``(x, params)`` and returns a contiguous float64 array (a vector in R^dim; its
    length is probed by ``check_returned_shapes``), else a ``TypeError`` saying how to write it."""
    rtype = _compiled_return_type(name, fn, dim)
    if rtype is not None and rtype != _VECTOR:
        raise TypeError(
            f"`{name}` must return a contiguous float64 array of length n = {dim}; it returns {rtype}. "
            f"{_how_to_jit(name, dim)}"
        )
    return fn


def matrix_function(name: str, fn: Any, dim: int | None = None) -> Any:
    """``fn`` if it compiles for ``(x, params)`` and returns a contiguous float64 matrix ((3, 3), or (dim, dim)
    when ``dim`` is given), else a ``TypeError``."""
    rtype = _compiled_return_type(name, fn, dim)
    if rtype is not None and rtype != _MATRIX_TYPE:
        shape = "a (3, 3)" if dim is None else f"an (n, n) = ({dim}, {dim})"
        advice = "" if dim is None else f" {_how_to_jit(name, dim)}"
        raise TypeError(f"`{name}` must return {shape} contiguous float64 array; it returns {rtype}.{advice}")
    return fn


def action_function(name: str, fn: Any, dim: int) -> Any:
    """``fn`` if it compiles for ``(x, v, params)`` and returns a contiguous float64 array (``P(x) v`` in R^dim;
    its length is probed by ``check_returned_shapes``), else a ``TypeError`` saying how to write it."""
    rtype = _compiled_return_type(name, fn, dim, ACTION_SIGNATURE)
    if rtype is not None and rtype != _VECTOR:
        raise TypeError(
            f"`{name}` must return a contiguous float64 array of length n = {dim}; it returns {rtype}. "
            f"{_how_to_jit_action(name)}"
        )
    return fn


def check_returned_shapes(
    wanted: dict[str, tuple[Callable, tuple[int, ...]]], x: npt.NDArray[np.float64], params: npt.NDArray[np.float64]
) -> None:
    """Each function of ``wanted`` (``{name: (fn, shape)}``) returns an array of its shape at the state ``x``: an
    array's type does not carry its length, and the kernels would read past a shorter one.  An action (``fn``
    of ``(x, v, params)``, marked by ``shape`` ending in ``"action"``) is applied to ``v = x``."""
    for name, (fn, shape) in wanted.items():
        action = shape[-1] == "action"
        shape = shape[:-1] if action else shape
        try:
            value = fn(x.copy(), x.copy(), params) if action else fn(x.copy(), params)
        except Exception:  # noqa: BLE001 - undefined at this point is the structure check's business
            continue
        if np.shape(value) != shape:
            shown = x.tolist() if x.size <= 8 else f"{np.array2string(x, threshold=8, precision=6)} (n = {x.size})"
            raise ValueError(f"`{name}` must return shape {shape}; at x = {shown} it returned shape {np.shape(value)}.")


def check_shapes(functions: ModelFunctions, params: npt.NDArray[np.float64]) -> None:
    """Array-returning functions give 3 values (P a 3x3 matrix) at a sample point: their type cannot
    say so, and the kernels would read past a shorter array."""
    wanted: dict[str, tuple[Callable, tuple[int, ...]]] = {
        "grad_H": (functions.grad_H, (3,)),
        "grad_S": (functions.grad_S, (3,)),
    }
    wanted["P" if functions.poisson_form == "matrix" else "J"] = (
        functions.poisson,
        (3, 3) if functions.poisson_form == "matrix" else (3,),
    )
    check_returned_shapes(wanted, SAMPLES[0], params)


@dataclass(frozen=True)
class ModelFunctionsN:
    """The jitted user functions of a system in R^n, by their role in ``dx/dt = P grad H + eps D grad S``:
    GENERIC's E, grad_E and L are ``H``, ``grad_H`` and ``P`` here.  ``M`` is the user's metric (Fish form's G,
    GENERIC's friction matrix), None where the paper's metric g is used.  Each operator is given either as a
    matrix function of ``(x, params)`` (``P``, ``M``) or as an action of ``(x, v, params)`` (``P_apply``,
    ``M_apply``), the other None."""

    H: Callable
    grad_H: Callable
    S: Callable
    grad_S: Callable
    P: Callable | None
    M: Callable | None
    P_apply: Callable | None = None
    M_apply: Callable | None = None


@numba.njit(cache=CACHE)
def no_metric(x, params):
    """The placeholder for ``ModelN.M`` where the paper's metric is used (never called): an (n, n) zero matrix, of
    the type a user's metric has."""
    n = x.shape[0]
    return np.zeros((n, n))


@numba.njit(cache=CACHE)
def no_action(x, v, params):
    """The placeholder for ``ModelN.P_apply`` / ``M_apply`` where the operator is given as a matrix (never
    called): a zero vector of length n, of the type an action has."""
    return np.zeros(x.shape[0])
