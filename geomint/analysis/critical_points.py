"""Equilibria on an energy level set in R^n: the critical points of S on ``{H = H0}``, their type and stability.

For a system in the Fish form, ``dx/dt = P grad H + eps D grad S`` with ``P grad S = 0`` and ``D grad H = 0``
(``MetriplecticSystem``, ``MetriplecticSystemN``), or in GENERIC form, ``dx/dt = L grad E + M grad S``
(``GenericSystem``: the same with H = E, P = L, D = M), a point of the level set where

    grad S(x) = lam grad H(x),   H(x) = H0,                                                (L)

is an equilibrium as soon as ``lam != 0``: ``P grad H = P grad S / lam = 0`` and ``D grad S = lam D grad H = 0``.
These are the critical points of S restricted to the level set (Lagrange), the states the dissipation drives
to (selective decay: Morrison, Physica D 18 (1986) 410; GENERIC: Grmela and Oettinger, Phys. Rev. E 56 (1997)
6620).  ``critical_points`` solves (L), ``n + 1`` equations in ``(x, lam)``, by Newton's method from many
starts on the level set, and classifies each solution by the constrained Hessian

    L_T = T (Hess S - lam Hess H) T^T,   T an orthonormal basis of grad H^perp,

(minimum, maximum or saddle of S on the level set) and by the Jacobian of the field restricted to the tangent
space, ``J_T = T Dxi T^T`` (``stability.linearise``).

**Which is stable.**  H is conserved and S is monotone (never rising in the Fish form, ``direction`` -1;
never falling in GENERIC, +1): on the invariant level set ``S`` (Fish) or ``-S`` (GENERIC) is a Lyapunov
function, so the S minimum (Fish) or the entropy maximum (GENERIC) is stable within the level set
(``CriticalPoint.lyapunov_stable``).  Linearly: ``V = S - S(x) - lam (H - H0)`` has Hessian ``L_T`` on the
tangent space and ``dV/dt = dS/dt``; for the paper's metric ``dS/dt = -eps |grad H|^2 |Pi_H grad S|^2 =
-eps |grad H|^2 |L_T delta|^2 + O(delta^3)``, so

    L_T J_T + J_T^T L_T = -2 eps |grad H|^2 L_T^2,

and by the inertia theorem (Ostrowski and Schneider, J. Math. Anal. Appl. 4 (1962) 72) for every ``eps > 0``
and non-singular ``L_T`` no eigenvalue of ``J_T`` lies on the imaginary axis and as many have negative real
part as ``L_T`` has positive eigenvalues: a minimum is stable, a maximum or a saddle unstable, whatever eps
(the R^n form of ``stability.factorise``'s conclusion in R^3).  For a degenerate metric (GENERIC's M, a
user's G) the same identity holds with ``2 eps L_T D_T L_T`` (semidefinite) on the right: the stable extremum
has no eigenvalue with positive real part, and the eigenvalues decide whether it attracts.

**Sets of critical points.**  Where ``L_T`` has zero eigenvalues and the points reached from ``x`` along their
eigenvectors are critical points with the same S (a Morse-Bott critical manifold: the lowest shell of 2-D
Euler, a sphere), the points found on it are reported once, with ``manifold_dim`` its dimension, the type
from the non-zero eigenvalues, and the linear stability across the manifold: the zero eigenvalues along it
(``J_T`` vanishes there, every point being an equilibrium) are left out, as ``EquilibriumCurve`` does in R^3.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._user_errors import UserFunctionError
from ._common import ZERO, check_level, dimension
from .stability import _tangent_bases, eigenvalue_kind, hessian_type, linearise, verdict

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

_ACCEPT = 1e-10  # a Newton solution is kept when both relative residuals are at most this
_ITERATIONS = 60  # Newton steps at most from one start
_RCOND = 1e-9  # singular values of the scaled Newton matrix below this fraction of the largest count as zero
_MANIFOLD_STEP = 1e-3  # the step along a flat direction (times 1 + |x|) in the test for a manifold
_SLIDES = 100  # steps of steepest descent or ascent of S on the level set at most, before Newton


@dataclass(frozen=True)
class CriticalPoint:
    """A critical point of S on ``H = H0`` (``grad S = lam grad H``), with its type and its stability.

    Attributes
    ----------
    x : ndarray, shape (n,)
        The point (for a manifold of critical points, the first found on it).
    lam : float
        The multiplier: ``grad S(x) = lam grad H(x)``.
    H, S : float
        The values there.
    type : str
        ``"minimum"``, ``"maximum"``, ``"saddle"`` or ``"degenerate"``: of S restricted to the level set
        (``stability.hessian_type`` of ``hessian_eigenvalues``, without the zeros along a manifold).
    hessian_eigenvalues : ndarray, shape (n - 1,)
        The eigenvalues of ``L_T = T (Hess S - lam Hess H) T^T``, ascending.
    manifold_dim : int
        0 for an isolated critical point; k for a k-dimensional manifold of them (Morse-Bott: ``L_T`` has k
        zero eigenvalues and the points along their eigenvectors are critical with the same S).
    points : ndarray, shape (m, n)
        Every distinct point found on that manifold (``x`` first); ``x[None]`` when isolated.
    lyapunov_stable : bool
        An equilibrium where S has the extremum its direction makes stable: the minimum in the Fish form (S never
        rises), the maximum in GENERIC form (the entropy never falls).  S (or -S) is then a Lyapunov function on
        the invariant level set.
    equilibrium : bool
        ``field_residual <= 1e-9``: the full field vanishes (it does wherever ``lam != 0``).
    jacobian : ndarray, shape (d, d)
        ``J_T``, the Jacobian of ``system.xi`` restricted to the tangent space of the level set (and of S's level
        set where the field is Hamiltonian, ``eps = 0``), across the manifold when ``manifold_dim > 0`` and the
        field vanishes along it (``d = n - 1 - manifold_dim``; else ``d = n - 1``); empty (0, 0) when not an
        equilibrium.
    eigenvalues : ndarray, shape (d,), complex
        Its eigenvalues.
    verdict : str
        ``"stable"``, ``"unstable"`` or ``"neutral"`` (``stability.verdict``), or ``"not an equilibrium"``.
    gradient_residual : float
        ``|grad S - lam grad H| / max(|grad S|, |lam| |grad H|)``.
    level_residual : float
        ``|H(x) - H0| / max(|H0|, |H(x)|, sum_i |x_i dH/dx_i|)``.
    hamiltonian_residual : float
        ``|P grad H| / (|P|_F |grad H|)`` (in R^3 ``|grad H x J| / (sqrt 2 |J| |grad H|)``; 0 where P = 0).
    field_residual : float
        ``|xi| / (|P|_F |grad H| + eps |D|_F |grad S|)``, ``xi`` the system's full field.
    """

    x: np.ndarray
    lam: float
    H: float
    S: float
    type: str
    hessian_eigenvalues: np.ndarray
    manifold_dim: int
    points: np.ndarray
    lyapunov_stable: bool
    equilibrium: bool
    jacobian: np.ndarray
    eigenvalues: np.ndarray
    verdict: str
    gradient_residual: float
    level_residual: float
    hamiltonian_residual: float
    field_residual: float

    @property
    def kind(self) -> str:
        """``"node"``, ``"focus"``, ``"saddle"``, ``"centre"`` or ``"degenerate"`` (``stability.eigenvalue_kind``);
        ``"not an equilibrium"`` where the field does not vanish."""
        if not self.equilibrium:
            return "not an equilibrium"
        return eigenvalue_kind(self.eigenvalues, _scale(self.jacobian))


def critical_points(
    system: MetriplecticSystem,
    H0: float,
    *,
    starts: npt.ArrayLike | None = None,
    n_starts: int = 64,
    box: Any = None,
    seed: int = 0,
    hess_H: Callable[[np.ndarray], Any] | None = None,
    hess_S: Callable[[np.ndarray], Any] | None = None,
    xtol: float = 1e-6,
    slide: bool = True,
) -> list[CriticalPoint]:
    """The critical points of S on the level set ``H = H0``, each classified: the equilibria there.

    Solves ``grad S = lam grad H``, ``H = H0`` (n + 1 equations in ``(x, lam)``) by Newton's method with a
    backtracking line search, from every start after moving it onto the level set along ``grad H``
    (Newton on ``t -> H(x + t grad H(x))``).  The Jacobian

        [[Hess S - lam Hess H, -grad H], [grad H^T, 0]]

    uses ``hess_H`` and ``hess_S`` where given, else central differences of the gradients (step
    ``1e-6 (1 + |x|)``); the step is the least-squares solution with singular values below ``1e-9`` of the
    largest dropped, so Newton also converges onto manifolds of critical points.  A solution is kept when both
    relative residuals (``CriticalPoint``) are at most ``1e-10``; two are the same point when
    ``|x - y| <= xtol max(|x|, |y|)``.  See the module's docstring for the classification.

    Parameters
    ----------
    system : MetriplecticSystem, MetriplecticSystemN or GenericSystem
        Any dimension n >= 2; the linear stability is that of ``system.xi`` with the system's eps.
    H0 : float
        The level.
    starts : array_like, shape (n,) or (m, n), optional
        Your own starts (each moved onto the level set first).  Without them, ``n_starts`` points drawn
        uniformly from ``box``.
    n_starts : int
    box : (low, high), optional
        Where random starts are drawn, each bound a number or an array (n,).  Default: the box spanned by the
        system's sample states (``samples=`` at construction, where its functions are known to be defined;
        ``[-1, 1]^3`` for a system in R^3).
    seed : int
        Of the random starts.
    hess_H, hess_S : callables ``x -> (n, n) array``, optional
        Exact Hessians of H and S at one state.
    xtol : float
        Relative distance below which two solutions are one point.
    slide : bool
        Also start Newton where steepest descent of S on the level set (ascent in GENERIC form: S's own
        direction; at most 100 steps from each start, Armijo's rule) comes to rest: Newton alone from random
        starts finds every kind of critical point but may miss the extremum that is stable.

    Returns
    -------
    list of CriticalPoint, by ascending S

    Raises
    ------
    ValueError
        ``H0`` not finite, or no start could be moved onto the level set (``H0`` outside the values of H
        reached from the starts); arguments of the wrong shape or value, each named.
    TypeError
        Arguments of the wrong type (``H0`` not a number, ``starts`` not numbers, ``hess_H`` not callable).

    Examples
    --------
    >>> import numpy as np, geomint
    >>> gas = geomint.systems.gas_containers()
    >>> E0 = gas.H([1.5, 0.0, 2.0, 2.0])
    >>> [c] = critical_points(gas, E0, n_starts=8)
    >>> c.type, c.lyapunov_stable, c.verdict          # the entropy maximum attracts
    ('maximum', True, 'stable')
    >>> bool(np.allclose(c.x, geomint.systems.gas_containers_limit(E0), atol=1e-10))
    True
    """
    n = dimension(system)
    H0 = check_level(H0)
    xtol = _check_xtol(xtol)
    hessians = _Hessians(system, n, hess_H, hess_S)
    starts_ = _starts(system, n, starts, n_starts, box, seed)
    solver = _Lagrange(system, H0, hessians)
    solutions, reached, direction = [], 0, float(getattr(system, "direction", -1.0))
    with np.errstate(all="ignore"):  # steps far out may overflow: the line searches then back off
        for x0 in starts_:
            x = solver.onto_level(x0)
            if x is None:
                continue
            reached += 1
            for y in (x, solver.slide(x, direction)) if slide else (x,):
                found = solver.solve(y)
                if found is not None:
                    solutions.append(found)
    if not reached:
        where = "`starts`" if starts is not None else "`box`"
        raise ValueError(
            f"`H0` = {H0!r}: no start could be moved onto the level set H = H0 along grad H; is H0 a value H "
            f"takes near {where}?"
        )
    distinct = _distinct(solutions, xtol)
    return _classified(system, H0, solver, distinct)


def critical_point(
    system: MetriplecticSystem,
    H0: float,
    x0: npt.ArrayLike,
    *,
    hess_H: Callable[[np.ndarray], Any] | None = None,
    hess_S: Callable[[np.ndarray], Any] | None = None,
) -> CriticalPoint:
    """The critical point of S on ``H = H0`` that Newton's method reaches from ``x0``, classified.

    As ``critical_points`` with the one start ``x0`` (moved onto the level set first, without the slide):
    ``continuation_n`` re-solves each point with it.  Raises ``ValueError`` naming ``x0`` when none is reached.

    Examples
    --------
    >>> import geomint
    >>> pendula = geomint.systems.damped_pendula(2)
    >>> c = critical_point(pendula, 1.0, [3.0, 3.1, 0.1, 0.0, 2.5])   # both pendula near the bottom, q = pi
    >>> (c.x.round(6) + 0.0).tolist(), c.type, c.verdict
    ([3.141593, 3.141593, 0.0, 0.0, 3.0], 'maximum', 'stable')
    """
    n = dimension(system)
    H0 = check_level(H0)
    start = _check_states("x0", x0, n)
    if len(start) != 1:
        raise ValueError(f"`x0` must be one state of n = {n} numbers; got shape {np.shape(x0)}.")
    solver = _Lagrange(system, H0, _Hessians(system, n, hess_H, hess_S))
    with np.errstate(all="ignore"):
        x = solver.onto_level(start[0])
    found = None if x is None else solver.solve(x)
    if found is None:
        raise ValueError(
            f"`x0` must lie near a critical point of S on H = {H0!r}; Newton's method reached none from "
            f"{start[0].tolist()}."
        )
    return _classified(system, H0, solver, [found])[0]


def to_level_set(system: MetriplecticSystem, x: npt.ArrayLike, H0: float) -> np.ndarray:
    """The states ``x`` (shape (n,) or (m, n)) moved onto ``H = H0`` along ``grad H`` (Newton on the gradient line).

    Each is iterated ``x <- x - t (H(x) - H0) grad H(x) / |grad H(x)|^2`` with ``t`` halved until ``|H - H0|``
    falls, to ``|H - H0| <= 1e-12`` of the size of H's terms; a state that does not get there gives a row of
    NaN (outside the functions' domain, at a critical point of H, or where H never takes the value H0).

    Examples
    --------
    >>> import numpy as np, geomint
    >>> fish = geomint.systems.random_fish(4)
    >>> y = to_level_set(fish, np.full(4, 0.5), 2.0)
    >>> bool(abs(fish.H(y) - 2.0) < 1e-12)
    True
    """
    n = dimension(system)
    H0 = check_level(H0)
    X = _check_states("x", x, n)
    solver = _Lagrange(system, H0, _Hessians(system, n, None, None))
    out = np.full_like(X, np.nan)
    for i, row in enumerate(X):
        with np.errstate(all="ignore"):
            y = solver.onto_level(row, tol=1e-12, loose=1e-12)
        if y is not None:
            out[i] = y
    return out[0] if np.ndim(x) == 1 else out


# -- Newton on the Lagrange system ------------------------------------------------------------------------------


class _Hessians:
    """``(Hess H, Hess S)`` at one state: the user's where given, else central differences of the gradients."""

    def __init__(self, system, n, hess_H, hess_S):
        for name, f in (("hess_H", hess_H), ("hess_S", hess_S)):
            if f is not None and not callable(f):
                raise TypeError(f"`{name}` must be a function x -> (n, n) array (the Hessian at one state); got {f!r}.")
        self.system, self.n, self.given = system, n, (hess_H, hess_S)

    def __call__(self, x):
        n, system = self.n, self.system
        step = 1e-6 * (1.0 + float(np.linalg.norm(x)))
        out = []
        for name, exact, gradient in zip(("hess_H", "hess_S"), self.given, (system.grad_H, system.grad_S)):
            if exact is not None:
                value = np.asarray(exact(x.copy()), dtype=np.float64)
                if value.shape != (n, n):
                    raise ValueError(f"`{name}` must return an ({n}, {n}) array; got shape {value.shape}.")
            else:
                shifts = np.concatenate([x + step * np.eye(n), x - step * np.eye(n)])
                g = np.atleast_2d(gradient(shifts))
                value = ((g[:n] - g[n:]) / (2.0 * step)).T
            out.append(0.5 * (value + value.T))
        return out


class _Lagrange:
    """Newton's method on ``(grad S - lam grad H, H - H0) = 0``, scaled so that both blocks are of size one."""

    def __init__(self, system, H0, hessians):
        self.system, self.H0, self.hessians = system, H0, hessians

    def values(self, x):
        """``(H, grad H, grad S)`` at ``x``, or None where they are not finite (outside the functions' domain)."""
        s = self.system
        with np.errstate(all="ignore"):
            h, gh, gs = float(s.H(x)), np.asarray(s.grad_H(x), dtype=np.float64), np.asarray(s.grad_S(x), np.float64)
        return (h, gh, gs) if np.isfinite(h) and np.all(np.isfinite(gh)) and np.all(np.isfinite(gs)) else None

    def h_scale(self, x, h, gh):
        return max(abs(self.H0), abs(h), float(np.sum(np.abs(x * gh))), 1e-300)

    def onto_level(self, x, tol=1e-10, loose=1e-6):
        """``x`` moved onto ``H = H0`` along ``grad H``: to ``|H - H0| <= tol`` of the size of H's terms, or
        ``loose`` where the iteration stalls; None where it gets neither (or leaves the functions' domain)."""
        x = np.array(x, dtype=np.float64)
        try:
            now = self.values(x)
        except UserFunctionError:
            return None
        for _ in range(100):
            if now is None:
                return None
            h, gh, _ = now
            miss, scale = abs(h - self.H0), self.h_scale(x, h, gh)
            if miss <= tol * scale:
                return x
            size = float(gh @ gh)
            if size == 0.0:
                return None  # a critical point of H
            d = -(h - self.H0) / size * gh
            # a trust region of |x| (at least 1): near a critical point of H the Newton step is huge
            length, reach = float(np.linalg.norm(d)), max(1.0, float(np.linalg.norm(x)))
            t = min(1.0, reach / length)
            while t * length > 1e-14 * reach:
                trial = x + t * d
                try:
                    after = self.values(trial)
                except UserFunctionError:
                    after = None
                if after is not None and abs(after[0] - self.H0) < miss:
                    x, now = trial, after
                    break
                t *= 0.5
            else:
                return x if miss <= loose * scale else None
        return None

    def slide(self, x, sign, steps=_SLIDES):
        """``x`` (on the level set) moved along ``sign Pi_H grad S`` (steepest ascent of S on the level set for
        ``sign`` +1, descent for -1), each step projected back onto it and accepted on Armijo's condition, until
        ``|Pi_H grad S| <= 1e-3 |grad S|`` or after ``steps`` steps: a start near an extremum of S."""
        system, t = self.system, None
        try:
            value = float(system.S(x))
            for _ in range(steps):
                now = self.values(x)
                if now is None or not np.isfinite(value):
                    return x
                _, gh, gs = now
                d = gs - float(gs @ gh) / float(gh @ gh) * gh
                size = float(np.linalg.norm(d))
                if size <= 1e-3 * float(np.linalg.norm(gs)):
                    return x
                reach = 0.25 * (1.0 + float(np.linalg.norm(x)))  # no step longer: the extremum nearby, not a far one
                t = min(0.1 * reach / size if t is None else 2.0 * t, reach / size)
                while t * size > 1e-8 * (1.0 + float(np.linalg.norm(x))):
                    y = self.onto_level(x + sign * t * d)
                    if y is not None:
                        after = float(system.S(y))
                        if sign * (after - value) >= 1e-4 * t * size * size:
                            x, value = y, after
                            break
                    t *= 0.5
                else:
                    return x
        except UserFunctionError:
            pass
        return x

    def _residual(self, x, lam, scales):
        try:
            now = self.values(x)
        except UserFunctionError:
            return None
        if now is None:
            return None
        h, gh, gs = now
        b, a, ell = scales
        return np.append((gs - lam * gh) / b, (h - self.H0) / (a * ell))

    def solve(self, x, lam=None):
        """``(x, lam, gradient residual, level residual)`` of the solution reached from ``x``, or None (also where
        a user function raises on the way: outside its domain)."""
        try:
            with np.errstate(all="ignore"):  # a step may overflow far out: the line search then backs off
                return self._solve(x, lam)
        except UserFunctionError:
            return None

    def _solve(self, x, lam):
        now = self.values(x)
        if now is None:
            return None
        n = x.size
        if lam is None:  # the least-squares multiplier at the start
            size = float(now[1] @ now[1])
            lam = float(now[2] @ now[1]) / size if size > 0.0 else 0.0
        for _ in range(_ITERATIONS):
            h, gh, gs = now
            a = float(np.linalg.norm(gh))
            if a == 0.0:
                return None  # a critical point of H: the level set is not a manifold there
            b = max(float(np.linalg.norm(gs)), abs(lam) * a) or a
            ell = 1.0 + float(np.linalg.norm(x))
            scales = (b, a, ell)
            r = np.append((gs - lam * gh) / b, (h - self.H0) / (a * ell))
            hess_H, hess_S = self.hessians(x)
            if not (np.all(np.isfinite(hess_H)) and np.all(np.isfinite(hess_S))):
                return None
            matrix = np.zeros((n + 1, n + 1))
            matrix[:n, :n] = (hess_S - lam * hess_H) * (ell / b)
            matrix[:n, n] = -gh / a
            matrix[n, :n] = gh / a
            u = np.linalg.lstsq(matrix, -r, rcond=_RCOND)[0]
            dx, dlam = ell * u[:n], u[n] * b / a
            size, t = float(np.linalg.norm(r)), min(1.0, ell / (float(np.linalg.norm(dx)) + 1e-300))  # |t dx| <= ell
            while t > 1e-3 * min(1.0, ell / (float(np.linalg.norm(dx)) + 1e-300)):
                trial = self._residual(x + t * dx, lam + t * dlam, scales)
                if trial is not None and float(np.linalg.norm(trial)) < size:
                    break
                t *= 0.5
            else:
                break  # no decrease along the Newton direction: converged to round-off, or stuck
            x, lam = x + t * dx, lam + t * dlam
            now = self.values(x)
            if now is None:
                return None
            if t * float(np.linalg.norm(dx)) <= 1e-15 * ell and t * abs(dlam) <= 1e-15 * (abs(lam) + b / a):
                break
        h, gh, gs = now
        scale = max(float(np.linalg.norm(gs)), abs(lam) * float(np.linalg.norm(gh)))
        gradient = float(np.linalg.norm(gs - lam * gh)) / scale if scale > 0.0 else 0.0
        level = abs(h - self.H0) / self.h_scale(x, h, gh)
        if gradient <= _ACCEPT and level <= _ACCEPT:
            return x, float(lam), gradient, level
        return None


def _distinct(solutions, xtol):
    """The solutions without repeats (``|x - y| <= xtol max(|x|, |y|)``), the smallest residual kept."""
    kept = []
    for found in sorted(solutions, key=lambda f: f[2] + f[3]):
        x = found[0]
        if not any(np.linalg.norm(x - k[0]) <= xtol * max(np.linalg.norm(x), np.linalg.norm(k[0])) for k in kept):
            kept.append(found)
    return kept


# -- classification -----------------------------------------------------------------------------------------------


def _constrained_hessian(system, solver, x, lam):
    """``(eigenvalues, eigenvectors as columns in R^n)`` of ``L_T`` at ``x``, ascending."""
    T = _tangent_bases(system, x[None])[0]
    hess_H, hess_S = solver.hessians(x)
    K = T @ (hess_S - lam * hess_H) @ T.T
    values, vectors = np.linalg.eigh(0.5 * (K + K.T))
    return values, T.T @ vectors


def _flat(values):
    """Which eigenvalues count as zero (the tolerance of ``hessian_type``)."""
    tol = 1e-7 * (abs(values[0]) + abs(values[-1])) if values.size else 0.0
    return np.abs(values) <= tol


def _on_manifold(system, solver, x, lam, directions):
    """True when the points ``x + delta v`` (``v`` each flat direction) lead back to critical points beside them
    with the value of S at ``x``: a Morse-Bott manifold, not a degenerate isolated point."""
    ell = 1.0 + float(np.linalg.norm(x))
    delta = _MANIFOLD_STEP * ell
    S0 = float(system.S(x))
    for v in directions.T:
        start = x + delta * v
        found = solver.solve(start, lam)
        if found is None:
            return False
        y = found[0]
        S_scale = max(abs(S0), float(np.sum(np.abs(y * np.asarray(system.grad_S(y))))), 1e-300)
        if np.linalg.norm(y - start) > 1e-2 * delta or abs(float(system.S(y)) - S0) > 1e-9 * S_scale:
            return False
    return True


def _classified(system, H0, solver, distinct):
    records = []
    for x, lam, gradient, level in distinct:
        values, vectors = _constrained_hessian(system, solver, x, lam)
        records.append([x, lam, gradient, level, values, vectors, float(system.S(x))])
    # group the points that may lie on one manifold: flat directions, the same multiplier and the same S
    groups = []
    for record in records:
        flat = int(np.sum(_flat(record[4])))
        for group in groups:
            first = group[0]
            if (
                flat
                and int(np.sum(_flat(first[4]))) == flat
                and abs(first[1] - record[1]) <= 1e-8 * max(abs(first[1]), abs(record[1]))
                and abs(first[6] - record[6]) <= 1e-9 * max(abs(first[6]), abs(record[6]), 1e-300)
            ):
                group.append(record)
                break
        else:
            groups.append([record])
    out = []
    for group in groups:
        x, lam, gradient, level, values, vectors, _ = group[0]
        flat = _flat(values)
        k = int(np.sum(flat))
        if k and _on_manifold(system, solver, x, lam, vectors[:, flat]):
            out.append(_point(system, H0, group, k))
        else:
            out.extend(_point(system, H0, [record], 0) for record in group)
    out.sort(key=lambda c: (c.S, tuple(c.x)))
    return out


def _point(system, H0, group, k):
    x, lam, gradient, level, values, vectors, S = group[0]
    flat = _flat(values) if k else np.zeros(values.size, dtype=bool)
    kind = hessian_type(values[~flat])
    direction = float(getattr(system, "direction", -1.0))
    hamiltonian, field = _field_residuals(system, x)
    equilibrium = field <= ZERO
    if equilibrium:
        jacobian, eigenvalues = _across(system, x, vectors[:, flat])
        said = verdict(eigenvalues, _scale(jacobian))
    else:
        jacobian, eigenvalues, said = np.zeros((0, 0)), np.zeros(0, dtype=complex), "not an equilibrium"
    stable_extremum = "minimum" if direction < 0 else "maximum"
    return CriticalPoint(
        x=x,
        lam=lam,
        H=float(system.H(x)),
        S=S,
        type=kind,
        hessian_eigenvalues=values,
        manifold_dim=k,
        points=np.array([r[0] for r in group]),
        lyapunov_stable=bool(equilibrium and kind == stable_extremum),
        equilibrium=bool(equilibrium),
        jacobian=jacobian,
        eigenvalues=eigenvalues,
        verdict=said,
        gradient_residual=gradient,
        level_residual=level,
        hamiltonian_residual=hamiltonian,
        field_residual=field,
    )


def _across(system, x, along):
    """``J_T`` at ``x`` and its eigenvalues, across the manifold spanned by ``along`` (columns in R^n) when the
    field vanishes along it (``J_T along = 0``); the full ``J_T`` otherwise."""
    conserved = ("S",) if system.eps == 0.0 else ()
    jacobian, _ = linearise(system, x, conserved=conserved)
    if along.shape[1]:
        T = _tangent_bases(system, x[None], conserved)[0]
        W = np.linalg.qr(T @ along)[0]
        if np.linalg.norm(jacobian @ W) <= 1e-6 * _scale(jacobian):
            U = np.linalg.svd(W.T)[2][W.shape[1] :].T  # the orthogonal complement of W in the tangent space
            jacobian = U.T @ jacobian @ U
    return jacobian, np.linalg.eigvals(jacobian)


def _field_residuals(system, x):
    """``(|P grad H| / (|P| |grad H|), |xi| / (|P| |grad H| + eps |D| |grad S|))`` at ``x``."""
    gh, gs = np.asarray(system.grad_H(x)), np.asarray(system.grad_S(x))
    if hasattr(system, "P"):  # R^n (and the R^n form in R^3)
        P, D = np.asarray(system.P(x)), np.asarray(system.D(x))
        p_norm, d_norm = float(np.linalg.norm(P)), float(np.linalg.norm(D))
    else:  # R^3: P v = v x J, |P|_F = sqrt 2 |J|; the paper's metric g
        p_norm, d_norm = np.sqrt(2.0) * float(np.linalg.norm(system.J(x))), float(np.linalg.norm(system.g(x)))
    xi_P = float(np.linalg.norm(system.xi_P(x)))
    hamiltonian_scale = p_norm * float(np.linalg.norm(gh))
    scale = hamiltonian_scale + system.eps * d_norm * float(np.linalg.norm(gs))
    hamiltonian = xi_P / hamiltonian_scale if hamiltonian_scale > 0.0 else 0.0
    field = float(np.linalg.norm(system.xi(x)))
    return hamiltonian, (field / scale if scale > 0.0 else (0.0 if field == 0.0 else np.inf))


def _scale(jacobian):
    return float(np.linalg.norm(jacobian)) + 1e-300


# -- arguments ----------------------------------------------------------------------------------------------------


def _check_states(name, x, n):
    try:
        X = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be real numbers: a state (n,) or states (m, n), n = {n}; got {x!r}.") from None
    if X.ndim not in (1, 2) or X.shape[-1] != n or X.size == 0:
        raise ValueError(
            f"`{name}` must have shape ({n},) (one state of n = {n} numbers) or (m, {n}) (m states); got shape "
            f"{X.shape}."
        )
    if not np.all(np.isfinite(X)):
        raise ValueError(f"`{name}` must be finite states.")
    return np.atleast_2d(X)


def _starts(system, n, starts, n_starts, box, seed):
    if starts is not None:
        return _check_states("starts", starts, n)
    if isinstance(n_starts, bool) or not isinstance(n_starts, numbers.Integral) or n_starts < 1:
        raise ValueError(f"`n_starts` must be an integer >= 1; got {n_starts!r}.")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"`seed` must be an integer >= 0; got {seed!r}.")
    low, high = _box(system, n, box)
    return np.random.default_rng(int(seed)).uniform(low, high, size=(int(n_starts), n))


def _box(system, n, box):
    if box is None:
        samples = getattr(system, "_samples", None)
        if samples is None:
            return -np.ones(n), np.ones(n)
        low, high = samples.min(axis=0), samples.max(axis=0)
        flat = high <= low
        return np.where(flat, low - 1.0, low), np.where(flat, high + 1.0, high)
    rule = f"`box` must be (low, high), each a number or an array of n = {n} numbers, finite, low < high"
    try:
        low, high = (np.broadcast_to(np.asarray(b, dtype=np.float64), (n,)) for b in box)
    except (TypeError, ValueError):
        raise ValueError(f"{rule}; got {box!r}.") from None
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low < high)):
        raise ValueError(f"{rule}; got {box!r}.")
    return low, high


def _check_xtol(xtol):
    if isinstance(xtol, bool) or not isinstance(xtol, numbers.Real) or not 0.0 < float(xtol) < 1.0:
        raise ValueError(f"`xtol` must be a number in (0, 1); got {xtol!r}.")
    return float(xtol)
