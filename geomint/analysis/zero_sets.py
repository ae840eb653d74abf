"""Zeros of a field on a level set ``{H = H0}``: least-squares correction and curve tracing.

A point is corrected onto ``{Z = 0, H = H0}`` by least squares (scipy's
``least_squares``, trust-region reflective, tolerances 1e-15); where the
matrix ``[DZ; grad H]`` has a one-dimensional null space the zero set is a
curve, traced by a predictor step of ``2 pi r / 96`` along the null vector and
a correction on the plane through the predicted point normal to it
(pseudo-arclength continuation).  ``zero_set`` starts from the local minima
of ``|Z|`` in a Fibonacci sample of the level set (``level_set``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np

from . import level_set as _level_set
from ._common import ZERO, as_points, check_field, check_level, field_of, require_three

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

_STEPS_PER_TURN = 96  # curve tracing: steps per 2 pi radius


def refine(system: MetriplecticSystem, x0: npt.ArrayLike, H0: float, field: str = "xi") -> npt.NDArray[np.float64]:
    """The zero of ``field`` on ``H = H0`` nearest ``x0`` (least squares on ``(F(x), H(x) - H0)``).

    Raises ``ValueError`` when no point with ``|F| <= 1e-9 |F|_scale`` and
    ``H = H0`` (to 1e-12 relative) is found from ``x0``; ``|F|_scale`` is the
    largest ``|grad H| (|J| + max(eps, 1) |grad H| |grad S|)`` at ``x0`` and at
    ``x0 +- 0.1 (1 + |x0|) e_i`` (1 where all vanish).

    Examples
    --------
    >>> import numpy as np, geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5)
    >>> x = refine(body, [0.01, 0.02, 0.99], 0.75)
    >>> bool(np.allclose(x, [0.0, 0.0, 1.0], rtol=0.0, atol=1e-12))
    True
    """
    require_three(system, "`refine`", "`critical_point`")
    x0 = cast("npt.NDArray[np.float64]", as_points(x0)[0])
    H0 = check_level(H0)
    F = field_of(system, check_field(field))
    radius = 1.0 + float(np.linalg.norm(x0))
    around = np.concatenate([x0[None], x0 + 0.1 * radius * np.eye(3), x0 - 0.1 * radius * np.eye(3)])
    gh, gs, j = (np.linalg.norm(np.atleast_2d(f(around)), axis=1) for f in (system.grad_H, system.grad_S, system.J))
    scale = float(np.max(gh * (j + max(system.eps, 1.0) * gh * gs))) or 1.0
    x = _Corrector(system, H0, F, scale, max(abs(H0), abs(float(system.H(x0))), 1e-300), radius).correct(x0)
    if x is None:
        raise ValueError(f"`x0` must lie near a zero of {field} on H = {H0!r}; none found from {x0.tolist()}.")
    return x


def zero_set(
    system: MetriplecticSystem,
    H0: float,
    Z: Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]],
    center: npt.ArrayLike | None,
    n: int,
) -> list[tuple[str, Any]]:
    """Isolated zeros and traced zero curves of ``Z`` on ``H = H0``: ``[("point", x) | ("curve", (pts, closed))]``.

    ``Z`` maps points ``(m, 3)`` to values ``(m, k)``.  Candidates are the local
    minima of ``|Z|`` over each point's 8 nearest neighbours in an ``n``-point
    Fibonacci sample of the level set (star-shaped about ``center``, default
    the minimiser of H), each corrected by ``_Corrector.correct``; a
    correction within one tracing step of a curve already found is dropped.
    """
    from scipy import spatial  # imported on use: a new process need not load it

    H0 = check_level(H0)
    if not (isinstance(n, (int, np.integer)) and n >= 20):
        raise ValueError(f"`n` must be an integer >= 20; got {n!r}.")
    center = (
        _level_set.energy_minimiser(system) if center is None else cast("npt.NDArray[np.float64]", as_points(center)[0])
    )
    points = _level_set.on_rays(system, H0, _level_set.fibonacci_directions(int(n)), center)
    size = np.linalg.norm(Z(points), axis=1)
    scale = float(size.max())
    if scale == 0.0:
        return []
    radius = float(np.max(np.linalg.norm(points - center, axis=1)))
    h_scale = max(float(np.abs(system.H(points)).max()), abs(H0), 1e-300)
    solver = _Corrector(system, H0, Z, scale, h_scale, radius)
    _, neighbours = spatial.cKDTree(points).query(points, k=9)  # pyright: ignore[reportAttributeAccessIssue]
    candidates = points[(size <= size[neighbours].min(axis=1)) & (size < 0.2 * scale)]
    found = []
    for x0 in candidates[np.argsort(np.linalg.norm(Z(candidates), axis=1))]:
        if _near(found, x0, 0.0, 0.5 * solver.ds):
            continue  # a sample point beside a traced curve: it would refine onto the curve
        x = solver.correct(x0)
        if x is None or _near(found, x, 1e-3 * radius, solver.ds):
            continue
        curve = solver.trace(x)
        found.append(("curve", curve) if curve is not None else ("point", x))
    return found


def _near(found, x, point_distance, curve_distance):
    for kind, data in found:
        if kind == "point" and np.linalg.norm(data - x) < point_distance:
            return True
        if kind == "curve" and np.min(np.linalg.norm(data[0] - x, axis=1)) < 2.0 * curve_distance:
            return True
    return False


class _Corrector:
    """Least-squares projection onto ``{Z = 0, H = H0}`` (optionally on a plane) and curve tracing."""

    def __init__(self, system, H0, Z, z_scale, h_scale, radius):
        self.system, self.H0, self.Z = system, H0, Z
        self.z_scale, self.h_scale, self.radius = z_scale, h_scale, radius
        self.ds = 2.0 * np.pi * radius / _STEPS_PER_TURN
        self.step = 1e-7 * radius

    def residual(self, x, plane=None):
        r = np.append(self.Z(x[None])[0] / self.z_scale, (self.system.H(x) - self.H0) / self.h_scale)
        return r if plane is None else np.append(r, plane[0] @ (x - plane[1]) / self.radius)

    def jacobian(self, x, plane=None):
        shifts = np.concatenate([x + self.step * np.eye(3), x - self.step * np.eye(3)])
        values = np.hstack([self.Z(shifts) / self.z_scale, (self.system.H(shifts) / self.h_scale)[:, None]])
        D = ((values[:3] - values[3:]) / (2.0 * self.step)).T
        return D if plane is None else np.vstack([D, plane[0] / self.radius])

    def correct(self, x0, plane=None):
        """The nearest point with ``|Z| <= 1e-9 z_scale`` and ``H = H0``, or None."""
        from scipy import optimize

        with np.errstate(divide="ignore", invalid="ignore"):  # trf divides by a zero step norm once converged
            x = optimize.least_squares(
                lambda x: self.residual(x, plane),
                x0,
                jac=lambda x: self.jacobian(x, plane),  # pyright: ignore[reportArgumentType]
                xtol=1e-15,
                ftol=1e-15,
                gtol=1e-15,
            ).x
        ok = np.linalg.norm(self.Z(x[None])[0]) <= ZERO * self.z_scale
        ok &= abs(self.system.H(x) - self.H0) <= 1e-12 * self.h_scale
        return x if ok else None

    def tangent(self, x, previous=None):
        """The null direction of ``[DZ; grad H]`` if it is (numerically) one-dimensional, else None."""
        D = self.jacobian(x)
        D = np.vstack([D[:-1] / max(np.linalg.norm(D[:-1]), 1e-300), D[-1] / max(np.linalg.norm(D[-1]), 1e-300)])
        _, s, Vt = np.linalg.svd(D)
        if s[2] <= 1e-6 * s[0] < s[1]:
            v = Vt[2]
        elif previous is not None and s[1] <= 1e-6 * s[0]:  # two null directions: keep going straight
            normal = Vt[0]
            v = previous - (previous @ normal) * normal
        else:
            return None
        return v if previous is None or v @ previous >= 0 else -v

    def trace(self, start):
        """``(points, closed)`` of the zero curve through ``start``, or None if ``start`` is isolated."""
        v0 = self.tangent(start)
        if v0 is None:
            return None
        branches = []
        for direction in (v0, -v0):
            branch, closed = self._branch(start, direction)
            if closed:
                return np.array(branch), True
            branches.append(branch)
        if len(branches[0]) + len(branches[1]) <= 2:
            return None  # the step along the null direction left the zero set: an isolated degenerate zero
        return np.array(branches[1][:0:-1] + branches[0]), False

    def _branch(self, start, v):
        branch = [start]
        x = start
        for k in range(4 * _STEPS_PER_TURN):
            predicted = x + self.ds * v
            nxt = self.correct(predicted, plane=(v, predicted))
            if nxt is None or np.linalg.norm(nxt - predicted) > 0.5 * self.ds:
                return branch, False
            if k >= 3 and np.linalg.norm(nxt - start) < 0.75 * self.ds:
                return branch, True
            v = self.tangent(nxt, previous=v)
            if v is None:
                return branch + [nxt], False
            branch.append(nxt)
            x = nxt
        return branch, False
