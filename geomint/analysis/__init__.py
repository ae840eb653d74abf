"""Equilibria on a level set ``{H = H0}``, the proposition that explains each, and their stability.

For the field ``xi = xi_P + eps xi_g`` (``xi_P = grad H x J``,
``xi_g = grad H x (grad H x grad S)``) the paper (D. Fish, *Dissipative
perturbations of 3d Hamiltonian systems*, section 1) proves:

* Lemma 6: ``xi_P . xi_g = 0``, so for ``eps > 0``, ``xi = 0`` iff ``xi_P = 0`` and ``xi_g = 0``.
* Lemma 8 / Prop. 9: at *regular* points (``P != 0``, i.e. ``J != 0``) ``xi = 0`` iff ``xi_P = 0``:
  the perturbed and the Hamiltonian system share their regular equilibria.
* Prop. 10: a regular equilibrium is a critical point of H or a point where ``grad S || grad H``.
* Prop. 11: ``xi_g = 0`` iff ``grad H = 0``, ``grad S = 0`` or ``grad S || grad H``
  (critical points of ``S`` restricted to ``H = H0``).
* Prop. 15: where ``grad S = 0`` at a regular point the leaf ``S = S0`` is invariant and the
  flow on it is Hamiltonian (``rest_cycles`` finds these curves on ``H = H0``).
* Section 2.3: at non-regular points (``J = 0``) ``xi = eps xi_g``, which need not vanish.

(Numbers are those of the paper's source, where lemmas, propositions and
equations share one counter.)  ``conditions`` evaluates these geometric
conditions at many points; ``equilibria`` finds the zeros of ``xi``, ``xi_P`` or
``xi_g`` on a level set, labels each with its reason and proposition and
classifies it by the linearisation restricted to the tangent plane of the
level set; connected sets of equilibria (the circle of the rigid body with
``a = b``) come back as one ``EquilibriumCurve``.
"""

from dataclasses import dataclass

import numpy as np

from . import level_set as _level_set

FIELDS = ("xi", "xi_P", "xi_g")
REASONS = {
    "critical point of H": "grad H = 0",
    "dS = 0": "grad S = 0",
    "grad S || grad H": "level sets of H and S touch (sigma = 0)",
}
_PROPOSITION = {
    ("xi", True): "Prop. 9/10: regular equilibrium, shared with the Hamiltonian system",
    ("xi", False): "Section 2.3: non-regular point (P = 0), xi = eps xi_g",
    ("xi_P", True): "Prop. 10: regular equilibrium of the Hamiltonian system",
    ("xi_P", False): "Section 2.3: non-regular point (P = 0), every point is an equilibrium of xi_P",
    ("xi_g", True): "Prop. 11: critical point of S restricted to H = H0",
    ("xi_g", False): "Prop. 11: critical point of S restricted to H = H0 (at a non-regular point)",
}
_ZERO = 1e-9  # a residual at most this fraction of its scale counts as zero
_STEPS_PER_TURN = 96  # curve tracing: steps per 2 pi radius


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
    def kind(self):
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
    def verdict(self):
        """The verdict shared by every point, or ``"mixed"``."""
        unique = set(self.verdicts.tolist())
        return unique.pop() if len(unique) == 1 else "mixed"

    @property
    def x(self):
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


# -- geometric conditions at many points -------------------------------------------------
@dataclass(frozen=True)
class Conditions:
    """Boolean arrays, shape ``(n,)``, of the geometric conditions of the propositions at ``n`` points.

    ``atol`` is the absolute zero used for ``grad H``, ``grad S`` and ``J``.
    """

    atol: float
    regular: np.ndarray
    critical_H: np.ndarray
    critical_S: np.ndarray
    parallel: np.ndarray
    xi_zero: np.ndarray
    xi_P_zero: np.ndarray
    xi_g_zero: np.ndarray


def conditions(system, X, atol=None, rtol=_ZERO):
    """Evaluate at each row of ``X`` the conditions that the paper's propositions relate.

    A vector counts as zero when its norm is at most ``atol``; a product
    (``xi_P = grad H x J``, ``sigma = grad S x grad H``,
    ``xi_g = grad H x (grad H x grad S)``) when a factor is zero or its norm is
    at most ``rtol`` times the product of its factors' norms; ``parallel``
    (``sigma = 0``) needs both gradients non-zero.  ``xi`` is zero
    when ``xi_P`` and ``eps xi_g`` are (they are orthogonal, Lemma 6).

    Parameters
    ----------
    system : MetriplecticSystem
    X : array_like, shape (n, 3) or (3,)
    atol : float, optional
        Absolute zero for ``grad H``, ``grad S`` and ``J``; default ``rtol`` times
        the largest of their norms over ``X``.
    rtol : float

    Returns
    -------
    Conditions

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5)
    >>> c = conditions(body, [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    >>> c.parallel.tolist(), c.xi_zero.tolist(), c.xi_P_zero.tolist()
    ([True, False], [True, False], [True, False])
    """
    X = _points(X)
    if not (isinstance(rtol, (int, float)) and 0.0 <= rtol < 1.0):
        raise ValueError(f"`rtol` must be a number in [0, 1); got {rtol!r}.")
    gh, gs, j = (np.atleast_2d(f(X)) for f in (system.grad_H, system.grad_S, system.J))
    norms = [np.linalg.norm(v, axis=1) for v in (gh, gs, j)]
    if atol is None:
        atol = rtol * max(float(n.max()) for n in norms)
    small_H, small_S, small_J = (n <= atol for n in norms)
    nh, ns, nj = norms
    xi_P = np.linalg.norm(np.cross(gh, j), axis=1)
    sigma = np.linalg.norm(np.cross(gs, gh), axis=1)
    xi_g = np.linalg.norm(np.cross(gh, np.cross(gh, gs)), axis=1)
    xi_P_zero = small_H | small_J | (xi_P <= rtol * nh * nj)
    xi_g_zero = small_H | small_S | (xi_g <= rtol * nh * nh * ns)
    return Conditions(
        atol=float(atol), regular=~small_J, critical_H=small_H, critical_S=small_S,
        parallel=~small_H & ~small_S & (sigma <= rtol * nh * ns), xi_P_zero=xi_P_zero, xi_g_zero=xi_g_zero,
        xi_zero=(xi_P_zero if system.hamiltonian else True) & (xi_g_zero | (system.eps == 0.0)),
    )


def shared_equilibria_hold(system, X, atol=None):
    """Lemma 8 (Prop. 9) at each row of ``X``: at a regular point ``xi = 0`` iff ``xi_P = 0``.

    Returns a boolean array, True where the statement holds (always at
    non-regular points, where it claims nothing).  Needs ``eps > 0`` and the
    Hamiltonian part on.

    Examples
    --------
    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body()
    >>> bool(shared_equilibria_hold(body, [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]).all())
    True
    """
    c = conditions(system, X, atol)
    return ~c.regular | (c.xi_zero == c.xi_P_zero)


def regular_equilibria_explained(system, X, atol=None):
    """Prop. 10 at each row of ``X``: a regular zero of ``xi_P`` is a critical point of H or has ``grad S || grad H``.

    Returns a boolean array, True where the statement holds.  Where
    ``grad S = 0`` the leaf is not the level set of S and the proposition is silent.
    """
    c = conditions(system, X, atol)
    return ~(c.regular & c.xi_P_zero & ~c.critical_S) | c.critical_H | c.parallel


def gradient_zeros_explained(system, X, atol=None):
    """Prop. 11 at each row of ``X``: ``xi_g = 0`` iff ``grad S || grad H`` or a gradient vanishes.

    Compares the norm of the field ``system.xi_g`` itself (not the conditions'
    cross products) against the geometric condition: the field counts as zero
    when ``|xi_g| <= 2 rtol |grad H|^2 |grad S| + |grad H|^2 atol + atol^2 |grad S|``
    (what ``|xi_g| = |grad H|^2 |grad S| sin(angle)`` allows under the tolerances of ``conditions``).

    Examples
    --------
    >>> import geomint
    >>> osc = geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0))
    >>> gradient_zeros_explained(osc, [[1.0, 0.0, 0.0], [0.6, 0.0, 0.8], [0.0, 0.0, 1.0]]).tolist()
    [True, True, True]
    """
    X = _points(X)
    c = conditions(system, X, atol)
    nh2 = np.linalg.norm(np.atleast_2d(system.grad_H(X)), axis=1) ** 2
    ns = np.linalg.norm(np.atleast_2d(system.grad_S(X)), axis=1)
    bound = 2 * _ZERO * nh2 * ns + nh2 * c.atol + c.atol ** 2 * ns
    field_zero = np.linalg.norm(np.atleast_2d(system.xi_g(X)), axis=1) <= bound
    geometric = c.parallel | c.critical_H | c.critical_S
    return field_zero == geometric


def explain(system, x, field="xi"):
    """``(regular, reasons, proposition)`` for a zero ``x`` of ``field``.

    ``reasons`` lists the keys of ``REASONS`` that hold at ``x`` (tolerances as
    in ``conditions`` with ``atol`` scaled by ``1 + |x|``).

    Examples
    --------
    >>> import geomint
    >>> explain(geomint.systems.degenerate_example(1), [1.0, 0.0, 0.0])
    (False, ('dS = 0',), 'Section 2.3: non-regular point (P = 0), xi = eps xi_g')
    """
    field = _check_field(field)
    x = _points(x)[0]
    c = conditions(system, x[None], atol=1e-7 * (1.0 + float(np.linalg.norm(x))), rtol=1e-7)
    held = {"critical point of H": c.critical_H[0], "dS = 0": c.critical_S[0], "grad S || grad H": c.parallel[0]}
    reasons = tuple(key for key, on in held.items() if on)
    regular = bool(c.regular[0])
    return regular, reasons, _PROPOSITION[(field, regular)]


# -- linearisation on the level set -----------------------------------------------------
def tangent_basis(system, x):
    """An orthonormal basis ``(2, 3)`` of the tangent plane ``grad H(x)^perp`` of the level set.

    Raises ``ValueError`` at a critical point of H (no tangent plane).
    """
    return _tangent_bases(system, _points(x))[0]


def _tangent_bases(system, X):
    normal = np.atleast_2d(system.grad_H(X))
    size = np.linalg.norm(normal, axis=1)
    if np.any(size == 0.0):
        x = X[np.argmin(size)]
        raise ValueError(f"`x` must not be a critical point of H (grad H = 0 there); got {x.tolist()}.")
    return np.linalg.svd((normal / size[:, None])[:, None, :])[2][:, 1:]


def linearise(system, x, field="xi", step=None):
    """The Jacobian of ``field`` restricted to the level set through ``x``, and its eigenvalues.

        J_T = T Df(x) T^T,   T = tangent_basis(system, x)   (2 x 2),

    with ``Df`` by central differences of step ``step`` (default
    ``1e-6 (1 + |x|)``).  At an equilibrium the level set is invariant, so the
    eigenvalues of ``J_T`` decide stability within it (the third eigenvalue of
    ``Df``, across the level set, is that of the conserved H and carries no
    information).

    Parameters
    ----------
    system : MetriplecticSystem
    x : array_like, shape (3,) or (m, 3)
    field : {"xi", "xi_P", "xi_g"}

    Returns
    -------
    jacobian : ndarray, shape (2, 2) (or (m, 2, 2))
    eigenvalues : ndarray, shape (2,) (or (m, 2)), complex

    Examples
    --------
    >>> import numpy as np, geomint
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.0)
    >>> _, lam = linearise(body, [0.0, 0.0, 1.0])
    >>> np.round(np.sort_complex(lam), 6)   # a centre: +-i sqrt((c - a)(c - b)) z0
    array([0.-0.707107j, 0.+0.707107j])
    """
    X = _points(x)
    F = _field(system, _check_field(field))
    steps = 1e-6 * (1.0 + np.linalg.norm(X, axis=1)) if step is None else np.full(len(X), float(step))
    shifts = np.concatenate([X + steps[:, None] * e for e in np.eye(3)] + [X - steps[:, None] * e for e in np.eye(3)])
    values = F(shifts).reshape(6, len(X), 3)
    Df = np.stack([(values[i] - values[i + 3]) / (2.0 * steps[:, None]) for i in range(3)], axis=2)
    T = _tangent_bases(system, X)
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

    def jacobian(self, eps):
        """``J_T(eps)``, shape (2, 2)."""
        return (self.mu * self.rotation - eps * self.grad_H_norm ** 2 * np.eye(2)) @ self.hessian

    @property
    def constrained_type(self):
        """``"minimum"``, ``"maximum"``, ``"saddle"`` or ``"degenerate"``: the critical point of S on ``H = H0``."""
        low, high = np.linalg.eigvalsh(self.hessian)
        tol = 1e-7 * (abs(low) + abs(high))
        if low > tol:
            return "minimum"
        if high < -tol:
            return "maximum"
        return "saddle" if low < -tol and high > tol else "degenerate"

    @property
    def node_eps(self):
        """``eps*`` where foci become nodes (``nan`` unless ``S`` has a strict extremum with ``l1 != l2``)."""
        l1, l2 = np.linalg.eigvalsh(self.hessian)
        if l1 * l2 <= 0.0 or l1 == l2:
            return float("nan")
        return float(2.0 * abs(self.mu) * np.sqrt(l1 * l2) / (self.grad_H_norm * abs(l1 - l2)))


def factorise(system, x, step=None):
    """The ``Factorisation`` of the tangent-plane Jacobian at a regular equilibrium ``x`` with ``grad S || grad H``.

    Hessians by central differences of the gradients (step ``1e-6 (1 + |x|)``
    by default).  Raises ``ValueError`` where ``grad H``, ``grad S`` or ``J``
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
    x = _points(x)[0]
    gh, gs, j = (np.asarray(f(x), dtype=float) for f in (system.grad_H, system.grad_S, system.J))
    for name, v in (("grad H", gh), ("grad S", gs), ("J", j)):
        if not np.linalg.norm(v) > 0.0:
            raise ValueError(f"`x` must be a regular point with grad H != 0 and grad S != 0; {name} = 0 at {x.tolist()}.")
    step = 1e-6 * (1.0 + float(np.linalg.norm(x))) if step is None else float(step)
    shifts = np.concatenate([x + step * np.eye(3), x - step * np.eye(3)])
    hess_H, hess_S = (((v[:3] - v[3:]) / (2.0 * step)).T for v in (np.atleast_2d(system.grad_H(shifts)),
                                                                    np.atleast_2d(system.grad_S(shifts))))
    lam, mu = float(gs @ gh / (gh @ gh)), float(j @ gs / (gs @ gs))
    T = tangent_basis(system, x)
    cross = np.array([[0.0, -gh[2], gh[1]], [gh[2], 0.0, -gh[0]], [-gh[1], gh[0], 0.0]])
    L = hess_S - lam * hess_H
    return Factorisation(lam, mu, float(np.linalg.norm(gh)), T @ (0.5 * (L + L.T)) @ T.T, T @ cross @ T.T)


def verdict(eigenvalues, scale, rtol=1e-7):
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


def eigenvalue_kind(eigenvalues, scale, rtol=1e-7):
    """The type of a 2 x 2 linearisation: ``"node"``, ``"focus"``, ``"saddle"``, ``"centre"`` or ``"degenerate"``.

    Real parts and imaginary parts within ``rtol scale`` of zero count as zero;
    ``"degenerate"``: an eigenvalue is zero.

    Examples
    --------
    >>> eigenvalue_kind([-1 + 1j, -1 - 1j], 1.0), eigenvalue_kind([-1.0, 2.0], 1.0)
    ('focus', 'saddle')
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    tol = rtol * float(scale)
    if np.any(np.abs(lam) <= tol):
        return "degenerate"
    if np.all(np.abs(lam.imag) <= tol):
        return "saddle" if lam.real.min() < 0 < lam.real.max() else "node"
    return "centre" if np.all(np.abs(lam.real) <= tol) else "focus"


def _scale(jacobian):
    return float(np.linalg.norm(jacobian)) + 1e-300


def refine(system, x0, H0, field="xi"):
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
    x0 = _points(x0)[0]
    H0 = _check_level(H0)
    F = _field(system, _check_field(field))
    radius = 1.0 + float(np.linalg.norm(x0))
    around = np.concatenate([x0[None], x0 + 0.1 * radius * np.eye(3), x0 - 0.1 * radius * np.eye(3)])
    gh, gs, j = (np.linalg.norm(np.atleast_2d(f(around)), axis=1) for f in (system.grad_H, system.grad_S, system.J))
    scale = float(np.max(gh * (j + max(system.eps, 1.0) * gh * gs))) or 1.0
    x = _Corrector(system, H0, F, scale, max(abs(H0), abs(float(system.H(x0))), 1e-300), radius).correct(x0)
    if x is None:
        raise ValueError(f"`x0` must lie near a zero of {field} on H = {H0!r}; none found from {x0.tolist()}.")
    return x


# -- finding zeros on the level set -----------------------------------------------------
def equilibria(system, H0, field="xi", center=None, n=4000):
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
    F = _field(system, _check_field(field))
    zeros = _zero_set(system, H0, F, center, n)
    found = []
    for kind, data in zeros:
        if kind == "point":
            regular, reasons, proposition = explain(system, data, field)
            jacobian, lam = linearise(system, data, field)
            found.append(Equilibrium(data, field, regular, reasons, proposition, jacobian, lam,
                                     verdict(lam, _scale(jacobian))))
        else:
            found.append(_equilibrium_curve(system, field, *data))
    return found


def rest_cycles(system, H0, center=None, n=4000):
    """The curves ``{grad S = 0} n {H = H0}`` and the stability of the flow ``xi`` across them.

    By Prop. 15 a regular point with ``grad S = 0`` lies on an invariant leaf
    on which the flow is Hamiltonian; on a level set of H such a leaf meets
    ``H = H0`` in curves.  Where ``xi`` does not vanish on the curve it is a
    periodic orbit with period ``T = oint ds / |xi|`` and Floquet exponent

        lambda = (1/T) oint tr(J_T(x)) ds / |xi(x)|,

    ``J_T`` the tangent-plane Jacobian (its trace is the surface divergence of
    ``xi``); ``lambda < 0``: the cycle attracts.

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
    zeros = _zero_set(system, H0, lambda X: np.atleast_2d(system.grad_S(X)), center, n)
    return [classify_cycle(system, points, closed) for kind, (points, closed) in zeros if kind == "curve"]


def classify_cycle(system, points, closed):
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
    regular, reasons = [], None
    for x in points:
        r, why, _ = explain(system, x, field)
        regular.append(r)
        reasons = set(why) if reasons is None else reasons & set(why)
    jacobians, eig = linearise(system, points, field)
    lam = eig[np.arange(len(points)), np.argmax(np.abs(eig), axis=1)].real
    scale = float(np.linalg.norm(jacobians, axis=(1, 2)).max())
    verdicts = np.array([verdict([v], scale) for v in lam])
    return EquilibriumCurve(points, closed, field, np.array(regular), tuple(k for k in REASONS if k in reasons),
                            _PROPOSITION[(field, bool(regular[0]))], lam, verdicts)


def _zero_set(system, H0, Z, center, n):
    """Isolated zeros and traced zero curves of ``Z`` on ``H = H0``: ``[("point", x) | ("curve", (pts, closed))]``."""
    from scipy import spatial  # imported on use: it costs a new process ~0.2 s

    H0 = _check_level(H0)
    if not (isinstance(n, (int, np.integer)) and n >= 20):
        raise ValueError(f"`n` must be an integer >= 20; got {n!r}.")
    center = _level_set.energy_minimiser(system) if center is None else _points(center)[0]
    points = _level_set.on_rays(system, H0, _level_set.fibonacci_directions(int(n)), center)
    size = np.linalg.norm(Z(points), axis=1)
    scale = float(size.max())
    if scale == 0.0:
        return []
    radius = float(np.max(np.linalg.norm(points - center, axis=1)))
    h_scale = max(float(np.abs(system.H(points)).max()), abs(H0), 1e-300)
    solver = _Corrector(system, H0, Z, scale, h_scale, radius)
    _, neighbours = spatial.cKDTree(points).query(points, k=9)
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
            x = optimize.least_squares(lambda x: self.residual(x, plane), x0, jac=lambda x: self.jacobian(x, plane),
                                       xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        ok = np.linalg.norm(self.Z(x[None])[0]) <= _ZERO * self.z_scale
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


# -- helpers -----------------------------------------------------------------------------
def _field(system, field):
    method = {"xi": system.xi, "xi_P": system.xi_P, "xi_g": system.xi_g}[field]
    return lambda X: np.atleast_2d(method(X))


def _check_field(field):
    if field not in FIELDS:
        raise ValueError(f"`field` must be one of {', '.join(FIELDS)}; got {field!r}.")
    return field


def _check_level(H0):
    try:
        value = float(H0)
    except (TypeError, ValueError):
        raise TypeError(f"`H0` must be a real number; got {H0!r}.") from None
    if not np.isfinite(value):
        raise ValueError(f"`H0` must be finite; got {H0!r}.")
    return value


def _points(X):
    try:
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
    except (TypeError, ValueError):
        raise TypeError(f"`x` must be an array of real numbers of shape (3,) or (n, 3); got {X!r}.") from None
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"`x` must have shape (3,) or (n, 3); got shape {X.shape}.")
    return X


def equilibrium_points(system, H0, center, n=4000):
    """``[(x, verdict), ...]`` on ``H = H0``: the points of ``equilibria`` with their verdicts, a curve of
    equilibria contributing each of its traced points (what a figure marks)."""
    pairs = []
    for found in equilibria(system, H0, "xi", center, n):
        if isinstance(found, EquilibriumCurve):
            pairs.extend(zip(found.points, found.verdicts.tolist()))
        else:
            pairs.append((found.x, found.verdict))
    return pairs
