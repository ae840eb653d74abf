"""The metriplectic system: energy, Casimir, Poisson tensor and the perturbation eps.

In R^3 every Poisson tensor acts as ``P v = v x J(x)`` for an axial vector field
``J``; S is a Casimir when ``grad S x J = 0``.  Following Fish (paper section 1),
the metric ``g = grad H (x) grad H - I |grad H|^2`` turns the Hamiltonian system
into

    dx/dt = xi_P + eps xi_g,   xi_P = grad H x J,   xi_g = grad H x (grad H x grad S),

along which ``dH/dt = 0`` and ``dS/dt = -eps |sigma|^2``, ``sigma = grad S x grad H``.
"""

from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np
from numba.core.dispatcher import Dispatcher
from numba.core.types.function_type import CompileResultWAP

from .. import _user_errors, _validate
from .._kernels import field as _field
from .._kernels.layout import Model

_VECTOR = numba.types.float64[::1]
_SIGNATURE = (_VECTOR, _VECTOR)
_SCALAR_TYPES = (numba.types.float64,)
_VECTOR_FORMS = {
    numba.types.UniTuple(numba.types.float64, 3): "tuple",
    numba.types.float64[::1]: "array",
}
_MATRIX_TYPE = numba.types.float64[:, ::1]
#: per user function: what it returns and the body of an example (the relaxing rigid body's)
_EXAMPLES = {
    "H": ("a float", "0.5 * (params[0] * x[0]**2 + params[1] * x[1]**2 + params[2] * x[2]**2)"),
    "grad_H": ("a 3-tuple of floats (fastest) or a float64 array", "(params[0] * x[0], params[1] * x[1], params[2] * x[2])"),
    "S": ("a float", "0.5 * (x[0]**2 + x[1]**2 + x[2]**2)"),
    "grad_S": ("a 3-tuple of floats (fastest) or a float64 array", "(x[0], x[1], x[2])"),
    "J": ("a 3-tuple of floats (fastest) or a float64 array", "(x[0], x[1], x[2])"),
    "P": ("a (3, 3) float64 array", "np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])"),
}


def _how_to_jit(name):
    """How to write the user function ``name`` (``H``, ``grad_H``, ``S``, ``grad_S``, ``J``, ``P``) for numba,
    with an example of that very function."""
    returns, body = _EXAMPLES.get(name, _EXAMPLES["grad_H"])
    return (f"Write it as a numba function of (x, params), e.g.\n    @numba.njit\n    def {name}(x, params):\n"
            f"        return {body}\nwith x and params float64 arrays; `{name}` returns {returns}.")


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


class MetriplecticSystem:
    """A metriplectic system in R^3 (paper eq. (sys), with the perturbation eps).

    Parameters
    ----------
    H, grad_H : numba-jitted functions ``(x, params) -> float`` / ``-> 3-vector``
        The energy (conserved) and its gradient.
    S, grad_S : numba-jitted functions
        The Casimir (dissipated) and its gradient.
    J : numba-jitted function ``(x, params) -> 3-vector``, optional
        Axial vector of the Poisson tensor, ``P v = v x J``.  Jacobi requires
        ``J . curl J = 0``; S must be a Casimir, ``grad S x J = 0``.
    P : numba-jitted function ``(x, params) -> (3, 3) float64 array``, optional
        The Poisson tensor as a skew matrix (give exactly one of J and P).
    eps : float, default 1.0
        The perturbation parameter, ``eps >= 0`` (0: the Hamiltonian system).
    params : sequence of float
        Passed to every function; model parameters belong here, not in globals.
    name : str
        A label for reports.
    exact_flows : dict, optional
        Exact or explicit Hamiltonian sub-flows the system admits, by name, with
        their data: ``{"rigid_body_flow": (a, b, c)}`` for ``H = (a x^2 + b y^2 + c z^2)/2``
        with ``J = m`` (``geomint.RigidBodyFlow``); ``{"rotor_splitting": ()}`` for a
        separable H with ``J = m`` (``geomint.RotorSplitting``);
        ``{"oscillator_rotation": ()}`` for ``H = |x|^2/2`` with a constant J
        (``geomint.OscillatorRotation``).  Checked at sample points like the
        structure; a declaration that does not hold raises ``ValueError``.
    check : bool, default True
        Check at a few sample points that the gradients match finite differences
        of H and S, that S is a Casimir of J and that J satisfies Jacobi (and P is
        skew); a violation raises ``ValueError``.

    Vector results may be 3-tuples (no allocation; about 6x cheaper per call in
    a compiled loop) or float64 arrays; grad_H, grad_S and J must use the same
    form.  Every method below accepts one state ``(3,)`` or many ``(n, 3)``.

    Examples
    --------
    >>> import numba, geomint
    >>> @numba.njit
    ... def H(x, p): return 0.5 * (x[0]**2 + x[1]**2 + x[2]**2)
    >>> @numba.njit
    ... def grad_H(x, p): return (x[0], x[1], x[2])
    >>> @numba.njit
    ... def S(x, p): return 0.5 * x[2]**2
    >>> @numba.njit
    ... def grad_S(x, p): return (0.0, 0.0, x[2])
    >>> @numba.njit
    ... def J(x, p): return (0.0, 0.0, 1.0)
    >>> system = geomint.MetriplecticSystem(H=H, grad_H=grad_H, S=S, grad_S=grad_S, J=J)
    >>> system.dS_dt([0.6, 0.0, 0.8]).round(3)
    np.float64(-0.23)
    """

    def __init__(self, *, H, grad_H, S, grad_S, J=None, P=None, eps=1.0, params=(), name="custom", exact_flows=None,
                 check=True):
        if (J is None) == (P is None):
            raise ValueError("give exactly one of `J` (axial vector) and `P` (skew matrix) for the Poisson tensor.")
        self.eps = _check_eps(eps)
        self.hamiltonian = True
        self._params = _validate.reals("params", params)
        self.name = str(name)
        scalar = {key: _scalar_function(key, fn) for key, fn in (("H", H), ("S", S))}
        forms = {key: _vector_function(key, fn) for key, fn in (("grad_H", grad_H), ("grad_S", grad_S))}
        if J is not None:
            forms["J"] = _vector_function("J", J)
        else:
            _matrix_function("P", P)
        if len(set(forms.values())) != 1:
            listed = ", ".join(f"`{k}` returns a {v}" for k, v in forms.items())
            raise TypeError(f"grad_H, grad_S and J must return the same kind of vector; {listed}. Make them all tuples.")
        self.functions = ModelFunctions(
            H=scalar["H"], grad_H=grad_H, S=scalar["S"], grad_S=grad_S,
            poisson=J if J is not None else P,
            vector_form=forms["grad_H"], poisson_form="axial" if J is not None else "matrix",
        )
        _check_shapes(self.functions, self._params)
        self.exact_flows = _check_exact_flows(exact_flows)
        if check:
            with np.errstate(all="ignore"):  # finite differences of huge values overflow: the checks see inf/nan
                _check_structure(self)
                for flow, data in self.exact_flows.items():
                    _EXACT_FLOW_CHECKS[flow](self, data)

    # -- the model as kernels receive it ------------------------------------------------
    @property
    def model(self):
        """``layout.Model(H, grad_H, S, grad_S, J or P, params, origin)``: the model as every kernel receives it.

        The functions are handed over as compiled first-class function objects
        (their machine addresses, looked up once), not as dispatchers, which
        numba would resolve anew at every kernel call.  Their types (tuple or
        array results, J or P) select the compiled kernel variant.  ``origin``
        holds H, grad H, S and grad S at 0 (0 where not finite): the kernels
        measure the constant and linear terms of H and S from it, the terms
        whose round-off ``x . grad F`` does not show.
        """
        if "_model" not in self.__dict__:
            f = self.functions
            self._model = Model(*(_first_class(fn) for fn in (f.H, f.grad_H, f.S, f.grad_S, f.poisson)), self._params,
                                self._origin())
        return self._model

    def _origin(self, params=None):
        """H, grad H, S, grad S at 0 (0 where not finite or raising), with ``params`` (default: the system's)."""
        f, p, zero = self.functions, self._params if params is None else params, np.zeros(3)
        values = []
        for value, gradient in ((f.H, f.grad_H), (f.S, f.grad_S)):
            try:
                with np.errstate(all="ignore"):
                    values += [float(value(zero, p)), *_components(gradient(zero, p))]
            except Exception:  # noqa: BLE001 - singular at 0 (log |x|, 1/|x| ...): no such terms to measure
                values += [0.0] * 4
        origin = np.array(values, dtype=np.float64)
        origin[~np.isfinite(origin)] = 0.0
        return origin

    @property
    def params(self):
        """A copy of the parameter vector."""
        return self._params.copy()

    def with_effects(self, *, hamiltonian=None, eps=None, params=None):
        """The same system with the Hamiltonian part switched on/off, another eps and/or other params.

        ``hamiltonian=False`` leaves the gradient system ``dx/dt = eps xi_g``
        (its kernels never call ``J``); ``eps=0`` leaves the Hamiltonian system
        (its fields never call ``grad_S``).  ``params`` (as many numbers as the
        system has) is checked as at construction: shapes, and that S is still a
        Casimir of the Poisson tensor.
        """
        other = object.__new__(MetriplecticSystem)
        other.__dict__.update(self.__dict__)
        if params is not None:
            values = _validate.reals("params", params)
            if values.shape != self._params.shape:
                raise ValueError(f"`params` must have {self._params.size} values, as the system's; got "
                                 f"{values.size}: {values.tolist()}.")
            other._params = values
            other.__dict__.pop("_model", None)
            _check_shapes(other.functions, values)
            with np.errstate(all="ignore"):
                _check_structure(other)
        if hamiltonian is not None:
            if not isinstance(hamiltonian, (bool, np.bool_)):
                raise TypeError(f"`hamiltonian` must be True or False; got {hamiltonian!r}.")
            other.hamiltonian = bool(hamiltonian)
        if eps is not None:
            other.eps = _check_eps(eps)
        return other

    def __getstate__(self):
        """Pickled without the compiled model (function addresses of this process), rebuilt on first use: a
        system can be shipped to other processes (Dask workers)."""
        state = dict(self.__dict__)
        state.pop("_model", None)
        return state

    def __repr__(self):
        effects = "" if self.hamiltonian else ", hamiltonian=False"
        return f"MetriplecticSystem(name={self.name!r}, eps={self.eps!r}{effects}, params={self.params.tolist()!r})"

    # -- evaluation at one state or many ------------------------------------------------
    def _evaluate(self, x):
        """``(H, S, grad H, grad S, J)`` at many states (n, 3), from one compiled loop: arrays."""
        X = np.ascontiguousarray(np.atleast_2d(_states(x)))
        if X.ndim != 2 or X.shape[1] != 3:
            raise ValueError(f"`x` must have shape (3,) or (n, 3); got shape {np.shape(x)}.")
        n = X.shape[0]
        out = (np.empty(n), np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)))
        with _user_errors.catching() as raised:
            _field.evaluate(self.model, X, *out)
        if raised:  # find the state and the function: the direct calls raise where the kernel's could not
            for row in X:
                self._at_one(row, range(5))
            raise raised[0]
        return out

    def _at(self, x, which):
        """The functions ``which`` (indices into H, S, grad H, grad S, J) at ``x``: scalars, and vectors as
        3-tuples of components, floats for one state (3,) and arrays for many (n, 3); ``_array`` makes
        arrays of them.  The same formulas then serve both."""
        X = _states(x)
        if X.shape == (3,):
            return self._at_one(X if X.flags.c_contiguous else np.ascontiguousarray(X), which)
        values = self._evaluate(X)
        return tuple(values[i] if i < 2 else tuple(values[i].T) for i in which)

    def _at_one(self, x, which):
        """One state: only the user functions asked for, each called once directly (no kernel dispatch,
        ~0.5 us a call)."""
        f, p = self.functions, self._params
        functions = (f.H, f.S, f.grad_H, f.grad_S, f.poisson)
        try:
            values = [functions[i](x, p) for i in which]
        except Exception:
            self._name_the_raising_function(x)
        return [float(v) if i < 2 else v if type(v) is tuple else _components(v) for i, v in zip(which, values)]

    def _name_the_raising_function(self, x):
        """Re-raise the exception being handled as a ``UserFunctionError`` naming the user function (as is
        if none raises on a second try)."""
        found = self.raising_function(x)
        if found is None:
            raise
        raise _user_errors.UserFunctionError(found[0], x.tolist(), found[1]) from found[1]

    def _xi_one(self, x):
        """``xi`` at one state (a contiguous (3,) array): the path a scipy right-hand side takes, the three
        user calls made directly (~3 us; ``_at_one``'s general bookkeeping costs ~1.5 us more)."""
        f, p, eps = self.functions, self._params, self.eps
        try:
            gh, gs = f.grad_H(x, p), f.grad_S(x, p)
            j = f.poisson(x, p) if self.hamiltonian else None
        except Exception:
            self._name_the_raising_function(x)
        gh = gh if type(gh) is tuple else _components(gh)
        gs = gs if type(gs) is tuple else _components(gs)
        if j is not None and type(j) is not tuple:
            j = _components(j)
        return np.array(_xi_of(gh, gs, j, eps))

    def raising_function(self, x):
        """``(name, exception)`` of the first user function that raises at ``x``, or None if none does."""
        f, p = self.functions, self._params
        x = np.array(x, dtype=np.float64)
        names = ("H", "S", "grad_H", "grad_S", "P" if f.poisson_form == "matrix" else "J")
        for name, fn in zip(names, (f.H, f.S, f.grad_H, f.grad_S, f.poisson)):
            try:
                fn(x.copy(), p)
            except Exception as error:  # noqa: BLE001 - any exception of the user's is the answer
                return name, error
        return None

    def H(self, x):
        """Energy at ``x``."""
        return self._at(x, (_H,))[0]

    def S(self, x):
        """Casimir (entropy-like function) at ``x``."""
        return self._at(x, (_S,))[0]

    def grad_H(self, x):
        return _array(self._at(x, (_GRAD_H,))[0])

    def grad_S(self, x):
        return _array(self._at(x, (_GRAD_S,))[0])

    def J(self, x):
        """Axial vector of the Poisson tensor, ``P v = v x J``."""
        return _array(self._at(x, (_J,))[0])

    def xi_P(self, x):
        """Hamiltonian field ``grad H x J``."""
        gh, j = self._at(x, (_GRAD_H, _J))
        return _array(_cross(gh, j))

    def xi_g(self, x):
        """Gradient field ``g grad S = grad H x (grad H x grad S)`` (without eps)."""
        gh, gs = self._at(x, (_GRAD_H, _GRAD_S))
        return _array(_cross(gh, _cross(gh, gs)))

    def xi(self, x):
        """The field ``xi_P + eps xi_g`` (without ``xi_P`` when the Hamiltonian part is off)."""
        X = _states(x)
        if X.shape == (3,):
            return self._xi_one(X if X.flags.c_contiguous else np.ascontiguousarray(X))
        if self.hamiltonian:
            gh, gs, j = self._at(X, (_GRAD_H, _GRAD_S, _J))
        else:
            (gh, gs), j = self._at(X, (_GRAD_H, _GRAD_S)), None
        return _array(_xi_of(gh, gs, j, self.eps))

    def g(self, x):
        """The metric ``grad H (x) grad H - I |grad H|^2``, shape (3, 3) or (n, 3, 3)."""
        gh = self.grad_H(x)
        outer = gh[..., :, None] * gh[..., None, :]
        return outer - np.eye(3) * np.sum(gh * gh, axis=-1)[..., None, None]

    def sigma(self, x):
        """``sigma = grad S x grad H``; ``dS/dt = -eps |sigma|^2``."""
        gh, gs = self._at(x, (_GRAD_H, _GRAD_S))
        return _array(_cross(gs, gh))

    def dS_dt(self, x):
        """Rate of change of S along the flow, ``-eps |sigma|^2``."""
        s = self.sigma(x)
        return -self.eps * np.sum(s * s, axis=-1)

    @classmethod
    def from_expressions(cls, *, H, S, J=None, P=None, params=None, eps=1.0, name="expressions"):
        """A system from formulas (strings), e.g. ``H="(y**2 + z**2)/2 - r*z"``, ``J=("-x", "0", "sigma")``.

        Text is parsed by a whitelist grammar (never evaluated), gradients are exact, the
        structure is checked symbolically, and generated numba code is cached on disk:
        see ``geomint.expressions.build`` for the grammar and every argument.
        """
        from . import expressions

        system = cls(**expressions.build(H=H, S=S, J=J, P=P, params=params, eps=eps, name=name))
        poisson = {"J": list(J)} if J is not None else {"P": [list(row) for row in P]}
        system.expressions = {"H": H, "S": S, **poisson, "params": dict(params or {})}  # for saved results
        return system


#: indices of the user functions in ``MetriplecticSystem._at``
_H, _S, _GRAD_H, _GRAD_S, _J = range(5)


def _states(x):
    """``x`` as a float64 array, or a TypeError naming ``x``."""
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"`x` must be a state of 3 real numbers, or an (n, 3) array of them; got {x!r}.") from None


def _components(v):
    """A user function's vector (3-tuple or array; a 3x3 ``P`` gives its axial vector) as a 3-tuple of floats."""
    if type(v) is tuple:
        return v
    a = np.asarray(v, dtype=np.float64)
    if a.shape == (3, 3):
        return (float(a[1, 2]), -float(a[0, 2]), float(a[0, 1]))
    return tuple(a.reshape(3).tolist())


def _cross(u, v):
    """``u x v`` on 3-tuples of components (floats, or arrays over states): plain arithmetic, because
    ``np.cross`` costs ~10 us on one pair."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _xi_of(gh, gs, j, eps):
    """``grad H x J + eps grad H x (grad H x grad S)`` on 3-tuples of components (floats for one state, arrays
    for many; ``j`` None: without the first term).  Written out once for both: on one state this arithmetic
    and the user calls are all ``xi`` costs."""
    a = (gh[1] * gs[2] - gh[2] * gs[1], gh[2] * gs[0] - gh[0] * gs[2], gh[0] * gs[1] - gh[1] * gs[0])
    d = (gh[1] * a[2] - gh[2] * a[1], gh[2] * a[0] - gh[0] * a[2], gh[0] * a[1] - gh[1] * a[0])
    if j is None:
        return (0.0 + eps * d[0], 0.0 + eps * d[1], 0.0 + eps * d[2])
    return (gh[1] * j[2] - gh[2] * j[1] + eps * d[0], gh[2] * j[0] - gh[0] * j[2] + eps * d[1],
            gh[0] * j[1] - gh[1] * j[0] + eps * d[2])


def _array(v):
    """A 3-tuple of components as an array: (3,) for floats, (n, 3) for arrays over states."""
    return np.array(v, dtype=np.float64) if isinstance(v[0], float) else np.stack(v, axis=-1)


# -- validation of the user's functions (the boundary) --------------------------------
def _compiled_return_type(name, fn):
    if numba.config.DISABLE_JIT:
        if not callable(fn):
            raise TypeError(f"`{name}` must be a function of (x, params); got {type(fn).__name__}.")
        return None
    if not isinstance(fn, Dispatcher):
        raise TypeError(f"`{name}` must be a numba-jitted function; got {fn!r}. {_how_to_jit(name)}")
    try:
        fn.compile(_SIGNATURE)
    except Exception as exc:
        raise TypeError(
            f"`{name}` does not compile for (x, params) with float64 arrays: "
            f"{type(exc).__name__}: {str(exc).splitlines()[0]}. {_how_to_jit(name)}"
        ) from exc
    return fn.overloads[_SIGNATURE].signature.return_type


def _first_class(fn):
    """A jitted user function as a first-class function object for the kernels."""
    if numba.config.DISABLE_JIT:
        return fn
    if _SIGNATURE not in fn.overloads:  # a system unpickled in another process (a Dask worker)
        fn.compile(_SIGNATURE)
    return CompileResultWAP(fn.overloads[_SIGNATURE])


def _scalar_function(name, fn):
    rtype = _compiled_return_type(name, fn)
    if rtype is not None and rtype not in _SCALAR_TYPES:
        raise TypeError(f"`{name}` must return a float64; it returns {rtype}. {_how_to_jit(name)}")
    return fn


def _vector_function(name, fn):
    rtype = _compiled_return_type(name, fn)
    if rtype is None:  # NUMBA_DISABLE_JIT=1: plain Python, any sequence of 3 floats will do
        return "python"
    if rtype not in _VECTOR_FORMS:
        raise TypeError(
            f"`{name}` must return a 3-tuple of floats or a contiguous float64 array; it returns {rtype}. {_how_to_jit(name)}"
        )
    return _VECTOR_FORMS[rtype]


def _matrix_function(name, fn):
    rtype = _compiled_return_type(name, fn)
    if rtype is not None and rtype != _MATRIX_TYPE:
        raise TypeError(f"`{name}` must return a (3, 3) contiguous float64 array; it returns {rtype}.")


def _check_shapes(functions, params):
    """Array-returning functions give 3 values (P a 3x3 matrix) at a sample point: their type cannot
    say so, and the kernels would read past a shorter array."""
    wanted = {"grad_H": (functions.grad_H, (3,)), "grad_S": (functions.grad_S, (3,))}
    wanted["P" if functions.poisson_form == "matrix" else "J"] = (
        functions.poisson, (3, 3) if functions.poisson_form == "matrix" else (3,))
    for name, (fn, shape) in wanted.items():
        x = _SAMPLES[0].copy()
        try:
            value = fn(x, params)
        except Exception:  # noqa: BLE001 - undefined at this point is the structure check's business
            continue
        if np.shape(value) != shape:
            raise ValueError(f"`{name}` must return shape {shape}; at x = {x.tolist()} it returned shape "
                             f"{np.shape(value)}.")


def _check_eps(eps):
    value = _validate.real("eps", eps)
    if not np.isfinite(value) or value < 0.0:
        raise ValueError(f"`eps` must be finite and >= 0; got {eps!r}.")
    return value


# -- structural checks at sample points ----------------------------------------------
_SAMPLES = np.random.default_rng(20261121).uniform(-1.0, 1.0, size=(6, 3))


def _check_structure(system):
    """Gradients vs finite differences, Casimir ``grad S x J = 0``, Jacobi, skew P, at sample points."""
    try:
        _check_samples(system)
    except _user_errors.UserFunctionError as error:
        raise _user_errors.UserFunctionError(
            error.function, error.x, error.__cause__,
            "The structure checks evaluate the functions at sample points in [-1, 1]^3 and 1e-6 around them: "
            "return NaN where a function is undefined there, or pass check=False.") from error.__cause__


def _check_samples(system):
    H, S, grad_H, grad_S, J = system._evaluate(_SAMPLES)
    finite = np.isfinite(H) & np.isfinite(S) & np.all(np.isfinite(np.hstack([grad_H, grad_S, J])), axis=1)
    points = _SAMPLES[finite]
    if points.size == 0:
        return
    step = 1e-6
    for label, values, grads in (("grad_H", H, grad_H), ("grad_S", S, grad_S)):
        fd = np.stack(
            [(_fn_values(system, points + step * e, label) - _fn_values(system, points - step * e, label)) / (2 * step)
             for e in np.eye(3)], axis=1)
        # central differences carry round-off ~ eps |F| / step: allow 1e-7 |F| besides 1e-5 relative
        size = np.maximum(np.abs(grads[finite]), np.abs(fd)).max(axis=1) + 1e-2 * np.abs(values[finite])
        _require(label, points, grads[finite], fd, "match finite differences of " + label[5:], scale=size)
    casimir = np.cross(grad_S[finite], J[finite])
    _require("J", points, casimir, np.zeros_like(casimir), "satisfy grad S x J = 0 (S must be a Casimir of P)",
             scale=np.linalg.norm(grad_S[finite], axis=1) * np.linalg.norm(J[finite], axis=1))
    curl = _curl(system, points, step)
    jacobi = np.sum(J[finite] * curl, axis=1)
    _require("J", points, jacobi, np.zeros_like(jacobi), "satisfy Jacobi, J . curl J = 0",
             scale=np.linalg.norm(J[finite], axis=1) * (np.linalg.norm(curl, axis=1) + 1.0))
    if system.functions.poisson_form == "matrix":
        for x in points:
            P = np.asarray(system.functions.poisson(x.copy(), system._params))
            if not np.allclose(P, -P.T, rtol=1e-12, atol=1e-12 * np.abs(P).max()):
                raise ValueError(f"`P` must be skew-symmetric; at x = {x.tolist()} it is {P.tolist()}.")


def _fn_values(system, X, label):
    return system._evaluate(X)[0 if label == "grad_H" else 1]


def _curl(system, points, step):
    D = np.stack([(system.J(points + step * e) - system.J(points - step * e)) / (2 * step) for e in np.eye(3)], axis=2)
    # D[n, i, j] = d J_i / d x_j
    return np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]], axis=1)


def _require(name, points, got, want, rule, scale=None):
    got, want = np.asarray(got), np.asarray(want)
    if scale is None:
        scale = np.max(np.abs(want), axis=-1) if want.ndim > 1 else np.abs(want)
    bad = np.abs(got - want).reshape(len(points), -1).max(axis=1) > 1e-5 * (np.asarray(scale) + 1e-8)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(
            f"`{name}` must {rule}; at x = {points[i].tolist()} it gives {np.atleast_1d(got[i]).tolist()} "
            f"(expected {np.atleast_1d(want[i]).tolist()}). Pass check=False to skip this check."
        )


# -- declared exact sub-flows ------------------------------------------------------------
_EXACT_FLOW_DATA = {"rigid_body_flow": 3, "rotor_splitting": 0, "oscillator_rotation": 0}


def _check_exact_flows(exact_flows):
    if exact_flows is None:
        return {}
    if not isinstance(exact_flows, dict):
        raise TypeError(f"`exact_flows` must be a dict {{name: data}}; got {type(exact_flows).__name__}.")
    checked = {}
    for name, data in exact_flows.items():
        if name not in _EXACT_FLOW_DATA:
            raise ValueError(f"`exact_flows` names must be among {sorted(_EXACT_FLOW_DATA)}; got {name!r}.")
        values = _validate.reals(f"exact_flows[{name!r}]", data)
        if values.size != _EXACT_FLOW_DATA[name]:
            raise ValueError(f"`exact_flows[{name!r}]` must hold {_EXACT_FLOW_DATA[name]} numbers; got {data!r}.")
        checked[name] = tuple(float(v) for v in values)
    return checked


def _check_rigid_body(system, moments):
    if not all(m > 0.0 for m in moments):
        raise ValueError(f"`exact_flows['rigid_body_flow']` must be positive moments (a, b, c); got {moments!r}.")
    _, _, grad_H, _, J = system._evaluate(_SAMPLES)
    _require("exact_flows", _SAMPLES, grad_H, _SAMPLES * np.array(moments),
             f"hold for rigid_body_flow: grad H = (a x, b y, c z) with (a, b, c) = {moments}")
    _require("exact_flows", _SAMPLES, J, _SAMPLES, "hold for rigid_body_flow: J = m")


def _check_rotors(system, data):
    _, _, _, _, J = system._evaluate(_SAMPLES)
    _require("exact_flows", _SAMPLES, J, _SAMPLES, "hold for rotor_splitting: J = m")
    step = 1e-6
    for j, e in enumerate(np.eye(3)):
        column = (system.grad_H(_SAMPLES + step * e) - system.grad_H(_SAMPLES - step * e)) / (2 * step)
        mixed = np.delete(column, j, axis=1)
        _require("exact_flows", _SAMPLES, mixed, np.zeros_like(mixed),
                 "hold for rotor_splitting: H separable, d grad_H_i / d x_j = 0 for i != j",
                 scale=np.abs(column).max(axis=1) + 1.0)


def _check_rotation(system, data):
    _, _, grad_H, _, J = system._evaluate(_SAMPLES)
    _require("exact_flows", _SAMPLES, grad_H, _SAMPLES, "hold for oscillator_rotation: grad H = x")
    _require("exact_flows", _SAMPLES, J, np.broadcast_to(J[0], J.shape), "hold for oscillator_rotation: J constant")


_EXACT_FLOW_CHECKS = {"rigid_body_flow": _check_rigid_body, "rotor_splitting": _check_rotors,
                      "oscillator_rotation": _check_rotation}
