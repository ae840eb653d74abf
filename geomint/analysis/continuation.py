"""Continuation in eps: each equilibrium, curve of equilibria and rest cycle followed as eps grows from 0.

The paper's closing remark (D. Fish, *Dissipative perturbations of 3d
Hamiltonian systems*, section 3) asks how the stability of equilibria changes
with the parameter eps of ``dx/dt = xi_P + eps xi_g``.  Two facts frame the answer:

* For ``eps > 0``, ``xi = 0`` iff ``xi_P = 0`` and ``xi_g = 0`` (Lemma 6: they are
  orthogonal), a condition that does not involve eps: **the equilibria do not
  move with eps**, only their eigenvalues do.  ``continuation`` re-solves each
  point at every eps anyway and records how far it moved.
* At ``eps = 0`` the regular equilibria are those of the Hamiltonian system
  (centres and saddles on the level set); a verdict can change at ``eps = 0+``,
  and at any ``eps > 0`` where an eigenvalue crosses the imaginary axis — which
  ``analysis.factorise`` shows cannot happen at a non-degenerate regular
  equilibrium with ``grad S || grad H``; this module finds what happens elsewhere.

``continuation`` finds the equilibria at the largest eps, follows them over
the given eps values and locates every change of verdict (stable / unstable /
neutral) or of kind (node / focus / saddle / centre / degenerate) by bisection.
It works on a sampled level surface, in R^3.  ``continuation_n`` does the same
in R^n for the equilibria of ``analysis.critical_points`` (the critical points of
S on the level set), with the same ``Branch``, ``Change`` and bisection.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from . import critical_points as _critical
from . import equilibria as _equilibria
from . import stability as _stability
from . import zero_sets as _zero_sets
from ._common import require_three

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

_BISECTIONS = 48


@dataclass(frozen=True)
class Change:
    """A change of ``(verdict, kind)`` between ``eps_low`` and ``eps_high`` (bisected to ``eps``).

    ``at_zero``: the bracket started at ``eps = 0`` and bisection ended below
    ``1e-3`` of its initial width, i.e. where the linearisation stops resolving
    real parts (``analysis.verdict``): the change happens as soon as ``eps > 0``.
    """

    eps_low: float
    eps_high: float
    before: tuple
    after: tuple

    at_zero: bool = False

    @property
    def eps(self) -> float:
        """Midpoint of the final bracket (0 for a change at ``eps = 0+``)."""
        return 0.0 if self.at_zero else 0.5 * (self.eps_low + self.eps_high)

    def __str__(self) -> str:
        where = "eps = 0+" if self.at_zero else f"eps = {self.eps:.6g}"
        return f"{'/'.join(self.before)} -> {'/'.join(self.after)} at {where}"


@dataclass(frozen=True)
class Branch:
    """One equilibrium, curve of equilibria or rest cycle followed in eps.

    Attributes
    ----------
    object : str
        ``"equilibrium"``, ``"curve"`` or ``"cycle"`` (R^3); ``"equilibrium"`` or ``"manifold"`` (``continuation_n``).
    x : ndarray, shape (n,)
        The point (for a curve, cycle or manifold, its first point) at the largest eps.
    label : str
        The reason (or ``"dS = 0 cycle"``) and the point, for tables and legends.
    eps : ndarray, shape (k,)
    eigenvalues : ndarray, shape (k, 2), complex
        Tangent-plane eigenvalues; for a curve ``(0, normal eigenvalue)`` at its
        first point; for a cycle ``(0, Floquet exponent)``:
        the last column is the informative one.  In R^n (``continuation_n``)
        shape ``(k, d)``: the eigenvalues of ``CriticalPoint.eigenvalues``, sorted.
    verdicts, kinds : ndarray of str, shape (k,)
        Kinds are those of ``analysis.eigenvalue_kind`` (``"cycle"`` for cycles).
    displacement : float
        Largest distance the point moved between eps values (0 for cycles).
    changes : list of Change
    """

    object: str
    x: np.ndarray
    label: str
    eps: np.ndarray
    eigenvalues: np.ndarray
    verdicts: np.ndarray
    kinds: np.ndarray
    displacement: float
    changes: list = field(default_factory=list)


@dataclass(frozen=True)
class Continuation:
    """The branches of one system on one level set ``H = H0``."""

    name: str
    H0: float
    branches: list

    def rows(self) -> list[list[str]]:
        """Table rows: label, verdict at the smallest and at the largest eps, and the changes found."""
        rows = []
        for b in self.branches:
            changes = "; ".join(str(c) for c in b.changes) or "none"
            rows.append([b.label, f"{b.verdicts[0]} {b.kinds[0]}", f"{b.verdicts[-1]} {b.kinds[-1]}", changes])
        return rows


def continuation(
    system: MetriplecticSystem, H0: float, eps_values: npt.ArrayLike, center: npt.ArrayLike | None = None, n: int = 2000
) -> Continuation:
    """Follow the equilibria and rest cycles of ``system`` on ``H = H0`` over ``eps_values``.

    Parameters
    ----------
    system : MetriplecticSystem
        Its own eps is ignored; ``system.with_effects(eps=e)`` is used for each ``e``.
    H0 : float
    eps_values : array_like, shape (k,)
        Increasing values ``>= 0``, ``k >= 2``, the largest ``> 0``.
    center, n
        As in ``analysis.equilibria`` (where the search runs, at the largest eps).

    Returns
    -------
    Continuation

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5)
    >>> result = continuation(body, 0.75, [0.0, 0.5, 4.0], n=1000)
    >>> top = [b for b in result.branches if b.x[2] > 0.5][0]   # the pole on the axis of c
    >>> top.verdicts.tolist(), top.kinds.tolist()
    (['neutral', 'stable', 'stable'], ['centre', 'focus', 'node'])
    >>> [str(c) for c in top.changes]   # eps* = 2 sqrt((c - a)(c - b)) / (c z0 |b - a|) = 1.88562
    ['neutral/centre -> stable/focus at eps = 0+', 'stable/focus -> stable/node at eps = 1.88562']
    """
    require_three(system, "`continuation` (equilibria found on a sampled level surface)", "`continuation_n`")
    eps_values = _check_eps_values(eps_values)
    top = system.with_effects(eps=float(eps_values[-1]))
    branches = [
        _follow_equilibrium(system, H0, e, eps_values)
        if isinstance(e, _equilibria.Equilibrium)
        else _follow_curve(system, H0, e, eps_values)
        for e in _equilibria.equilibria(top, H0, center=center, n=n)
    ]
    branches += [
        _follow_cycle(system, c, eps_values) for c in _equilibria.rest_cycles(top, H0, center=center, n=n) if c.periodic
    ]
    return Continuation(system.name, float(H0), branches)


def continuation_n(
    system: MetriplecticSystem,
    H0: float,
    eps_values: npt.ArrayLike,
    *,
    starts: npt.ArrayLike | None = None,
    n_starts: int = 64,
    box: Any = None,
    seed: int = 0,
    hess_H: Callable[[np.ndarray], Any] | None = None,
    hess_S: Callable[[np.ndarray], Any] | None = None,
    slide: bool = True,
) -> Continuation:
    """Follow the equilibria of ``critical_points`` on ``H = H0`` and their stability over ``eps_values``, in R^n.

    The critical points of S on the level set are found at the largest eps (``analysis.critical_points`` with
    ``starts``, ``n_starts``, ``box``, ``seed``, ``hess_H``, ``hess_S``, ``slide``); each that is an equilibrium
    is re-solved at every eps (``analysis.critical_point`` from the point found at the next larger eps) and
    linearised there, across its manifold when it lies on one.  Changes of verdict or kind are located by
    bisection, as ``continuation`` does in R^3.  In the Fish form the points do not move with eps (``grad S =
    lam grad H`` does not involve it; ``Branch.displacement`` records the check), and with the paper's metric the
    verdict is fixed for every ``eps > 0`` by the type of the point (the inertia argument in
    ``analysis.critical_points``): the changes are at ``eps = 0+`` (a centre becomes a focus) and between foci
    and nodes.  For a GENERIC system eps scales M (``with_effects``).  Works for systems in R^3 too.

    Parameters
    ----------
    system : MetriplecticSystemN, GenericSystem or MetriplecticSystem
        Its own eps is ignored; ``system.with_effects(eps=e)`` is used for each ``e``.
    H0 : float
    eps_values : array_like, shape (k,)
        Increasing values ``>= 0``, ``k >= 2``, the largest ``> 0``.

    Returns
    -------
    Continuation
        One ``Branch`` per equilibrium (``object`` ``"equilibrium"``, or ``"manifold"`` for a manifold of them);
        its eigenvalues are those of ``CriticalPoint.eigenvalues``, sorted, ``(k, d)``.

    Examples
    --------
    >>> import geomint
    >>> fish = geomint.systems.random_fish(3, seed=1)
    >>> result = continuation_n(fish, 1.0, [0.0, 0.5, 2.0], n_starts=8)
    >>> low = result.branches[0]                  # the least S: a minimum, stable as soon as eps > 0
    >>> low.verdicts.tolist(), [c.at_zero for c in low.changes][:1]
    (['neutral', 'stable', 'stable'], [True])
    """
    eps_values = _check_eps_values(eps_values)
    top = system.with_effects(eps=float(eps_values[-1]))
    hessians = {"hess_H": hess_H, "hess_S": hess_S}
    found = _critical.critical_points(
        top, H0, starts=starts, n_starts=n_starts, box=box, seed=seed, slide=slide, **hessians
    )
    branches = [_follow_critical(system, H0, c, eps_values, hessians) for c in found if c.equilibrium]
    return Continuation(system.name, float(H0), branches)


def _follow_critical(system, H0, point, eps_values, hessians):
    size = len(point.eigenvalues)

    def state(eps, x):
        c = _critical.critical_point(system.with_effects(eps=eps), H0, x, **hessians)
        lam = np.sort_complex(c.eigenvalues) if len(c.eigenvalues) == size else np.full(size, np.nan, dtype=complex)
        return c.x, lam, (c.verdict, c.kind)

    where = f"a {point.manifold_dim}-dimensional set of equilibria through" if point.manifold_dim else "equilibrium at"
    label = f"{point.type} of S (S = {point.S:.6g}): {where} {_point(point.x)}"
    return _follow("manifold" if point.manifold_dim else "equilibrium", point.x, label, eps_values, state)


def _state_of_point(system, H0, x, eps):
    """``(x, sorted eigenvalues, (verdict, kind), Jacobian norm)`` of the equilibrium near ``x`` at ``eps``."""
    s = system.with_effects(eps=eps)
    x = _zero_sets.refine(s, x, H0)
    jacobian, lam = _stability.linearise(s, x)
    scale = float(np.linalg.norm(jacobian)) + 1e-300
    return x, np.sort_complex(lam), (_stability.verdict(lam, scale), _stability.eigenvalue_kind(lam, scale)), scale


def _follow_equilibrium(system, H0, equilibrium, eps_values):
    def state(eps, x):
        return _state_of_point(system, H0, x, eps)[:3]

    label = f"{', '.join(equilibrium.reasons) or 'P = 0'} at {_point(equilibrium.x)}"
    return _follow("equilibrium", equilibrium.x, label, eps_values, state)


def _follow_curve(system, H0, curve, eps_values):
    def state(eps, x):
        x, lam, _, scale = _state_of_point(system, H0, x, eps)
        normal = lam[np.argmax(np.abs(lam))].real
        return x, np.array([0.0, normal], dtype=complex), (_stability.verdict([normal], scale), "curve")

    label = f"curve of equilibria ({', '.join(curve.reasons) or 'P = 0'}) through {_point(curve.x)}"
    return _follow("curve", curve.x, label, eps_values, state)


def _follow_cycle(system, cycle, eps_values):
    def state(eps, x):
        c = _equilibria.classify_cycle(system.with_effects(eps=eps), cycle.points, cycle.closed)
        return x, np.array([0.0, c.exponent], dtype=complex), (c.verdict, "cycle")

    return _follow("cycle", cycle.points[0], f"dS = 0 cycle through {_point(cycle.points[0])}", eps_values, state)


def _follow(kind, x_top, label, eps_values, state):
    """Evaluate ``state(eps, x) -> (x, eigenvalues, (verdict, kind))`` from the largest eps down; bisect changes."""
    records, x = [], x_top
    for eps in eps_values[::-1]:
        record = state(float(eps), x)
        records.append(record)
        x = record[0]
    records.reverse()
    points = np.array([r[0] for r in records])
    changes = [
        _bisect(state, float(eps_values[k]), float(eps_values[k + 1]), records[k][2], records[k + 1][2], points[k])
        for k in range(len(eps_values) - 1)
        if records[k][2] != records[k + 1][2]
    ]
    return Branch(
        kind,
        x_top,
        label,
        np.asarray(eps_values),
        np.array([r[1] for r in records]),
        np.array([r[2][0] for r in records]),
        np.array([r[2][1] for r in records]),
        float(np.max(np.linalg.norm(points - x_top, axis=1))),
        changes,
    )


def _bisect(state, low, high, before, after, x):
    from_zero, width = low == 0.0, high - low
    for _ in range(_BISECTIONS):
        middle = 0.5 * (low + high)
        if middle in (low, high):
            break
        if state(middle, x)[2] == before:
            low = middle
        else:
            high = middle
    return Change(low, high, before, after, at_zero=from_zero and high < 1e-3 * width)


def _point(x):
    shown = [f"{v:.3g}" for v in np.where(np.abs(x) < 1e-9, 0.0, x)]
    if len(shown) > 8:  # a long state: its first and last entries
        shown = [*shown[:3], "...", *shown[-3:]]
    return "(" + ", ".join(shown) + ")"


def _check_eps_values(eps_values):
    try:
        values = np.asarray(eps_values, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"`eps_values` must be a sequence of real numbers; got {eps_values!r}.") from None
    if values.ndim != 1 or values.size < 2:
        raise ValueError(f"`eps_values` must be a 1-D sequence of at least 2 values; got shape {values.shape}.")
    if not (np.all(np.isfinite(values)) and values[0] >= 0.0 and np.all(np.diff(values) > 0) and values[-1] > 0.0):
        raise ValueError(f"`eps_values` must be finite, increasing and >= 0; got {values.tolist()!r}.")
    return values
