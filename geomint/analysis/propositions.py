"""The paper's propositions as predicates at many points, and the proposition that explains a zero.

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
  flow on it is Hamiltonian (``analysis.rest_cycles`` finds these curves on ``H = H0``).
* Section 2.3: at non-regular points (``J = 0``) ``xi = eps xi_g``, which need not vanish.

(Numbers are those of the paper's source, where lemmas, propositions and
equations share one counter.)  ``conditions`` evaluates these geometric
conditions at many points; ``explain`` names the reasons and the proposition for one zero.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from ._common import ZERO, as_points, check_field, require_three

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

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


def conditions(
    system: MetriplecticSystem,
    X: npt.ArrayLike,
    atol: float | None = None,
    rtol: float = ZERO,
) -> Conditions:
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
    require_three(system, "`conditions` (the paper's propositions, stated with cross products)", "`critical_points`")
    X = as_points(X)
    if not (isinstance(rtol, (int, float)) and 0.0 <= rtol < 1.0):
        raise ValueError(f"`rtol` must be a number in [0, 1); got {rtol!r}.")
    gh, gs, j = (np.atleast_2d(f(X)) for f in (system.grad_H, system.grad_S, system.J))
    norms = [np.linalg.norm(v, axis=1) for v in (gh, gs, j)]
    if atol is None:
        atol = rtol * max((float(n.max()) for n in norms if n.size), default=0.0)  # (no points: no conditions)
    small_H, small_S, small_J = (n <= atol for n in norms)
    nh, ns, nj = norms
    xi_P = np.linalg.norm(np.cross(gh, j), axis=1)
    sigma = np.linalg.norm(np.cross(gs, gh), axis=1)
    xi_g = np.linalg.norm(np.cross(gh, np.cross(gh, gs)), axis=1)
    xi_P_zero = small_H | small_J | (xi_P <= rtol * nh * nj)
    xi_g_zero = small_H | small_S | (xi_g <= rtol * nh * nh * ns)
    return Conditions(
        atol=float(atol),
        regular=~small_J,
        critical_H=small_H,
        critical_S=small_S,
        parallel=~small_H & ~small_S & (sigma <= rtol * nh * ns),
        xi_P_zero=xi_P_zero,
        xi_g_zero=xi_g_zero,
        xi_zero=(xi_P_zero if system.hamiltonian else True) & (xi_g_zero | (system.eps == 0.0)),
    )


def shared_equilibria_hold(
    system: MetriplecticSystem,
    X: npt.ArrayLike,
    atol: float | None = None,
) -> npt.NDArray[np.bool_]:
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


def regular_equilibria_explained(
    system: MetriplecticSystem,
    X: npt.ArrayLike,
    atol: float | None = None,
) -> npt.NDArray[np.bool_]:
    """Prop. 10 at each row of ``X``: a regular zero of ``xi_P`` is a critical point of H or has ``grad S || grad H``.

    Returns a boolean array, True where the statement holds.  Where
    ``grad S = 0`` the leaf is not the level set of S and the proposition is silent.
    """
    c = conditions(system, X, atol)
    return ~(c.regular & c.xi_P_zero & ~c.critical_S) | c.critical_H | c.parallel


def gradient_zeros_explained(
    system: MetriplecticSystem,
    X: npt.ArrayLike,
    atol: float | None = None,
) -> npt.NDArray[np.bool_]:
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
    require_three(system, "`gradient_zeros_explained`", "`critical_points`")
    X = as_points(X)
    c = conditions(system, X, atol)
    nh2 = np.linalg.norm(np.atleast_2d(system.grad_H(X)), axis=1) ** 2
    ns = np.linalg.norm(np.atleast_2d(system.grad_S(X)), axis=1)
    bound = 2 * ZERO * nh2 * ns + nh2 * c.atol + c.atol**2 * ns
    field_zero = np.linalg.norm(np.atleast_2d(system.xi_g(X)), axis=1) <= bound
    geometric = c.parallel | c.critical_H | c.critical_S
    return field_zero == geometric


def explain(system: MetriplecticSystem, x: npt.ArrayLike, field: str = "xi") -> tuple[bool, tuple[str, ...], str]:
    """``(regular, reasons, proposition)`` for a zero ``x`` of ``field``.

    ``reasons`` lists the keys of ``REASONS`` that hold at ``x`` (tolerances as
    in ``conditions`` with ``atol`` scaled by ``1 + |x|``).

    Examples
    --------
    >>> import geomint
    >>> explain(geomint.systems.degenerate_example(1), [1.0, 0.0, 0.0])
    (False, ('dS = 0',), 'Section 2.3: non-regular point (P = 0), xi = eps xi_g')
    """
    require_three(system, "`explain`", "`critical_point`")
    field = check_field(field)
    x = cast("npt.NDArray[np.float64]", as_points(x)[0])
    c = conditions(system, x[None], atol=1e-7 * (1.0 + float(np.linalg.norm(x))), rtol=1e-7)
    zero = {"xi": c.xi_zero, "xi_P": c.xi_P_zero, "xi_g": c.xi_g_zero}[field]
    if not bool(np.all(zero)):
        size = float(np.linalg.norm(getattr(system, field)(x)))
        raise ValueError(
            f"`x` must be a zero of `{field}` (the propositions explain equilibria); at x = {x.tolist()} "
            f"|{field}| = {size:.3g}. Find the zeros with geomint.analysis.critical_point or critical_points."
        )
    held = {"critical point of H": c.critical_H[0], "dS = 0": c.critical_S[0], "grad S || grad H": c.parallel[0]}
    reasons = tuple(key for key, on in held.items() if on)
    regular = bool(c.regular[0])
    return regular, reasons, _PROPOSITION[(field, regular)]
