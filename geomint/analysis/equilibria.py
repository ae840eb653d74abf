"""Equilibria on a level set ``{H = H0}``, each explained and classified; curves of equilibria; rest cycles [R3].

``equilibria`` finds the zeros of ``xi``, ``xi_P`` or ``xi_g`` on a level
set, labels each with its reason and proposition (``propositions``) and
classifies it by the linearisation restricted to the tangent plane of the
level set (``stability``); connected sets of equilibria (the circle of the
rigid body with ``a = b``) come back as one ``EquilibriumCurve``.
``rest_cycles`` (3-D only [R3]: curves on a two-dimensional level surface)
finds the invariant curves ``{grad S = 0} n {H = H0}`` of Prop. 15 and their
Floquet exponents.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._common import check_field, field_of, require_three
from .propositions import REASONS, explain
from .stability import eigenvalue_kind, linearise, verdict
from .zero_sets import zero_set

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..model.system import MetriplecticSystem


@dataclass(frozen=True)
class Equilibrium:
    """An isolated equilibrium on ``H = H0``.

    Attributes
    ----------
    x : ndarray, shape (3,)
        The point.
    field : str
        ``"xi"``, ``"xi_P"`` or ``"xi_g"``: the field it is a zero of.
    regular : bool
        ``J(x) != 0`` (the Poisson tensor has rank 2).
    reasons : tuple of str
        Keys of ``REASONS`` that hold at ``x`` (empty only at a non-regular zero of ``xi_P``).
    proposition : str
        The paper's statement that explains the point.
    jacobian : ndarray, shape (2, 2)
        The linearisation restricted to the tangent plane ``grad H^perp``.
    eigenvalues : ndarray, shape (2,), complex
    verdict : str
        ``"stable"``, ``"unstable"`` or ``"neutral"`` (see ``verdict``).
    """

    x: np.ndarray
    field: str
    regular: bool
    reasons: tuple
    proposition: str
    jacobian: np.ndarray
    eigenvalues: np.ndarray
    verdict: str

    @property
    def kind(self) -> str:
        """``"node"``, ``"focus"``, ``"saddle"``, ``"centre"`` or ``"degenerate"`` (see ``eigenvalue_kind``)."""
        return eigenvalue_kind(self.eigenvalues, _scale(self.jacobian))


@dataclass(frozen=True)
class EquilibriumCurve:
    """A curve of equilibria on ``H = H0``, traced point by point.

    Attributes
    ----------
    points : ndarray, shape (m, 3)
        Points along the curve, in order (``closed``: the last joins the first).
    closed : bool
    field, proposition : str
        As in ``Equilibrium`` (the proposition of the first point).
    regular : ndarray of bool, shape (m,)
    reasons : tuple of str
        Reasons that hold at every point of the curve.
    normal_eigenvalues : ndarray, shape (m,)
        At each point the eigenvalue of the tangent-plane Jacobian across the
        curve (the other one, along the curve, is zero).
    verdicts : ndarray of str, shape (m,)
        ``"stable"`` (attracting), ``"unstable"`` or ``"neutral"`` per point.
    """

    points: np.ndarray
    closed: bool
    field: str
    regular: np.ndarray
    reasons: tuple
    proposition: str
    normal_eigenvalues: np.ndarray
    verdicts: np.ndarray

    @property
    def verdict(self) -> str:
        """The verdict shared by every point, or ``"mixed"``."""
        unique = set(self.verdicts.tolist())
        return unique.pop() if len(unique) == 1 else "mixed"

    @property
    def x(self) -> np.ndarray:
        """A representative point (the first)."""
        return self.points[0]


@dataclass(frozen=True)
class RestCycle:
    """A curve ``{grad S = 0} n {H = H0}``: invariant by Prop. 15, the flow on it is Hamiltonian.

    Attributes
    ----------
    points : ndarray, shape (m, 3)
    closed : bool
    periodic : bool
        True when the curve is closed and the component of ``xi`` along it keeps
        one sign (no equilibrium on it): it is then a periodic orbit.
    period : float
        ``oint ds / |xi|`` (``inf`` when not periodic).
    exponent : float
        Floquet exponent across the cycle, the time average of the surface
        divergence ``tr(J_T)`` of ``xi`` over one period (``nan`` when not periodic).
    verdict : str
        ``"stable"`` (attracting), ``"unstable"`` or ``"neutral"``; ``"not a cycle"`` when not periodic.
    """

    points: np.ndarray
    closed: bool
    periodic: bool
    period: float
    exponent: float
    verdict: str


def _scale(jacobian):
    return float(np.linalg.norm(jacobian)) + 1e-300


def equilibria(
    system: MetriplecticSystem, H0: float, field: str = "xi", center: npt.ArrayLike | None = None, n: int = 4000
) -> list[Equilibrium | EquilibriumCurve]:
    """Equilibria of ``field`` on the level set ``H = H0``, each explained and classified.

    Candidates are the local minima of ``|F|`` over each point's 8 nearest
    neighbours in an ``n``-point Fibonacci sample of the level set
    (``geomint.level_set``; the set must be star-shaped about ``center``,
    default the minimiser of H); each is refined by least squares on
    ``(F(x), H(x) - H0) = 0`` and kept when ``|F| <= 1e-9 max |F|``.  Where the
    zero set is a curve (the matrix ``[DF; grad H]`` has a null vector and a
    predictor-corrector step along it stays on the zero set) the curve is
    traced (``2 pi r / 96`` per step, ``r`` the largest distance of the level
    set from ``center``) and returned once, as an ``EquilibriumCurve``; an
    isolated equilibrium closer than one such step to a curve is not separated from it.

    Parameters
    ----------
    system : MetriplecticSystem
    H0 : float
    field : {"xi", "xi_P", "xi_g"}
        The full field, its Hamiltonian part, or its gradient part (without eps).
    center : array_like, shape (3,), optional
    n : int
        Sample size; raise it when equilibria lie closer than the sample spacing.

    Returns
    -------
    list of Equilibrium and EquilibriumCurve

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0)
    >>> found = equilibria(body, 0.75, n=1000)
    >>> sorted((e.verdict, e.reasons[0]) for e in found)[:2]
    [('stable', 'grad S || grad H'), ('stable', 'grad S || grad H')]
    >>> len(found)
    6
    """
    require_three(system, "`equilibria` (on a sampled level surface)", "`critical_points`")
    F = field_of(system, check_field(field))
    zeros = zero_set(system, H0, F, center, n)
    found = []
    for kind, data in zeros:
        if kind == "point":
            regular, reasons, proposition = explain(system, data, field)
            jacobian, lam = linearise(system, data, field)
            found.append(
                Equilibrium(data, field, regular, reasons, proposition, jacobian, lam, verdict(lam, _scale(jacobian)))
            )
        else:
            found.append(_equilibrium_curve(system, field, *data))
    return found


def rest_cycles(
    system: MetriplecticSystem,
    H0: float,
    center: npt.ArrayLike | None = None,
    n: int = 4000,
) -> list[RestCycle]:
    """The curves ``{grad S = 0} n {H = H0}`` and the stability of the flow ``xi`` across them.

    By Prop. 15 a regular point with ``grad S = 0`` lies on an invariant leaf
    on which the flow is Hamiltonian; on a level set of H such a leaf meets
    ``H = H0`` in curves.  Where ``xi`` does not vanish on the curve it is a
    periodic orbit with period ``T = oint ds / |xi|`` and Floquet exponent

        lambda = (1/T) oint tr(J_T(x)) ds / |xi(x)|,

    ``J_T`` the tangent-plane Jacobian (its trace is the surface divergence of
    ``xi``); ``lambda < 0``: the cycle attracts.
    [R3]: the curves are traced on a two-dimensional level surface.

    Examples
    --------
    >>> import geomint
    >>> osc = geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0), eps=1.0)   # S = z^2
    >>> [cycle] = rest_cycles(osc, 0.5, n=1000)        # the equator of the unit sphere
    >>> cycle.verdict, round(cycle.exponent, 6)        # -eps rho^2 S''(0) = -2
    ('stable', -2.0)
    >>> round(cycle.period, 2)                         # 2 pi, to the resolution of the traced points
    6.28
    """
    require_three(system, "`rest_cycles` (curves on a level surface)", "`critical_points`")
    zeros = zero_set(system, H0, lambda X: np.atleast_2d(system.grad_S(X)), center, n)
    return [classify_cycle(system, points, closed) for kind, (points, closed) in zeros if kind == "curve"]


def classify_cycle(system: MetriplecticSystem, points: npt.NDArray[np.float64], closed: bool) -> RestCycle:
    """A ``RestCycle`` for an invariant curve given by ``points`` (shape ``(m, 3)``, in order) under ``system.xi``.

    Used by ``rest_cycles``; call it directly to re-classify a known curve for
    another eps (``system.with_effects(eps=...)``).
    """
    chords = np.diff(points, axis=0, append=points[:1])
    segment = np.linalg.norm(chords, axis=1)
    along = np.sum(system.xi(points) * chords, axis=1) / segment  # xi is tangent to the invariant curve
    if not closed or along.min() * along.max() <= 0.0 or np.abs(along).min() <= 1e-6 * np.abs(along).max():
        return RestCycle(points, closed, False, np.inf, np.nan, "not a cycle")
    jacobians = linearise(system, points)[0]
    # trapezoidal rule for oint ds / |xi| (xi is tangent to the curve: |xi| is the speed along it)
    dt = 0.5 * (segment + np.roll(segment, 1)) / np.linalg.norm(system.xi(points), axis=1)
    period = float(dt.sum())
    # the tangent Jacobian vanishes on a rigidly rotating cycle: measure against the rotation rate too
    scale = float(np.linalg.norm(jacobians, axis=(1, 2)).max()) + 2.0 * np.pi / period
    exponent = float(np.sum(dt * np.trace(jacobians, axis1=1, axis2=2)) / period)
    return RestCycle(points, closed, True, period, exponent, verdict([exponent], scale))


def _equilibrium_curve(system, field, points, closed):
    regular, reasons, propositions = [], None, []
    for x in points:
        r, why, proposition = explain(system, x, field)
        regular.append(r)
        propositions.append(proposition)
        reasons = set(why) if reasons is None else reasons & set(why)
    jacobians, eig = linearise(system, points, field)
    lam = eig[np.arange(len(points)), np.argmax(np.abs(eig), axis=1)].real  # pyright: ignore[reportAttributeAccessIssue]
    scale = float(np.linalg.norm(jacobians, axis=(1, 2)).max())
    verdicts = np.array([verdict([v], scale) for v in lam])
    return EquilibriumCurve(
        points,
        closed,
        field,
        np.array(regular),
        tuple(k for k in REASONS if k in reasons),  # pyright: ignore[reportOperatorIssue]
        propositions[0],
        lam,
        verdicts,
    )


def equilibrium_points(
    system: MetriplecticSystem,
    H0: float,
    center: npt.ArrayLike | None,
    n: int = 4000,
) -> list[tuple[np.ndarray, str]]:
    """``[(x, verdict), ...]`` on ``H = H0``: the points of ``equilibria`` with their verdicts, a curve of
    equilibria contributing each of its traced points (what a figure marks)."""
    pairs = []
    for found in equilibria(system, H0, "xi", center, n):
        if isinstance(found, EquilibriumCurve):
            pairs.extend(zip(found.points, found.verdicts.tolist()))
        else:
            pairs.append((found.x, found.verdict))
    return pairs
