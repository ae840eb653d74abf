"""Linear stability on the level set, in R^3 and R^n: the tangent-space Jacobian, its verdict and kind.

At an equilibrium the level set ``H = H0`` is invariant, so stability within
it is decided by ``J_T = T Df T^T``, the Jacobian of the field restricted to
the tangent space ``grad H^perp`` (``T`` an orthonormal basis of it): 2 x 2 in
R^3, (n - 1) x (n - 1) in R^n.  ``verdict``, ``eigenvalue_kind`` and
``hessian_type`` (the type of a critical point of S on the level set from the
eigenvalues of its constrained Hessian) serve both.  ``factorise`` [R3] writes
``J_T`` at a regular equilibrium with ``grad S || grad H`` through the
cross-product matrix ``[grad H x]``: it holds in R^3 only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ._common import as_points, check_field, dimension, field_of, require_three

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem


def tangent_basis(
    system: MetriplecticSystem, x: npt.ArrayLike, conserved: Sequence[str | Callable[..., Any]] = ()
) -> npt.NDArray[np.float64]:
    """An orthonormal basis (rows) of the tangent space of the level set through ``x``.

    Without ``conserved``: ``grad H(x)^perp``, shape ``(n - 1, n)`` (``(2, 3)`` in R^3).  With
    ``conserved`` (``"S"`` for the system's S, or functions ``x -> grad C(x)`` of one state): the
    orthogonal complement of ``grad H`` and those gradients, shape ``(n - r, n)``, ``r`` their rank
    (singular values below ``1e-9`` of the largest, of the unit normals, count as zero: where
    ``grad S || grad H`` the level sets touch and S removes no further direction).

    Raises ``ValueError`` at a critical point of H (no tangent plane).
    """
    n = dimension(system)
    return _tangent_bases(system, as_points(x, n), conserved)[0]


def _tangent_bases(system, X, conserved=()):
    normal = np.atleast_2d(system.grad_H(X))
    size = np.linalg.norm(normal, axis=1)
    if np.any(size == 0.0):
        x = X[np.argmin(size)]
        raise ValueError(f"`x` must not be a critical point of H (grad H = 0 there); got {x.tolist()}.")
    if not conserved:
        return np.linalg.svd((normal / size[:, None])[:, None, :])[2][:, 1:]
    normals = np.stack([normal, *(_conserved_gradients(system, X, c) for c in conserved)], axis=1)
    norms = np.linalg.norm(normals, axis=2, keepdims=True)
    unit = np.divide(normals, norms, out=np.zeros_like(normals), where=norms > 0.0)
    _, s, Vt = np.linalg.svd(unit)
    ranks = np.sum(s > 1e-9 * s[:, :1], axis=1)
    if np.any(ranks != ranks[0]):
        raise ValueError(
            f"`conserved`: the normals of the level sets have rank {ranks.min()} at some points of `x` and "
            f"{ranks.max()} at others; linearise those points separately."
        )
    return Vt[:, int(ranks[0]) :]


def _conserved_gradients(system, X, c):
    """``grad C`` at every row of ``X`` for an entry of ``conserved``: ``"S"`` or a function of one state."""
    if isinstance(c, str):
        if c != "S":
            raise ValueError(f'`conserved` entries must be "S" or functions x -> grad C(x); got {c!r}.')
        return np.atleast_2d(system.grad_S(X))
    if not callable(c):
        raise TypeError(f'`conserved` entries must be "S" or functions x -> grad C(x); got {c!r}.')
    values = np.array([np.asarray(c(row.copy()), dtype=np.float64) for row in X])
    if values.shape != X.shape:
        raise ValueError(
            f"`conserved`: a gradient function must return an array of shape ({X.shape[1]},); got shape "
            f"{values.shape[1:]}."
        )
    return values


def linearise(
    system: MetriplecticSystem,
    x: npt.ArrayLike,
    field: str = "xi",
    step: float | None = None,
    conserved: Sequence[str | Callable[..., Any]] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """The Jacobian of ``field`` restricted to the level set through ``x``, and its eigenvalues.

        J_T = T Df(x) T^T,   T = tangent_basis(system, x, conserved)   ((n - 1) x (n - 1); 2 x 2 in R^3),

    with ``Df`` by central differences of step ``step`` (default
    ``1e-6 (1 + |x|)``).  At an equilibrium the level set is invariant (``d/dt H = 0``
    gives ``grad H^T Df = 0`` there: ``Df`` maps into the tangent space), so the
    eigenvalues of ``Df`` are those of ``J_T`` and a zero, across the level set, that
    carries no information; ``J_T``'s decide stability within it.  Quantities the
    field also conserves (``conserved``: ``"S"`` where the flow is Hamiltonian, S a
    Casimir of P; the user's own as functions ``x -> grad C(x)``) remove their
    normals too.  Works in R^3 and R^n (``system.dim``).

    Parameters
    ----------
    system : MetriplecticSystem
    x : array_like, shape (n,) or (m, n)
    field : {"xi", "xi_P", "xi_g"}
    step : float, optional
    conserved : sequence of "S" or callables, optional

    Returns
    -------
    jacobian : ndarray, shape (d, d) (or (m, d, d)), d = n - 1 without ``conserved``
    eigenvalues : ndarray, shape (d,) (or (m, d)), complex

    Examples
    --------
    >>> import numpy as np, geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.0)
    >>> _, lam = linearise(body, [0.0, 0.0, 1.0])
    >>> np.round(np.sort_complex(lam), 6)   # a centre: +-i sqrt((c - a)(c - b)) z0
    array([0.-0.707107j, 0.+0.707107j])
    """
    n = dimension(system)
    X = as_points(x, n)
    F = field_of(system, check_field(field))
    steps = 1e-6 * (1.0 + np.linalg.norm(X, axis=1)) if step is None else np.full(len(X), float(step))
    shifts = np.concatenate([X + steps[:, None] * e for e in np.eye(n)] + [X - steps[:, None] * e for e in np.eye(n)])
    values = F(shifts).reshape(2 * n, len(X), n)
    Df = np.stack([(values[i] - values[i + n]) / (2.0 * steps[:, None]) for i in range(n)], axis=2)
    T = _tangent_bases(system, X, conserved)
    jacobian = T @ Df @ np.transpose(T, (0, 2, 1))
    eigenvalues = np.linalg.eigvals(jacobian)
    return (jacobian[0], eigenvalues[0]) if np.ndim(x) == 1 else (jacobian, eigenvalues)


@dataclass(frozen=True)
class Factorisation:
    """The tangent-plane Jacobian of ``xi`` at a regular equilibrium with ``grad S = lam grad H != 0``.

    With ``J = mu grad S`` (S is a Casimir) and ``L = Hess S - lam Hess H``
    (the Hessian of the Lagrangian of S restricted to ``H = H0``), linearising
    ``xi_P = mu grad H x grad S`` and ``xi_g = grad H x (grad H x grad S)`` where
    ``grad H x grad S = 0`` gives, in an orthonormal tangent basis ``T``,

        J_T(eps) = (mu C_T - eps |grad H|^2 I) L_T,   C_T = T [grad H x] T^T,   L_T = T L T^T.

    ``C_T`` is ``|grad H|`` times a rotation by a right angle, so
    ``det J_T = |grad H|^2 (mu^2 + eps^2 |grad H|^2) det L_T`` and
    ``tr J_T = -eps |grad H|^2 tr L_T``: for every ``eps > 0`` the verdict is that
    of the critical point of ``S`` on the level set (minimum: stable; maximum:
    unstable; saddle: saddle), whatever eps — no eigenvalue crosses the imaginary
    axis at ``eps > 0``.  Where ``det L_T > 0`` the foci become nodes at

        eps* = 2 |mu| sqrt(det L_T) / (|grad H| |l1 - l2|),   l1, l2 the eigenvalues of L_T.

    Attributes
    ----------
    lam, mu : float
    grad_H_norm : float
    hessian : ndarray, shape (2, 2)
        ``L_T`` (symmetric).
    rotation : ndarray, shape (2, 2)
        ``C_T`` (skew).
    """

    lam: float
    mu: float
    grad_H_norm: float
    hessian: np.ndarray
    rotation: np.ndarray

    def jacobian(self, eps: float) -> npt.NDArray[np.float64]:
        """``J_T(eps)``, shape (2, 2)."""
        return (self.mu * self.rotation - eps * self.grad_H_norm**2 * np.eye(2)) @ self.hessian

    @property
    def constrained_type(self) -> str:
        """``"minimum"``, ``"maximum"``, ``"saddle"`` or ``"degenerate"``: the critical point of S on ``H = H0``."""
        return hessian_type(np.linalg.eigvalsh(self.hessian))

    @property
    def node_eps(self) -> float:
        """``eps*`` where foci become nodes (``nan`` unless ``S`` has a strict extremum with ``l1 != l2``)."""
        l1, l2 = np.linalg.eigvalsh(self.hessian)
        if l1 * l2 <= 0.0 or l1 == l2:
            return float("nan")
        return float(2.0 * abs(self.mu) * np.sqrt(l1 * l2) / (self.grad_H_norm * abs(l1 - l2)))


def factorise(system: MetriplecticSystem, x: npt.ArrayLike, step: float | None = None) -> Factorisation:
    """The ``Factorisation`` of the tangent-plane Jacobian at a regular equilibrium ``x`` with ``grad S || grad H``.

    [R3]: the cross-product matrix ``[grad H x]`` exists in R^3 only.  Hessians
    by central differences of the gradients (step ``1e-6 (1 + |x|)`` by default).  Raises ``ValueError`` where ``grad
    H``, ``grad S`` or ``J``
    vanishes (the factorisation needs all three).

    Examples
    --------
    >>> import numpy as np, geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=2.0)
    >>> f = factorise(body, [0.0, 0.0, 1.0])
    >>> f.constrained_type, round(f.node_eps, 5)      # S = |m|^2/2 has its minimum on H = 0.75 at the pole
    ('minimum', 1.88562)
    >>> bool(np.allclose(f.jacobian(2.0), linearise(body, [0.0, 0.0, 1.0])[0], atol=1e-8))
    True
    """
    require_three(system, "`factorise` (the cross product with grad H)", "`linearise` and `critical_points`")
    x = cast("npt.NDArray[np.float64]", as_points(x)[0])
    gh, gs, j = (np.asarray(f(x), dtype=float) for f in (system.grad_H, system.grad_S, system.J))
    for name, v in (("grad H", gh), ("grad S", gs), ("J", j)):
        if not np.linalg.norm(v) > 0.0:
            raise ValueError(
                f"`x` must be a regular point with grad H != 0 and grad S != 0; {name} = 0 at {x.tolist()}."
            )
    step = 1e-6 * (1.0 + float(np.linalg.norm(x))) if step is None else float(step)
    shifts = np.concatenate([x + step * np.eye(3), x - step * np.eye(3)])
    hess_H, hess_S = (
        ((v[:3] - v[3:]) / (2.0 * step)).T
        for v in (np.atleast_2d(system.grad_H(shifts)), np.atleast_2d(system.grad_S(shifts)))
    )
    lam, mu = float(gs @ gh / (gh @ gh)), float(j @ gs / (gs @ gs))
    T = tangent_basis(system, x)
    cross = np.array([[0.0, -gh[2], gh[1]], [gh[2], 0.0, -gh[0]], [-gh[1], gh[0], 0.0]])
    L = hess_S - lam * hess_H
    return Factorisation(lam, mu, float(np.linalg.norm(gh)), T @ (0.5 * (L + L.T)) @ T.T, T @ cross @ T.T)


def verdict(eigenvalues: npt.ArrayLike, scale: float, rtol: float = 1e-7) -> str:
    """``"stable"`` if every real part is below ``-rtol scale``, ``"unstable"`` if one is above, else ``"neutral"``.

    ``scale`` is the size of the Jacobian (e.g. its norm): real parts within
    ``rtol scale`` of zero are not resolved by the finite-difference
    linearisation, and there the linearisation does not decide (centres, the
    zero eigenvalue along a curve of equilibria).

    Examples
    --------
    >>> verdict([-1.0 + 2.0j, -1.0 - 2.0j], 3.0), verdict([1e-12j, -1e-12j], 1.0)
    ('stable', 'neutral')
    """
    real = np.real(np.asarray(eigenvalues))
    tol = rtol * float(scale)
    if np.all(real < -tol):
        return "stable"
    return "unstable" if np.any(real > tol) else "neutral"


def eigenvalue_kind(eigenvalues: npt.ArrayLike, scale: float, rtol: float = 1e-7) -> str:
    """The type of a linearisation: ``"node"``, ``"focus"``, ``"saddle"``, ``"centre"`` or ``"degenerate"``.

    Real parts and imaginary parts within ``rtol scale`` of zero count as zero;
    ``"degenerate"``: an eigenvalue is zero; ``"saddle"``: real parts of both
    signs; otherwise ``"node"`` if every eigenvalue is real, ``"centre"`` if every
    one is imaginary, else ``"focus"``.  For the 2 x 2 linearisation in R^3 these
    are the textbook types; in R^n they name the spectrum the same way (a
    ``"focus"`` has a complex pair, a ``"node"`` none).

    Examples
    --------
    >>> eigenvalue_kind([-1 + 1j, -1 - 1j], 1.0), eigenvalue_kind([-1.0, 2.0], 1.0)
    ('focus', 'saddle')
    >>> eigenvalue_kind([-1 + 1j, -1 - 1j, -3.0], 1.0), eigenvalue_kind([-1 + 1j, -1 - 1j, 3.0], 1.0)
    ('focus', 'saddle')
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    tol = rtol * float(scale)
    if np.any(np.abs(lam) <= tol):
        return "degenerate"
    # numpy's stubs type .real/.imag of an array of unknown dtype wrongly
    real, imag = lam.real, lam.imag  # pyright: ignore[reportAttributeAccessIssue]
    if real.min() < -tol and real.max() > tol:
        return "saddle"
    if np.all(np.abs(imag) <= tol):
        return "node"
    return "centre" if np.all(np.abs(real) <= tol) else "focus"


def hessian_type(eigenvalues: npt.ArrayLike, rtol: float = 1e-7) -> str:
    """The critical point of S on a level set from the eigenvalues of its constrained Hessian.

    ``"minimum"`` if every eigenvalue is above ``tol = rtol (|min| + |max|)``,
    ``"maximum"`` if every one is below ``-tol``, ``"saddle"`` if there are both,
    else ``"degenerate"`` (an eigenvalue within ``tol`` of zero, none of the other sign).
    The constrained Hessian is ``T (Hess S - lam Hess H) T^T`` at a point with
    ``grad S = lam grad H`` (``Factorisation.hessian`` in R^3, ``CriticalPoint.hessian_eigenvalues`` in R^n).

    Examples
    --------
    >>> hessian_type([1.0, 2.0]), hessian_type([-1.0, 2.0, 3.0]), hessian_type([0.0, -1.0])
    ('minimum', 'saddle', 'degenerate')
    """
    values = np.sort(np.real(np.asarray(eigenvalues)).astype(float))
    if values.size == 0:
        return "degenerate"
    low, high = float(values[0]), float(values[-1])
    tol = rtol * (abs(low) + abs(high))
    if low > tol:
        return "minimum"
    if high < -tol:
        return "maximum"
    return "saddle" if low < -tol and high > tol else "degenerate"
