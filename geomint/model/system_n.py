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

The kernels receive both as ``layout.ModelN``.  Design notes: /work/shared/DESIGN_RN.md, section 1.
"""

from __future__ import annotations

import hashlib
import keyword
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _user_errors, _validate
from .._kernels.layout import PAPER_METRIC, USER_METRIC, ModelN
from .checks import check_dim, check_samples, check_structure_n
from .functions import (
    ModelFunctionsN,
    array_function,
    check_returned_shapes,
    first_class,
    matrix_function,
    no_metric,
    scalar_function,
)
from .system import MetriplecticSystem, _check_eps

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    Vector = npt.NDArray[np.float64]

#: the roles of the user functions in ``dx/dt = P grad H + eps D grad S``, and their names in the Fish form
_FISH_NAMES = {"H": "H", "grad_H": "grad_H", "S": "S", "grad_S": "grad_S", "P": "P", "M": "metric"}
_GENERIC_NAMES = {"H": "E", "grad_H": "grad_E", "S": "S", "grad_S": "grad_S", "P": "L", "M": "M"}


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
    eps : float, default 1.0
        The perturbation parameter, ``eps >= 0``.
    params : sequence of float
        Passed to every function.
    dim : int
        The dimension n >= 2 of the state.
    metric : numba-jitted function ``(x, params) -> (n, n) float64 array``, optional
        A metric G to use instead of the paper's g: symmetric, negative
        semidefinite, ``G grad H = 0``.
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
        ``ValueError`` naming the argument.

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
        samples: npt.ArrayLike | None = None,
        check: bool = True,
        variables: Any = None,
        J: Any = None,
        exact_flows: Any = None,
    ) -> None:
        if J is not None:
            raise TypeError(
                "`J` (an axial vector) describes a Poisson tensor in R^3 only: in R^n give `P`, the (n, n) skew matrix."
            )
        if exact_flows is not None:
            raise TypeError("`exact_flows` are declared for systems in R^3 only.")
        if P is None:
            raise TypeError("give `P`, the Poisson tensor as an (n, n) skew matrix function of (x, params).")
        self._setup(
            dict(H=H, grad_H=grad_H, S=S, grad_S=grad_S, P=P, M=metric),
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
        self.functions = ModelFunctionsN(
            H=scalar_function(names["H"], given["H"], n),
            grad_H=array_function(names["grad_H"], given["grad_H"], n),
            S=scalar_function(names["S"], given["S"], n),
            grad_S=array_function(names["grad_S"], given["grad_S"], n),
            P=matrix_function(names["P"], given["P"], n),
            M=None if given["M"] is None else matrix_function(names["M"], given["M"], n),
        )
        self._samples = check_samples(samples, n)
        self._checked = bool(check)
        self._check(check)

    def _check(self, structure):
        """Shapes at the first sample; the structure at all of them when ``structure``."""
        f, n = self.functions, self.dim
        wanted = {self._names["grad_H"]: (f.grad_H, (n,)), self._names["grad_S"]: (f.grad_S, (n,))}
        wanted[self._names["P"]] = (f.P, (n, n))
        if f.M is not None:
            wanted[self._names["M"]] = (f.M, (n, n))
        check_returned_shapes(wanted, self._samples[0], self._params)
        if structure:
            with np.errstate(all="ignore"):  # finite differences of huge values overflow: the checks see inf/nan
                check_structure_n(self)

    # -- the model as kernels receive it ------------------------------------------------
    @property
    def metric(self) -> int:
        """``layout.PAPER_METRIC`` (the paper's g) or ``layout.USER_METRIC`` (the user's G, GENERIC's M)."""
        return PAPER_METRIC if self.functions.M is None else USER_METRIC

    @property
    def model(self) -> ModelN:  # pyright: ignore[reportIncompatibleVariableOverride]  # the R^n engine's model
        """``layout.ModelN(H, grad_H, S, grad_S, P, M, params, metric, direction, origin)``: the system as the
        R^n kernels receive it, the functions as compiled first-class function objects.  Where the paper's metric
        is used, M is a placeholder of the same type (an (n, n) zero matrix, never called)."""
        if "_model" not in self.__dict__:
            f = self.functions
            M = no_metric if f.M is None else f.M
            handles = tuple(first_class(fn) for fn in (f.H, f.grad_H, f.S, f.grad_S, f.P, M))
            self._model = ModelN(*handles, self._params, self.metric, self.direction, self._origin())  # pyright: ignore[reportCallIssue]
        return self._model

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
            other.__dict__.pop("_model", None)
            other._check(self._checked)
        if hamiltonian is not None:
            if not isinstance(hamiltonian, (bool, np.bool_)):
                raise TypeError(f"`hamiltonian` must be True or False; got {hamiltonian!r}.")
            other.hamiltonian = bool(hamiltonian)
        if eps is not None:
            other.eps = _check_eps(eps)
        return other

    def __repr__(self) -> str:
        effects = "" if self.hamiltonian else ", hamiltonian=False"
        metric = "" if self.functions.M is None or self.direction > 0 else ", metric=user"
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

    def _call(self, role, x):
        """The user function of ``role`` (``H``, ``grad_H``, ``S``, ``grad_S``, ``P``, ``M``) at the state ``x``;
        an exception it raises becomes a ``UserFunctionError`` naming it by the user's name."""
        fn = getattr(self.functions, role)
        try:
            value = fn(x if x.flags.c_contiguous else np.ascontiguousarray(x), self._params)
        except Exception as error:
            raise _user_errors.UserFunctionError(self._names[role], x.tolist(), error) from error
        return float(value) if role in ("H", "S") else np.asarray(value, dtype=np.float64)

    def _evaluate_one(self, x, with_matrices=False):
        """``(H, S, grad H, grad S, P, M)`` at one state (P and M only ``with_matrices``; M None for the paper's
        metric)."""
        values = [self._call(role, x) for role in ("H", "S", "grad_H", "grad_S")]
        if not with_matrices:
            return (*values, None, None)
        M = None if self.functions.M is None else self._call("M", x)
        return (*values, self._call("P", x), M)

    def _over(self, x, one):
        """``one(state)`` at one state ``(n,)``, stacked over many ``(m, n)``."""
        X, single = self._states(x)
        values = [one(row) for row in X]
        return values[0] if single else np.array(values)

    def raising_function(self, x: npt.ArrayLike) -> tuple[str, Exception] | None:
        """``(name, exception)`` of the first user function that raises at ``x``, or None if none does."""
        X, _ = self._states(x)
        for role in ("H", "S", "grad_H", "grad_S", "P", "M"):
            fn = getattr(self.functions, role)
            if fn is None:
                continue
            try:
                fn(X[0].copy(), self._params)
            except Exception as error:  # noqa: BLE001 - any exception of the user's is the answer
                return self._names[role], error
        return None

    def H(self, x: npt.ArrayLike) -> Any:  # a float at one state (n,), an array at many (m, n)
        """The energy at ``x``."""
        return self._over(x, lambda row: self._call("H", row))

    def S(self, x: npt.ArrayLike) -> Any:  # a float at one state (n,), an array at many (m, n)
        """The Casimir (Fish form) or entropy (GENERIC) at ``x``."""
        return self._over(x, lambda row: self._call("S", row))

    def grad_H(self, x: npt.ArrayLike) -> Vector:
        return self._over(x, lambda row: self._call("grad_H", row))

    def grad_S(self, x: npt.ArrayLike) -> Vector:
        return self._over(x, lambda row: self._call("grad_S", row))

    def P(self, x: npt.ArrayLike) -> Vector:
        """The Poisson tensor, shape (n, n) at one state, (m, n, n) at many."""
        return self._over(x, lambda row: self._call("P", row))

    def g(self, x: npt.ArrayLike) -> Vector:
        """The paper's metric ``grad H grad H^T - |grad H|^2 I``, shape (n, n) or (m, n, n)."""
        return self._over(x, lambda row: _paper_metric(self._call("grad_H", row)))

    def D(self, x: npt.ArrayLike) -> Vector:
        """The metric the field uses: the paper's g, or the user's G (GENERIC: M); (n, n) or (m, n, n)."""
        if self.functions.M is None:
            return self.g(x)
        return self._over(x, lambda row: self._call("M", row))

    def _dissipative(self, row):
        """``D grad S`` at one state (with ``grad S``), D applied without forming g where it is the paper's."""
        gs = self._call("grad_S", row)
        if self.functions.M is not None:
            return self._call("M", row) @ gs, gs
        gh = self._call("grad_H", row)
        return gh * (gh @ gs) - (gh @ gh) * gs, gs

    def xi_P(self, x: npt.ArrayLike) -> Vector:
        """The Hamiltonian field ``P grad H``."""
        return self._over(x, lambda row: self._call("P", row) @ self._call("grad_H", row))

    def xi_g(self, x: npt.ArrayLike) -> Vector:
        """The dissipative field ``D grad S`` (without eps)."""
        return self._over(x, lambda row: self._dissipative(row)[0])

    def _xi_row(self, row):
        field = self.eps * self._dissipative(row)[0]
        if self.hamiltonian:
            field = self._call("P", row) @ self._call("grad_H", row) + field
        return field

    def xi(self, x: npt.ArrayLike) -> Vector:
        """The field ``P grad H + eps D grad S`` (without the first term when the Hamiltonian part is off)."""
        return self._over(x, self._xi_row)

    def dH_dt(self, x: npt.ArrayLike) -> Any:
        """``grad H . xi`` as computed: 0 up to round-off (the structure's residual)."""
        return self._over(x, lambda row: float(self._call("grad_H", row) @ self._xi_row(row)))

    def dS_dt(self, x: npt.ArrayLike) -> Any:
        """The rate of S along the flow, ``eps grad S . D grad S`` (``P grad S = 0`` drops the Hamiltonian term):
        for the paper's metric ``-eps |grad H|^2 |Pi_H grad S|^2``, a sum of squares (<= 0 in floating point
        too); <= 0 in the Fish form, >= 0 in GENERIC."""
        return self._over(x, self._dS_dt_row)

    def _dS_dt_row(self, row):
        if self.functions.M is not None:
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
    params, dim, name, samples, check, variables
        As for ``MetriplecticSystemN``; the checks name ``E``, ``grad_E``, ``L`` and ``M``.

    ``E(x)`` is ``H(x)``, ``L(x)`` is ``P(x)`` and ``M(x)`` is ``D(x)``.
    Conserved quantities besides E are not declared (yet).
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
        L: Callable[..., Any],
        M: Callable[..., Any],
        params: npt.ArrayLike = (),
        dim: int | None = None,
        name: str = "custom",
        samples: npt.ArrayLike | None = None,
        check: bool = True,
        variables: Any = None,
    ) -> None:
        self._setup(
            dict(H=E, grad_H=grad_E, S=S, grad_S=grad_S, P=L, M=M),
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
    repeated = sorted({v for v in names if names.count(v) > 1})
    if repeated:
        raise ValueError(f"{rule}; {repeated[0]!r} is given {names.count(repeated[0])} times.")
    return names


def _paper_metric(gh):
    return np.outer(gh, gh) - np.eye(gh.size) * (gh @ gh)


def _shown_params(params):
    """The params for ``repr``: the values up to 16 of them, else their number and a digest (tells systems apart)."""
    if params.size <= 16:
        return repr(params.tolist())
    digest = hashlib.sha256(np.ascontiguousarray(params).tobytes()).hexdigest()[:12]
    return f"<{params.size} values, sha256 {digest}>"


__all__ = ["GenericSystem", "MetriplecticSystemN"]
