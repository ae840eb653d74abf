"""The metriplectic system: energy, Casimir, Poisson tensor and the perturbation eps.

In R^3 every Poisson tensor acts as ``P v = v x J(x)`` for an axial vector field
``J``; S is a Casimir when ``grad S x J = 0``.  Following Fish (paper section 1),
the metric ``g = grad H (x) grad H - I |grad H|^2`` turns the Hamiltonian system
into

    dx/dt = xi_P + eps xi_g,   xi_P = grad H x J,   xi_g = grad H x (grad H x grad S),

along which ``dH/dt = 0`` and ``dS/dt = -eps |sigma|^2``, ``sigma = grad S x grad H``.

The user's functions are typed and compiled by ``functions``, the structure is
checked by ``checks``, and the cross products are ``axial``'s (3-D only).
"""

from __future__ import annotations

import functools
import numbers
from typing import TYPE_CHECKING, Any, Self

import numpy as np

from .. import _user_errors, _validate
from .._kernels import field as _field
from .._kernels.layout import Model
from . import handles
from . import model_types as _model_types  # noqa: F401 - the models' numba types kept per model object
from .checks import check_exact_flows, check_structure, declared_exact_flows
from .functions import ModelFunctions, check_shapes, matrix_function, scalar_function, vector_function
from .handles import kernel_handle

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence

    import numpy.typing as npt

    Vector = npt.NDArray[np.float64]


@functools.cache
def _axial():
    """``model.axial`` [R3], the cross-product arithmetic of the fields, imported on first use: the model's
    core imports no 3-D-only module when it is imported."""
    from . import axial

    return axial


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
    dim : int, optional
        The dimension: absent or 3 for this class; any other ``n >= 2`` makes a
        system in R^n (``geomint.model.system_n.MetriplecticSystemN``: P as an
        (n, n) matrix, an optional ``metric``, array-valued functions).

    Vector results may be 3-tuples (no allocation: the faster form in a
    compiled loop) or float64 arrays; grad_H, grad_S and J must use the same
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

    #: the formulas of a system made by ``from_expressions`` (only there), for saved results
    expressions: dict[str, Any]
    #: the dimension of the state (``MetriplecticSystemN`` sets its own)
    dim: int = 3
    #: the names of the coordinates (``MetriplecticSystemN`` sets its own)
    variables: tuple[str, ...] = ("x", "y", "z")
    #: -1.0: S never rises (the Fish form); GENERIC's entropy never falls (+1.0, ``GenericSystem``)
    direction: float = -1.0

    #: the class a call with ``dim`` other than 3 makes (``model.system_n.MetriplecticSystemN`` registers itself
    #: by subclassing with ``rn=True``: this module imports none of the R^n model)
    _rn_class: type | None = None
    #: True in that class and its subclasses
    _in_rn: bool = False

    def __init_subclass__(cls, rn: bool = False, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if rn:
            MetriplecticSystem._rn_class = cls
            cls._in_rn = True

    def __new__(cls, *args: Any, dim: Any = None, **kwargs: Any) -> Self:
        """``MetriplecticSystem(..., dim=n)`` with n other than 3 makes a system in R^n (``MetriplecticSystemN``,
        whose ``__init__`` then takes the same arguments); without ``dim``, or with ``dim=3``, the system in R^3."""
        if cls is MetriplecticSystem and dim is not None and not _is_three(dim):
            if MetriplecticSystem._rn_class is None:  # pragma: no cover - geomint.model imports model.system_n
                raise RuntimeError("the R^n model (geomint.model.system_n) is not imported")
            return object.__new__(MetriplecticSystem._rn_class)
        if cls is MetriplecticSystem:
            for key in ("metric", "samples"):
                if kwargs.get(key) is not None:
                    raise TypeError(
                        f"`{key}` is an argument of the systems in R^n: pass `dim` (the dimension n) too; in R^3 "
                        "the metric is the paper's g, and the checks' samples are fixed."
                    )
        return object.__new__(cls)  # pyright: ignore[reportReturnType]  # an instance of cls, which is Self

    def __init__(
        self,
        *,
        H: Callable[..., Any],
        grad_H: Callable[..., Any],
        S: Callable[..., Any],
        grad_S: Callable[..., Any],
        J: Callable[..., Any] | None = None,
        P: Callable[..., Any] | None = None,
        eps: float = 1.0,
        params: npt.ArrayLike = (),
        name: str = "custom",
        exact_flows: dict[str, Any] | None = None,
        check: bool = True,
        dim: int | None = None,
    ) -> None:
        if (J is None) == (P is None):
            raise ValueError("give exactly one of `J` (axial vector) and `P` (skew matrix) for the Poisson tensor.")
        self.eps = _check_eps(eps)
        self.hamiltonian = True
        self._params = _validate.reals("params", params)
        self.name = str(name)
        scalar = {key: scalar_function(key, fn) for key, fn in (("H", H), ("S", S))}
        forms = {key: vector_function(key, fn) for key, fn in (("grad_H", grad_H), ("grad_S", grad_S))}
        if J is not None:
            forms["J"] = vector_function("J", J)
        else:
            matrix_function("P", P)
        if len(set(forms.values())) != 1:
            listed = ", ".join(f"`{k}` returns a {v}" for k, v in forms.items())
            raise TypeError(
                f"grad_H, grad_S and J must return the same kind of vector; {listed}. Make them all tuples."
            )
        self.functions = ModelFunctions(
            H=scalar["H"],
            grad_H=grad_H,
            S=scalar["S"],
            grad_S=grad_S,
            poisson=J if J is not None else P,  # pyright: ignore[reportArgumentType]  # one of them is given
            vector_form=forms["grad_H"],
            poisson_form="axial" if J is not None else "matrix",
        )
        check_shapes(self.functions, self._params)
        self.exact_flows = declared_exact_flows(exact_flows)
        if _validate.flag("check", check):
            with np.errstate(all="ignore"):  # finite differences of huge values overflow: the checks see inf/nan
                check_structure(self)
                check_exact_flows(self)

    # -- the model as kernels receive it ------------------------------------------------
    @property
    def model(self) -> Model:
        """``layout.Model(H, grad_H, S, grad_S, J or P, params, origin)``: the model as kernels receive it, the
        functions as compiled first-class function objects (one compiled kernel serves every system of the same
        function types; a user function that raises is caught by ``geomint._user_errors``).

        Their types (tuple or array results, J or P) select the compiled
        kernel variant.  ``origin`` holds H, grad H, S and grad S at 0 (0 where
        not finite): the kernels measure the constant and linear terms of H
        and S from it, the terms whose round-off ``x . grad F`` does not show.
        """
        return self._kernel_model(inline=False)

    @property
    def inlined_model(self) -> Model:
        """The same model with each user function that can be found again by name handed over to be inlined
        (``geomint.model.handles``, by default in R^3 only): the step loop's (``geomint.run.chunks``, ensembles),
        compiled for this system and cached, several times faster on small systems; its kernels catch what the
        functions raise."""
        return self._kernel_model(inline=True)

    def _kernel_model(self, inline: bool) -> Any:
        models = self.__dict__.setdefault("_models", {})
        inline = inline and handles.enabled(rn=self._in_rn)
        if inline not in models:
            models[inline] = self._build_model(lambda fn, action=False: kernel_handle(fn, action, inline))
        return models[inline]

    def _build_model(self, handle: Any) -> Model:
        f = self.functions
        handles = tuple(handle(fn) for fn in (f.H, f.grad_H, f.S, f.grad_S, f.poisson))
        return Model(*handles, self._params, self._origin())  # pyright: ignore[reportCallIssue]  # 5 handles

    def _origin(self, params=None):
        """H, grad H, S, grad S at 0 (0 where not finite or raising), with ``params`` (default: the system's)."""
        f, p, zero = self.functions, self._params if params is None else params, np.zeros(3)
        components = _axial().components
        values = []
        for value, gradient in ((f.H, f.grad_H), (f.S, f.grad_S)):
            try:
                with np.errstate(all="ignore"):
                    values += [float(value(zero, p)), *components(gradient(zero, p))]
            except Exception:  # noqa: BLE001 - singular at 0 (log |x|, 1/|x| ...): no such terms to measure
                values += [0.0] * 4
        origin = np.array(values, dtype=np.float64)
        origin[~np.isfinite(origin)] = 0.0
        return origin

    @property
    def params(self) -> Vector:
        """A copy of the parameter vector."""
        return self._params.copy()

    def with_effects(
        self, *, hamiltonian: bool | None = None, eps: float | None = None, params: npt.ArrayLike | None = None
    ) -> MetriplecticSystem:
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
                raise ValueError(
                    f"`params` must have {self._params.size} values, as the system's; got "
                    f"{values.size}: {values.tolist()}."
                )
            other._params = values
            other.__dict__.pop("_models", None)
            record_params(other, values)
            check_shapes(other.functions, values)
            with np.errstate(all="ignore"):
                check_structure(other)
        if hamiltonian is not None:
            other.hamiltonian = _validate.flag("hamiltonian", hamiltonian)
        if eps is not None:
            other.eps = _check_eps(eps)
        return other

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without the compiled model (function addresses of this process), rebuilt on first use: a
        system can be shipped to other processes (Dask workers)."""
        state = dict(self.__dict__)
        state.pop("_models", None)
        return state

    def __repr__(self) -> str:
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

    def _at(self, x: npt.ArrayLike, which: Sequence[int]) -> Sequence[Any]:
        """The functions ``which`` (indices into H, S, grad H, grad S, J) at ``x``: scalars, and vectors as
        3-tuples of components, floats for one state (3,) and arrays for many (n, 3); ``_array`` makes
        arrays of them.  The same formulas then serve both."""
        X = _states(x)
        if X.shape == (3,):
            return self._at_one(X if X.flags.c_contiguous else np.ascontiguousarray(X), which)
        values = self._evaluate(X)
        return tuple(values[i] if i < 2 else tuple(values[i].T) for i in which)

    def _at_one(self, x, which):
        """One state: only the user functions asked for, each called once directly (no kernel dispatch)."""
        f, p = self.functions, self._params
        functions = (f.H, f.S, f.grad_H, f.grad_S, f.poisson)
        try:
            values = [functions[i](x, p) for i in which]
        except Exception:
            self._name_the_raising_function(x)
        return [float(v) if i < 2 else v if type(v) is tuple else _axial().components(v) for i, v in zip(which, values)]

    def _name_the_raising_function(self, x):
        """Re-raise the exception being handled as a ``UserFunctionError`` naming the user function (as is
        if none raises on a second try)."""
        found = self.raising_function(x)
        if found is None:
            raise
        raise _user_errors.UserFunctionError(found[0], x.tolist(), found[1]) from found[1]

    def _xi_one(self, x):
        """``xi`` at one state (a contiguous (3,) array): the path a scipy right-hand side takes, the three
        user calls made directly, without ``_at_one``'s general bookkeeping."""
        f, p, eps = self.functions, self._params, self.eps
        try:
            gh, gs = f.grad_H(x, p), f.grad_S(x, p)
            j = f.poisson(x, p) if self.hamiltonian else None
        except Exception:
            self._name_the_raising_function(x)
        axial = _axial()
        gh = gh if type(gh) is tuple else axial.components(gh)
        gs = gs if type(gs) is tuple else axial.components(gs)
        if j is not None and type(j) is not tuple:
            j = axial.components(j)
        return np.array(axial.xi_of(gh, gs, j, eps))

    def raising_function(self, x: npt.ArrayLike) -> tuple[str, Exception] | None:
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

    def H(self, x: npt.ArrayLike) -> Any:  # a float at one state (3,), an array at many (n, 3)
        """Energy at ``x``."""
        return self._at(x, (_H,))[0]

    def S(self, x: npt.ArrayLike) -> Any:  # a float at one state (3,), an array at many (n, 3)
        """Casimir (entropy-like function) at ``x``."""
        return self._at(x, (_S,))[0]

    def H_and_S(self, x: npt.ArrayLike) -> tuple[Any, Any]:
        """``(H(x), S(x))`` in one evaluation: floats at one state, arrays at many."""
        H, S = self._at(x, (_H, _S))
        return H, S

    def grad_H(self, x: npt.ArrayLike) -> Vector:
        return _array(self._at(x, (_GRAD_H,))[0])

    def grad_S(self, x: npt.ArrayLike) -> Vector:
        return _array(self._at(x, (_GRAD_S,))[0])

    def J(self, x: npt.ArrayLike) -> Vector:
        """Axial vector of the Poisson tensor, ``P v = v x J``."""
        return _array(self._at(x, (_J,))[0])

    def xi_P(self, x: npt.ArrayLike) -> Vector:
        """Hamiltonian field ``grad H x J``."""
        gh, j = self._at(x, (_GRAD_H, _J))
        return _array(_axial().cross(gh, j))

    def xi_g(self, x: npt.ArrayLike) -> Vector:
        """Gradient field ``g grad S = grad H x (grad H x grad S)`` (without eps)."""
        gh, gs = self._at(x, (_GRAD_H, _GRAD_S))
        cross = _axial().cross
        return _array(cross(gh, cross(gh, gs)))

    def xi(self, x: npt.ArrayLike) -> Vector:
        """The field ``xi_P + eps xi_g`` (without ``xi_P`` when the Hamiltonian part is off)."""
        X = _states(x)
        if X.shape == (3,):
            return self._xi_one(X if X.flags.c_contiguous else np.ascontiguousarray(X))
        if self.hamiltonian:
            gh, gs, j = self._at(X, (_GRAD_H, _GRAD_S, _J))
        else:
            (gh, gs), j = self._at(X, (_GRAD_H, _GRAD_S)), None
        return _array(_axial().xi_of(gh, gs, j, self.eps))

    def g(self, x: npt.ArrayLike) -> Vector:
        """The metric ``grad H (x) grad H - I |grad H|^2``, shape (3, 3) or (n, 3, 3)."""
        gh = self.grad_H(x)
        outer = gh[..., :, None] * gh[..., None, :]
        return outer - np.eye(3) * np.sum(gh * gh, axis=-1)[..., None, None]

    def sigma(self, x: npt.ArrayLike) -> Vector:
        """``sigma = grad S x grad H``; ``dS/dt = -eps |sigma|^2``."""
        gh, gs = self._at(x, (_GRAD_H, _GRAD_S))
        return _array(_axial().cross(gs, gh))

    def dS_dt(self, x: npt.ArrayLike) -> Any:  # a float at one state (3,), an array at many (n, 3)
        """Rate of change of S along the flow, ``-eps |sigma|^2``."""
        s = self.sigma(x)
        return -self.eps * np.sum(s * s, axis=-1)

    @classmethod
    def from_expressions(
        cls,
        *,
        H: str,
        S: str,
        J: Sequence[str] | None = None,
        P: Sequence[Sequence[str]] | None = None,
        params: Mapping[str, float] | None = None,
        eps: float = 1.0,
        name: str = "expressions",
        variables: Sequence[str] | None = None,
        **rn: Any,
    ) -> MetriplecticSystem:
        """A system from formulas (strings), e.g. ``H="(y**2 + z**2)/2 - r*z"``, ``J=("-x", "0", "sigma")``.

        Text is parsed by a whitelist grammar (never evaluated), gradients are exact, the
        structure is checked symbolically, and generated numba code is cached on disk:
        see ``geomint.model.expressions.build`` for the grammar and every argument.

        With ``variables`` (named coordinates, families ``"q[1..N]"``; any number of them, 3 included) the
        system is one in R^n: ``MetriplecticSystemN.from_expressions``, which also takes ``metric``,
        ``sizes``, ``define``, ``samples`` and ``check``.  Without it the coordinates are x, y, z and the
        system is the R^3 engine's.
        """
        if variables is not None:
            if J is not None:
                raise TypeError(
                    "`J` (an axial vector) is the R^3 form: with `variables` give `P`, the (n, n) skew matrix "
                    '(n lists of n formulas, or rules {"q, p": "1", "p, q": "-1"}).'
                )
            return MetriplecticSystem._rn_class.from_expressions(  # pyright: ignore[reportOptionalMemberAccess]
                variables=variables, H=H, S=S, P=P, params=params, eps=eps, name=name, **rn
            )
        if rn:
            raise TypeError(
                f"{', '.join(f'`{k}`' for k in rn)}: arguments of systems in R^n written as formulas: give "
                "`variables` too (the coordinates' names)."
            )
        from . import expressions

        system = cls(**expressions.build(H=H, S=S, J=J, P=P, params=params, eps=eps, name=name))
        poisson = {"J": list(J)} if J is not None else {"P": [list(row) for row in P]}  # pyright: ignore[reportOptionalIterable]  # J or P
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


def _array(v):
    """A 3-tuple of components as an array: (3,) for floats, (n, 3) for arrays over states."""
    return np.array(v, dtype=np.float64) if isinstance(v[0], float) else np.stack(v, axis=-1)


def _is_three(dim):
    """``dim`` is the integer 3 (a bool or float is not: the R^n class then names the argument)."""
    return isinstance(dim, numbers.Integral) and not isinstance(dim, (bool, np.bool_)) and dim == 3


def record_params(system: Any, values: npt.NDArray[np.float64]) -> None:
    """A system made ``from_expressions`` records its parameters by name (``system.expressions``, written into
    saved results): given new values, the record takes them, under the same names in the same order."""
    recorded = system.__dict__.get("expressions")
    if recorded and isinstance(recorded.get("params"), dict) and len(recorded["params"]) == values.size:
        system.expressions = {**recorded, "params": dict(zip(recorded["params"], values.tolist()))}


def _check_eps(eps):
    value = _validate.real("eps", eps)
    if not np.isfinite(value) or value < 0.0:
        raise ValueError(f"`eps` must be finite and >= 0; got {eps!r}.")
    return value
