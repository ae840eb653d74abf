"""Metriplectic systems in R^n: the Fish form with the paper's metric or the user's, and the GENERIC form.

Fish form (paper eq. (sys) in any dimension n >= 2)::

    dx/dt = P(x) grad H + eps D(x) grad S,   D = g = grad H grad H^T - |grad H|^2 I   (or the user's G),

with P skew and ``P grad S = 0``; g (and a user's G: symmetric, negative
semidefinite, ``G grad H = 0``) gives ``dH/dt = 0`` and ``dS/dt = eps grad S . D grad S <= 0``
(for g: ``-eps |grad H|^2 |Pi_H grad S|^2``, ``Pi_H = I - h h^T``, ``h = grad H / |grad H|``).
Only skewness and the Casimir are used: Jacobi is neither needed nor checked (a
Galerkin truncation of 2-D Euler is skew and degenerate but not Jacobi).

GENERIC form (Grmela and Oettinger, Phys. Rev. E 56 (1997) 6620)::

    dx/dt = L(x) grad E + M(x) grad S,

L skew with ``L grad S = 0``, M symmetric positive semidefinite with ``M grad E = 0``: E
is conserved and the entropy S never falls.  It is the Fish form with H = E, P = L and
the metric M (eps = 1), the entropy rising instead of falling (``direction`` +1).

The kernels receive both as ``layout.ModelN``.  The scheme and its reasons: docs/engine_rn.md.
"""

from __future__ import annotations

import hashlib
import keyword
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _user_errors, _validate
from .._kernels.layout import M_ACTION, P_ACTION, PAPER_METRIC, USER_METRIC, ModelN
from .checks import check_dim, check_samples, check_structure_n
from .functions import (
    ModelFunctionsN,
    action_function,
    array_function,
    check_returned_shapes,
    matrix_function,
    no_action,
    no_metric,
    scalar_function,
)
from .system import MetriplecticSystem, _check_eps, record_params

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    Vector = npt.NDArray[np.float64]

#: the roles of the user functions in ``dx/dt = P grad H + eps D grad S``, and their names in the Fish form
_FISH_NAMES = {
    "H": "H",
    "grad_H": "grad_H",
    "S": "S",
    "grad_S": "grad_S",
    "P": "P",
    "M": "metric",
    "P_apply": "P_apply",
    "M_apply": "metric_apply",
}
_GENERIC_NAMES = {
    "H": "E",
    "grad_H": "grad_E",
    "S": "S",
    "grad_S": "grad_S",
    "P": "L",
    "M": "M",
    "P_apply": "L_apply",
    "M_apply": "M_apply",
}


class MetriplecticSystemN(MetriplecticSystem, rn=True):
    """A metriplectic system in R^n, n >= 2, in the Fish form (S never rises).

        dx/dt = P(x) grad H + eps D(x) grad S,   D = g = grad H grad H^T - |grad H|^2 I   or the user's G.

    ``geomint.MetriplecticSystem(..., dim=n)`` with n other than 3 makes one;
    ``MetriplecticSystemN(..., dim=3)`` is the same form in R^3.

    Parameters
    ----------
    H, grad_H : numba-jitted functions ``(x, params) -> float`` / ``-> float64 array (n,)``
        The energy (conserved) and its gradient.
    S, grad_S : numba-jitted functions
        The Casimir (dissipated) and its gradient.
    P : numba-jitted function ``(x, params) -> (n, n) float64 array``
        The Poisson tensor: skew, with ``P grad S = 0``.  Jacobi is not required.
    P_apply : numba-jitted function ``(x, v, params) -> float64 array (n,)``
        The Poisson tensor as an action, ``P(x) v``, in place of ``P`` (give
        exactly one of the two): the kernels then never form an (n, n) matrix,
        and a step costs what the action costs (docs/engine_rn.md, "Solving the
        step").
    eps : float, default 1.0
        The perturbation parameter, ``eps >= 0``.
    params : sequence of float
        Passed to every function.
    dim : int
        The dimension n >= 2 of the state.
    metric : numba-jitted function ``(x, params) -> (n, n) float64 array``, optional
        A metric G to use instead of the paper's g: symmetric, negative
        semidefinite, ``G grad H = 0``.
    metric_apply : numba-jitted function ``(x, v, params) -> float64 array (n,)``, optional
        The same metric as an action ``G(x) v``, in place of ``metric``.
    name : str
        A label for reports.
    variables : sequence of n str, optional
        The names of the coordinates, in order (default ``("x0", "x1", ...)``):
        distinct Python identifiers.  They label saved results and
        ``to_xarray``'s ``component`` dimension (``system.variables``).
    samples : array (k, n), optional
        The states the structure checks use (default: six drawn uniformly from
        ``[-1, 1]^n`` with a fixed seed); give states in the domain where the
        functions are defined only on part of R^n.
    check : bool, default True
        Check at the samples that the gradients match central differences of H
        and S, P is skew, ``P grad S = 0``, and a given metric is symmetric,
        negative semidefinite and annihilates ``grad H``; a violation raises
        ``ValueError`` naming the argument.  An operator given as an action is
        checked on its matrix, formed column by column, for n <= 32, and by
        random probes (``u . P v = -v . P u``, ``v . G v <= 0``) above.

    Notes
    -----
    x and params reach the functions as contiguous float64 arrays; vectors are
    returned as contiguous float64 arrays (not tuples) of length n, matrices as
    (n, n) arrays.  Every method below accepts one state ``(n,)`` or many ``(m, n)``.

    Examples
    --------
    >>> import numba, numpy as np, geomint
    >>> @numba.njit
    ... def H(x, p): return 0.5 * np.sum(x * x)
    >>> @numba.njit
    ... def grad_H(x, p): return x.copy()
    >>> @numba.njit
    ... def S(x, p): return 0.5 * x[3] * x[3]
    >>> @numba.njit
    ... def grad_S(x, p): return np.array([0.0, 0.0, 0.0, x[3]])
    >>> @numba.njit
    ... def P(x, p): return np.array([[0.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0] * 4, [0.0] * 4])
    >>> system = geomint.MetriplecticSystem(H=H, grad_H=grad_H, S=S, grad_S=grad_S, P=P, dim=4)
    >>> round(system.dS_dt([0.6, 0.0, 0.0, 0.8]), 3)
    -0.23
    """

    #: S never rises (Fish form); GENERIC's entropy never falls (+1.0)
    direction = -1.0
    _names = _FISH_NAMES

    def __init__(
        self,
        *,
        H: Callable[..., Any],
        grad_H: Callable[..., Any],
        S: Callable[..., Any],
        grad_S: Callable[..., Any],
        P: Callable[..., Any] | None = None,
        eps: float = 1.0,
        params: npt.ArrayLike = (),
        dim: int | None = None,
        metric: Callable[..., Any] | None = None,
        name: str = "custom",
        P_apply: Callable[..., Any] | None = None,
        metric_apply: Callable[..., Any] | None = None,
        samples: npt.ArrayLike | None = None,
        check: bool = True,
        variables: Any = None,
        J: Any = None,
        exact_flows: Any = None,
    ) -> None:
        if J is not None:
            if dim is not None:
                check_dim(dim)  # dim=3.0 came here from MetriplecticSystem: the dimension is what is wrong
            raise TypeError(
                "`J` (an axial vector) describes a Poisson tensor in R^3 only: in R^n give `P`, the (n, n) skew matrix."
            )
        if exact_flows is not None:
            raise TypeError("`exact_flows` are declared for systems in R^3 only.")
        self._setup(
            dict(H=H, grad_H=grad_H, S=S, grad_S=grad_S, P=P, M=metric, P_apply=P_apply, M_apply=metric_apply),
            eps=eps,
            params=params,
            dim=dim,
            name=name,
            samples=samples,
            check=check,
            variables=variables,
        )

    def _setup(self, given, *, eps, params, dim, name, samples, check, variables=None):
        """Shared by both forms: ``given`` maps the roles (H, grad_H, S, grad_S, P, M) to the user's functions."""
        if dim is None:
            raise TypeError("`dim` (the dimension n >= 2 of the state) is required for a system in R^n.")
        self.dim = n = check_dim(dim)
        self.eps = _check_eps(eps)
        self.hamiltonian = True
        self._params = _validate.reals("params", params)
        self.name = str(name)
        self.variables = check_variables(variables, n)
        self.exact_flows = {}
        names = self._names
        _one_form(names, given, "P", required=True)
        _one_form(names, given, "M", required=self.direction > 0)
        self.functions = ModelFunctionsN(
            H=scalar_function(names["H"], given["H"], n),
            grad_H=array_function(names["grad_H"], given["grad_H"], n),
            S=scalar_function(names["S"], given["S"], n),
            grad_S=array_function(names["grad_S"], given["grad_S"], n),
            P=None if given["P"] is None else matrix_function(names["P"], given["P"], n),
            M=None if given["M"] is None else matrix_function(names["M"], given["M"], n),
            P_apply=None if given["P_apply"] is None else action_function(names["P_apply"], given["P_apply"], n),
            M_apply=None if given["M_apply"] is None else action_function(names["M_apply"], given["M_apply"], n),
        )
        self._samples = check_samples(samples, n)
        self._checked = _validate.flag("check", check)
        self._check(self._checked)

    def _check(self, structure):
        """Shapes at the first sample; the structure at all of them when ``structure``."""
        f, n = self.functions, self.dim
        wanted: dict[str, tuple[Any, tuple[Any, ...]]] = {
            self._names["grad_H"]: (f.grad_H, (n,)),
            self._names["grad_S"]: (f.grad_S, (n,)),
        }
        for role in ("P", "M"):
            if getattr(f, role) is not None:
                wanted[self._names[role]] = (getattr(f, role), (n, n))
            if getattr(f, role + "_apply") is not None:
                wanted[self._names[role + "_apply"]] = (getattr(f, role + "_apply"), (n, "action"))
        check_returned_shapes(wanted, self._samples[0], self._params)
        if structure:
            with np.errstate(all="ignore"):  # finite differences of huge values overflow: the checks see inf/nan
                check_structure_n(self)

    # -- the model as kernels receive it ------------------------------------------------
    @property
    def metric(self) -> int:
        """``layout.PAPER_METRIC`` (the paper's g) or ``layout.USER_METRIC`` (the user's G, GENERIC's M)."""
        f = self.functions
        return PAPER_METRIC if f.M is None and f.M_apply is None else USER_METRIC

    @property
    def actions(self) -> int:
        """Which operators are given as actions: ``layout.P_ACTION | layout.M_ACTION`` bits (0: both matrices)."""
        f = self.functions
        return (P_ACTION if f.P_apply is not None else 0) | (M_ACTION if f.M_apply is not None else 0)

    def _build_model(self, handle: Any) -> ModelN:  # pyright: ignore[reportIncompatibleMethodOverride]  # R^n
        """``layout.ModelN(H, grad_H, S, grad_S, P, M, params, metric, direction, origin, P_apply, M_apply,
        actions)``: the system as the R^n kernels receive it (``model``: the functions first-class;
        ``inlined_model``: inlined where they can be).  Each operator's unused form (the matrix where an action is
        given, the action where a matrix is, both where the paper's metric is used) is a placeholder, never
        called."""
        f = self.functions
        matrices = tuple(handle(no_metric if fn is None else fn) for fn in (f.P, f.M))
        actions = tuple(handle(no_action if fn is None else fn, action=True) for fn in (f.P_apply, f.M_apply))
        handles = tuple(handle(fn) for fn in (f.H, f.grad_H, f.S, f.grad_S))
        fields = (*handles, *matrices, self._params, self.metric, self.direction, self._origin(), *actions)
        return ModelN(*fields, self.actions)  # pyright: ignore[reportCallIssue]  # 12 fields and actions

    def _origin(self, params=None):
        """``(H(0), S(0))``, 0 where not finite or raising, with ``params`` (default: the system's)."""
        f, p, zero = self.functions, self._params if params is None else params, np.zeros(self.dim)
        values = []
        for fn in (f.H, f.S):
            try:
                with np.errstate(all="ignore"):
                    values.append(float(fn(zero, p)))
            except Exception:  # noqa: BLE001 - singular at 0 (log |x|, 1/|x| ...): no constant term to measure
                values.append(0.0)
        origin = np.array(values, dtype=np.float64)
        origin[~np.isfinite(origin)] = 0.0
        return origin

    def with_effects(
        self, *, hamiltonian: bool | None = None, eps: float | None = None, params: npt.ArrayLike | None = None
    ) -> MetriplecticSystemN:
        """The same system with the Hamiltonian part switched on/off, another eps and/or other params.

        ``hamiltonian=False`` leaves ``dx/dt = eps D grad S``; ``eps=0`` the
        Hamiltonian system (for GENERIC, eps scales M).  New ``params`` (as many
        numbers as the system has) are checked at the samples as at construction
        (the structure only if it was checked then).
        """
        other = object.__new__(type(self))
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
            other._check(self._checked)
        if hamiltonian is not None:
            other.hamiltonian = _validate.flag("hamiltonian", hamiltonian)
        if eps is not None:
            other.eps = _check_eps(eps)
        return other

    def __repr__(self) -> str:
        effects = "" if self.hamiltonian else ", hamiltonian=False"
        metric = "" if self.metric == PAPER_METRIC or self.direction > 0 else ", metric=user"
        return (
            f"{type(self).__name__}(name={self.name!r}, dim={self.dim}, eps={self.eps!r}{metric}{effects}, "
            f"params={_shown_params(self._params)})"
        )

    # -- evaluation at one state or many ------------------------------------------------
    def _states(self, x):
        """``x`` as a C-contiguous float64 array (m, n) and whether it was one state (n,), or an error naming ``x``."""
        n = self.dim
        try:
            X = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            raise TypeError(f"`x` must be a state of n = {n} real numbers, or an (m, {n}) array of them.") from None
        if X.ndim not in (1, 2) or X.shape[-1] != n:
            raise ValueError(
                f"`x` must have shape ({n},) (one state of n = {n} numbers) or (m, {n}) (m states); got shape "
                f"{X.shape}."
            )
        return np.ascontiguousarray(np.atleast_2d(X)), X.ndim == 1

    def _call(self, role, x, v=None) -> Any:  # a float for H and S, an array otherwise
        """The user function of ``role`` (``H``, ``grad_H``, ``S``, ``grad_S``, ``P``, ``M``, ``P_apply``,
        ``M_apply``; an action applied to ``v``) at the state ``x``; an exception it raises becomes a
        ``UserFunctionError`` naming it by the user's name.  ``P`` and ``M`` given as actions are formed column by
        column (n actions)."""
        f = getattr(self.functions, role)
        if f is None:  # P or M given as an action (``_check`` made sure one form is given)
            return np.column_stack([self._call(role + "_apply", x, e) for e in np.eye(self.dim)])
        x = x if x.flags.c_contiguous else np.ascontiguousarray(x)
        before = x.copy()
        try:
            if role.endswith("_apply"):
                value = f(x, np.ascontiguousarray(v, dtype=np.float64), self._params)
            else:
                value = f(x, self._params)
        except Exception as error:
            raise _user_errors.UserFunctionError(self._names[role], x.tolist(), error) from error
        _user_errors.wrote_into(self._names[role], before, x)
        return float(value) if role in ("H", "S") else np.asarray(value, dtype=np.float64)

    def _apply(self, role, x, v) -> Any:
        """``P(x) v`` (``role`` "P") or ``M(x) v`` ("M") by the operator's native form: its action, or its matrix
        times v."""
        if getattr(self.functions, role + "_apply") is not None:
            return self._call(role + "_apply", x, v)
        return self._call(role, x) @ v

    def _evaluate_one(self, x, with_matrices=False):
        """``(H, S, grad H, grad S, P, M)`` at one state (P and M only ``with_matrices``, as matrices; M None for
        the paper's metric)."""
        values = [self._call(role, x) for role in ("H", "S", "grad_H", "grad_S")]
        if not with_matrices:
            return (*values, None, None)
        M = None if self.metric == PAPER_METRIC else self._call("M", x)
        return (*values, self._call("P", x), M)

    def _over(self, x, one, rank=1) -> Any:
        """``one(state)`` at one state ``(n,)``, stacked over many ``(m, n)``; ``rank``: of one value (0 a number,
        1 a vector, 2 a matrix), which gives no states its shape ``(0, n, ...)``, as in R^3."""
        X, single = self._states(x)
        values = [one(row) for row in X]
        if single:
            return values[0]
        return np.array(values) if values else np.empty((0,) + (self.dim,) * rank)

    def raising_function(self, x: npt.ArrayLike) -> tuple[str, Exception] | None:
        """``(name, exception)`` of the first user function that raises at ``x``, or None if none does."""
        X, _ = self._states(x)
        for role in ("H", "S", "grad_H", "grad_S", "P", "M", "P_apply", "M_apply"):
            fn = getattr(self.functions, role)
            if fn is None:
                continue
            try:
                if role.endswith("_apply"):
                    fn(X[0].copy(), X[0].copy(), self._params)
                else:
                    fn(X[0].copy(), self._params)
            except Exception as error:  # noqa: BLE001 - any exception of the user's is the answer
                return self._names[role], error
        return None

    def H(self, x: npt.ArrayLike) -> Any:  # a float at one state (n,), an array at many (m, n)
        """The energy at ``x``."""
        return self._over(x, lambda row: self._call("H", row), 0)

    def S(self, x: npt.ArrayLike) -> Any:  # a float at one state (n,), an array at many (m, n)
        """The Casimir (Fish form) or entropy (GENERIC) at ``x``."""
        return self._over(x, lambda row: self._call("S", row), 0)

    def H_and_S(self, x: npt.ArrayLike) -> tuple[Any, Any]:
        """``(H(x), S(x))``: floats at one state, arrays at many."""
        return self.H(x), self.S(x)

    def grad_H(self, x: npt.ArrayLike) -> Vector:
        return self._over(x, lambda row: self._call("grad_H", row))

    def grad_S(self, x: npt.ArrayLike) -> Vector:
        return self._over(x, lambda row: self._call("grad_S", row))

    def P(self, x: npt.ArrayLike) -> Vector:
        """The Poisson tensor, shape (n, n) at one state, (m, n, n) at many (formed column by column where it is
        given as an action)."""
        return self._over(x, lambda row: self._call("P", row), 2)

    def g(self, x: npt.ArrayLike) -> Vector:
        """The paper's metric ``grad H grad H^T - |grad H|^2 I``, shape (n, n) or (m, n, n)."""
        return self._over(x, lambda row: _paper_metric(self._call("grad_H", row)), 2)

    def D(self, x: npt.ArrayLike) -> Vector:
        """The metric the field uses: the paper's g, or the user's G (GENERIC: M); (n, n) or (m, n, n)."""
        if self.metric == PAPER_METRIC:
            return self.g(x)
        return self._over(x, lambda row: self._call("M", row), 2)

    def _dissipative(self, row):
        """``D grad S`` at one state (with ``grad S``), D applied without forming g where it is the paper's."""
        gs = self._call("grad_S", row)
        if self.metric != PAPER_METRIC:
            return self._apply("M", row, gs), gs
        gh = self._call("grad_H", row)
        return gh * (gh @ gs) - (gh @ gh) * gs, gs

    def xi_P(self, x: npt.ArrayLike) -> Vector:
        """The Hamiltonian field ``P grad H``."""
        return self._over(x, lambda row: self._apply("P", row, self._call("grad_H", row)))

    def xi_g(self, x: npt.ArrayLike) -> Vector:
        """The dissipative field ``D grad S`` (without eps)."""
        return self._over(x, lambda row: self._dissipative(row)[0])

    def _xi_row(self, row):
        field = self.eps * self._dissipative(row)[0]
        if self.hamiltonian:
            field = self._apply("P", row, self._call("grad_H", row)) + field
        return field

    def xi(self, x: npt.ArrayLike) -> Vector:
        """The field ``P grad H + eps D grad S`` (without the first term when the Hamiltonian part is off)."""
        return self._over(x, self._xi_row)

    def dH_dt(self, x: npt.ArrayLike) -> Any:
        """``grad H . xi`` as computed: 0 up to round-off (the structure's residual)."""
        return self._over(x, lambda row: float(self._call("grad_H", row) @ self._xi_row(row)), 0)

    def dS_dt(self, x: npt.ArrayLike) -> Any:
        """The rate of S along the flow, ``eps grad S . D grad S`` (``P grad S = 0`` drops the Hamiltonian term):
        for the paper's metric ``-eps |grad H|^2 |Pi_H grad S|^2``, a sum of squares (<= 0 in floating point
        too); <= 0 in the Fish form, >= 0 in GENERIC."""
        return self._over(x, self._dS_dt_row, 0)

    def _dS_dt_row(self, row):
        if self.metric != PAPER_METRIC:
            dissipative, gs = self._dissipative(row)
            return self.eps * float(gs @ dissipative)
        gh, gs = self._call("grad_H", row), self._call("grad_S", row)
        size = float(gh @ gh)
        if size == 0.0:
            return -0.0 * self.eps
        rest = gs - (float(gh @ gs) / size) * gh
        return -self.eps * size * float(rest @ rest)

    # -- what R^3 has and R^n has not ---------------------------------------------------
    def J(self, x: npt.ArrayLike) -> Vector:
        """Not in R^n: the axial vector of a Poisson tensor exists in R^3 only (use ``P``)."""
        raise TypeError(
            f"`J` is the axial vector of a Poisson tensor in R^3; a system in R^n (n = {self.dim}) has none: use "
            "`P(x)`, the (n, n) matrix."
        )

    def sigma(self, x: npt.ArrayLike) -> Vector:
        """Not in R^n: ``sigma = grad S x grad H`` is a cross product (R^3); ``dS_dt`` gives the rate."""
        raise TypeError(
            f"`sigma` (grad S x grad H) is a cross product, defined in R^3 only; for a system in R^n (n = "
            f"{self.dim}) `dS_dt(x)` gives the rate of S."
        )

    @classmethod
    def from_expressions(  # pyright: ignore[reportIncompatibleMethodOverride]  # the R^n fields
        cls,
        *,
        variables: Any,
        H: str,
        S: str,
        P: Any,
        params: Any = None,
        eps: float = 1.0,
        metric: Any = None,
        sizes: Any = None,
        define: Any = None,
        name: str = "expressions",
        samples: npt.ArrayLike | None = None,
        check: bool = True,
    ) -> MetriplecticSystemN:
        """A Fish-form system in R^n from formulas with named variables (``geomint.model.expressions_n``).

        ``variables`` names the coordinates in order: ``"s"`` one, ``"q[N]"`` or ``"q[1..N]"`` a family
        (bounds from ``sizes``, integers fixed at generation); H and S are formulas (``sum(p[i]**2/2, i)``);
        ``P`` and ``metric`` (optional, the user's G) are n lists of n formulas or rules
        ``{"q[i], p[i]": "1", "p[i], q[i]": "-1"}``; ``params`` ``{name: float}`` (read at run time),
        ``define`` ``{name: formula}`` (sub-formulas).  Gradients are exact (sympy), the structure is checked
        symbolically, the generated code is cached on disk (a second process loads it).  ``samples`` and
        ``check`` are the constructor's.

        >>> import geomint
        >>> system = geomint.MetriplecticSystemN.from_expressions(
        ...     variables=("q", "p", "s"), H="(q**2 + p**2)/2", S="s**2/2",
        ...     P={"q, p": "1", "p, q": "-1"}, eps=0.5)
        >>> system.xi([1.0, 0.0, 1.0]).tolist()
        [0.0, -1.0, -0.5]
        """
        from . import expressions_n

        return expressions_n.fish_system(
            cls,
            variables=variables,
            H=H,
            S=S,
            P=P,
            params=params,
            eps=eps,
            metric=metric,
            sizes=sizes,
            define=define,
            name=name,
            samples=samples,
            check=check,
        )


class GenericSystem(MetriplecticSystemN):
    """A system in GENERIC form in R^n (Grmela and Oettinger, Phys. Rev. E 56 (1997) 6620).

        dx/dt = L(x) grad E + M(x) grad S,

    L skew with ``L grad S = 0`` (S a Casimir of L), M symmetric positive
    semidefinite with ``M grad E = 0``: E is conserved and the entropy S never
    falls, ``dS/dt = grad S . M grad S >= 0``.  To the engine it is the Fish form
    with H = E, P = L, the metric M, eps = 1 and ``direction`` +1.

    Parameters
    ----------
    E, grad_E : numba-jitted functions ``(x, params) -> float`` / ``-> float64 array (n,)``
        The energy and its gradient.
    S, grad_S : numba-jitted functions
        The entropy and its gradient.
    L : numba-jitted function ``(x, params) -> (n, n) float64 array``
        The Poisson matrix (skew, ``L grad S = 0``).
    M : numba-jitted function ``(x, params) -> (n, n) float64 array``
        The friction matrix (symmetric positive semidefinite, ``M grad E = 0``).
    L_apply, M_apply : numba-jitted functions ``(x, v, params) -> float64 array (n,)``
        The same operators as actions, ``L(x) v`` and ``M(x) v``, in place of
        ``L`` and ``M`` (exactly one form of each): no (n, n) matrix is formed.
    params, dim, name, samples, check, variables
        As for ``MetriplecticSystemN``; the checks name ``E``, ``grad_E``, ``L`` and ``M``.

    Notes
    -----
    ``E(x)`` is ``H(x)``, ``L(x)`` is ``P(x)`` and ``M(x)`` is ``D(x)``.
    Conserved quantities besides E are not declared (yet).

    Examples
    --------
    A damped oscillator in a heat bath (x = (q, p, s), temperature ``T = exp(s)``):

    >>> import numba, numpy as np, geomint
    >>> @numba.njit
    ... def E(x, p): return 0.5 * (x[0] ** 2 + x[1] ** 2) + np.exp(x[2])
    >>> @numba.njit
    ... def grad_E(x, p): return np.array([x[0], x[1], np.exp(x[2])])
    >>> @numba.njit
    ... def S(x, p): return x[2]
    >>> @numba.njit
    ... def grad_S(x, p): return np.array([0.0, 0.0, 1.0])
    >>> @numba.njit
    ... def L(x, p): return np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    >>> @numba.njit
    ... def M(x, p):
    ...     w = np.array([0.0, 1.0, -x[1] / np.exp(x[2])])
    ...     return p[0] * np.exp(x[2]) * np.outer(w, w)
    >>> bath = geomint.GenericSystem(E=E, grad_E=grad_E, S=S, grad_S=grad_S, L=L, M=M, params=[0.5], dim=3)
    >>> sol = geomint.solve(bath, [1.0, 0.0, 0.0], (0.0, 20.0), h=0.05)
    >>> bool(sol.energy_error < 1e-14), sol.S_falls, bool(sol.S[-1] > sol.S[0])
    (True, 0, True)
    """

    direction = +1.0
    _names = _GENERIC_NAMES

    def __init__(
        self,
        *,
        E: Callable[..., Any],
        grad_E: Callable[..., Any],
        S: Callable[..., Any],
        grad_S: Callable[..., Any],
        L: Callable[..., Any] | None = None,
        M: Callable[..., Any] | None = None,
        params: npt.ArrayLike = (),
        dim: int | None = None,
        name: str = "custom",
        samples: npt.ArrayLike | None = None,
        check: bool = True,
        variables: Any = None,
        L_apply: Callable[..., Any] | None = None,
        M_apply: Callable[..., Any] | None = None,
    ) -> None:
        self._setup(
            dict(H=E, grad_H=grad_E, S=S, grad_S=grad_S, P=L, M=M, P_apply=L_apply, M_apply=M_apply),
            eps=1.0,
            params=params,
            dim=dim,
            name=name,
            samples=samples,
            check=check,
            variables=variables,
        )

    @classmethod
    def from_expressions(  # pyright: ignore[reportIncompatibleMethodOverride]  # GENERIC's fields
        cls,
        *,
        variables: Any,
        E: str,
        S: str,
        L: Any,
        M: Any,
        params: Any = None,
        sizes: Any = None,
        define: Any = None,
        name: str = "expressions",
        samples: npt.ArrayLike | None = None,
        check: bool = True,
    ) -> GenericSystem:
        """A GENERIC system from formulas with named variables (``geomint.model.expressions_n``).

        As ``MetriplecticSystemN.from_expressions`` with E, S, L (skew, ``L grad S = 0``) and M (symmetric,
        ``M grad E = 0``; positive semidefiniteness is checked at the samples).  N damped pendula:

        >>> import geomint
        >>> pendula = geomint.GenericSystem.from_expressions(
        ...     variables=("q[1..N]", "p[1..N]", "s"), sizes={"N": 2}, params={"gamma": 0.5},
        ...     E="sum(p[i]**2/2 + cos(q[i]), i) + s", S="s",
        ...     L={"q[i], p[i]": "1", "p[i], q[i]": "-1"},
        ...     M={"p[i], p[i]": "gamma", "p[i], s": "-gamma*p[i]", "s, p[i]": "-gamma*p[i]",
        ...        "s, s": "gamma*sum(p[i]**2, i)"})
        >>> pendula.variables, pendula.dS_dt([0.0, 0.0, 1.0, 2.0, 0.0])
        (('q1', 'q2', 'p1', 'p2', 's'), 2.5)
        """
        from . import expressions_n

        return expressions_n.generic_system(
            cls,
            variables=variables,
            E=E,
            S=S,
            L=L,
            M=M,
            params=params,
            sizes=sizes,
            define=define,
            name=name,
            samples=samples,
            check=check,
        )

    def E(self, x: npt.ArrayLike) -> Any:  # a float at one state (n,), an array at many (m, n)
        """The energy at ``x`` (``H``)."""
        return self.H(x)

    def grad_E(self, x: npt.ArrayLike) -> Vector:
        return self.grad_H(x)

    def L(self, x: npt.ArrayLike) -> Vector:
        """The Poisson matrix (``P``), (n, n) or (m, n, n)."""
        return self.P(x)

    def M(self, x: npt.ArrayLike) -> Vector:
        """The friction matrix (``D``), (n, n) or (m, n, n)."""
        return self.D(x)

    def dE_dt(self, x: npt.ArrayLike) -> Any:
        """``grad E . xi`` as computed: 0 up to round-off."""
        return self.dH_dt(x)


def check_variables(variables: Any, n: int) -> tuple[str, ...]:
    """The names of the n coordinates: ``("x0", ..., "x{n-1}")`` for None, else n distinct Python identifiers (not
    keywords), as a tuple; a TypeError/ValueError naming ``variables`` otherwise."""
    if variables is None:
        return tuple(f"x{i}" for i in range(n))
    rule = f"`variables` must be a sequence of n = {n} distinct names (Python identifiers), one per coordinate"
    if isinstance(variables, (str, bytes)) or not hasattr(variables, "__iter__"):
        raise TypeError(f"{rule}; got {variables!r}.")
    names = tuple(variables)
    bad = [v for v in names if not isinstance(v, str) or not v.isidentifier() or keyword.iskeyword(v)]
    if bad:
        raise ValueError(f"{rule}; {bad[0]!r} is not an identifier.")
    if len(names) != n:
        raise ValueError(f"{rule}; got {len(names)} names.")
    repeated = _validate.repeated(names)
    if repeated:
        raise ValueError(f"{rule}; {repeated[0][0]!r} is given {repeated[0][1]} times.")
    return names


def _one_form(names, given, role, required):
    """Exactly one of the matrix ``given[role]`` and the action ``given[role + "_apply"]`` (at most one where the
    operator is optional), else a TypeError naming both."""
    matrix, action = names[role], names[role + "_apply"]
    if given[role] is not None and given[role + "_apply"] is not None:
        raise TypeError(
            f"give `{matrix}` (a matrix function of (x, params)) or `{action}` (its action, a function "
            f"of (x, v, params)), not both."
        )
    if required and given[role] is None and given[role + "_apply"] is None:
        what = "the Poisson tensor" if role == "P" else "the friction matrix"
        raise TypeError(
            f"give `{matrix}`, {what} as an (n, n) matrix function of (x, params), or `{action}`, its action "
            f"v -> {matrix}(x) v as a function of (x, v, params)."
        )


def _paper_metric(gh):
    return np.outer(gh, gh) - np.eye(gh.size) * (gh @ gh)


def _shown_params(params):
    """The params for ``repr``: the values up to 16 of them, else their number and a digest (tells systems apart)."""
    if params.size <= 16:
        return repr(params.tolist())
    digest = hashlib.sha256(np.ascontiguousarray(params).tobytes()).hexdigest()[:12]
    return f"<{params.size} values, sha256 {digest}>"


__all__ = ["GenericSystem", "MetriplecticSystemN"]
