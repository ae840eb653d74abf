"""The test problems: systems from the catalogue, initial states, horizons and known answers.

Known answers:
- the free rigid body (R1) by Jacobi elliptic functions (``free_rigid_body_exact``);
- the dissipative oscillator with ``S = c z^2`` has a closed-form solution for any
  eps (``oscillator_exact``, derived below);
- a relaxing rigid body relaxes to the pole on the axis of its largest
  coefficient with ``S_inf = H0 / c`` (paper section 2.1); the quartic body to
  the point of smallest |m| on its level set of H, also on that axis
  (``rigid_body_attractor``).
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np

import geomint
from geomint import systems

#: docs/references.md R1/R2: m0 = (cos 1.1, 0, sin 1.1); R5: x0 = (0.6, 0, 0.8)
RIGID_BODY_X0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
OSCILLATOR_X0 = np.array([0.6, 0.0, 0.8])
INERTIA = (0.5, 1.0, 1.5)
QUARTIC_K = 0.5


@dataclass(frozen=True)
class Problem:
    """A system, an initial state and what is known about the solution.

    ``exact(t)`` gives the state at time t where a closed form exists;
    ``attractor`` the state the trajectory relaxes to, where predicted.
    """

    name: str
    title: str
    system: geomint.MetriplecticSystem
    x0: np.ndarray
    exact: Callable | None = None
    attractor: np.ndarray | None = None


def oscillator_exact(x0, coefficient, eps, t):
    """Exact solution of the dissipative oscillator with ``S = c z^2`` (``coefficients = (0, 0, c)``).

    With ``H = |x|^2/2`` conserved, ``r^2 = 2 H`` and ``rho^2 = x^2 + y^2 = r^2 - z^2``,
    the field gives ``dz/dt = -eps rho^2 S'(z) = -2 c eps (r^2 - z^2) z``, so
    ``u = z^2`` solves the logistic equation ``du/dt = -2k (r^2 - u) u`` with
    ``k = 2 c eps``:

        z(t)^2 = z0^2 e^{-2 k r^2 t} / (1 - (z0^2 / r^2)(1 - e^{-2 k r^2 t})),

    (for c = 1/2, eps = 1 this is docs/references.md R5), and the (x, y) part turns
    clockwise at unit rate with radius rho(t): ``(x, y) = rho(t) (cos(theta0 - t),
    sin(theta0 - t))``.  ``t`` may be an array; returns shape ``t.shape + (3,)``.
    """
    x0 = np.asarray(x0, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    r2 = float(x0 @ x0)
    u0 = x0[2] ** 2
    decay = np.exp(-2.0 * (2.0 * coefficient * eps) * r2 * t)
    u = u0 * decay / (1.0 - (u0 / r2) * (1.0 - decay))
    z = np.sign(x0[2]) * np.sqrt(u)
    rho = np.sqrt(r2 - u)
    theta = np.arctan2(x0[1], x0[0]) - t
    return np.stack([rho * np.cos(theta), rho * np.sin(theta), z], axis=-1)


def free_rigid_body_exact(x0, coefficients, t):
    """Exact free rigid body (eps = 0) by Jacobi elliptic functions, for R1-like data.

    Celledoni, Fasso, Safstrom, Zanna, SIAM J. Sci. Comput. 30 (2008) 2084,
    doi:10.1137/070704393 (docs/references.md R1).  Inertias ``I = 1/coefficients``
    with ``I_0 > I_1 > I_2``, energy ``E2 = 2H``, ``M^2 = |m|^2 < E2 I_1`` (so
    A1 = I_0, A3 = I_2) and ``x0 = (alpha, 0, gamma)``, alpha, gamma > 0 (the
    elliptic phase starts at 0).  With ``u = omega t``:

        m = (alpha cn(u | k^2), beta sn(u | k^2), gamma dn(u | k^2)),

    ``beta = sqrt((E2 A3 - M^2) I_m / (A3 - I_m))``, the sign + because geomint's
    field ``grad H x m`` gives ``dm_1/dt(0) = m_0 m_2 (c - a) > 0``.  u is reduced
    modulo the period 4K before ``scipy.special.ellipj``.
    """
    from scipy.special import ellipj, ellipk

    x0 = np.asarray(x0, dtype=np.float64)
    A1, Im, A3 = (1.0 / np.asarray(coefficients, dtype=np.float64)).tolist()
    if not (A1 > Im > A3 and x0[1] == 0.0 and x0[0] > 0.0 and x0[2] > 0.0):
        raise ValueError(f"free_rigid_body_exact needs I_0 > I_1 > I_2 and x0 = (alpha > 0, 0, gamma > 0); got {x0}.")
    M2 = float(x0 @ x0)
    E2 = float(np.sum(x0 * x0 / np.array([A1, Im, A3])))
    if not M2 < E2 * Im:
        raise ValueError(f"free_rigid_body_exact needs |m|^2 < 2 H I_1; got {M2} >= {E2 * Im}.")
    k2 = (Im - A1) * (E2 * A3 - M2) / ((A3 - Im) * (M2 - E2 * A1))
    omega = np.sqrt((A3 - Im) * (M2 - E2 * A1) / (A1 * Im * A3))
    beta = np.sqrt((E2 * A3 - M2) * Im / (A3 - Im))
    u = np.mod(omega * np.asarray(t, dtype=np.float64), 4.0 * ellipk(k2))
    sn, cn, dn, _ = ellipj(u, k2)
    return np.stack([x0[0] * cn, beta * sn, x0[2] * dn], axis=-1)


def rigid_body_attractor(system, x0):
    """The pole a (quartic) rigid body relaxes to: on the axis of the largest coefficient, same sign as x0.

    Relaxation lowers ``S``, a function of ``|m|^2``, on the level set ``H = H0``:
    the limit is the point of that level set closest to the origin.  Along the
    axis of the largest quadratic coefficient c (with the same quartic k on every
    axis) ``H = c rho^2/2 + k rho^4/4``, so ``rho^2 = 2 H0 / c`` (k = 0, i.e.
    ``S_inf = H0/c``) or ``rho^2 = (sqrt(c^2 + 4 k H0) - c) / k``.
    """
    params = system.params
    axis = int(np.argmax(params[:3]))
    c = params[axis]
    k = params[3] if params.size > 3 else 0.0
    H0 = float(system.H(x0))
    rho2 = 2.0 * H0 / c if k == 0.0 else (np.sqrt(c * c + 4.0 * k * H0) - c) / k
    pole = np.zeros(3)
    pole[axis] = np.copysign(np.sqrt(rho2), x0[axis])
    return pole


def free_rigid_body():
    """docs/references.md R1: the free rigid body (eps = 0)."""
    system = systems.relaxing_rigid_body(*INERTIA, eps=0.0)
    return Problem(
        "free_rigid_body",
        "free rigid body (R1, eps = 0)",
        system,
        RIGID_BODY_X0,
        exact=lambda t: free_rigid_body_exact(RIGID_BODY_X0, INERTIA, t),
    )


def relaxing_rigid_body(eps):
    """docs/references.md R2 with the given eps."""
    system = systems.relaxing_rigid_body(*INERTIA, eps=eps)
    return Problem(
        "relaxing_rigid_body",
        f"relaxing rigid body (R2, eps = {eps:g})",
        system,
        RIGID_BODY_X0,
        attractor=rigid_body_attractor(system, RIGID_BODY_X0),
    )


def quartic_rigid_body(eps):
    """The catalogue's non-quadratic rigid body (k = 0.5) from the R1 state."""
    system = systems.quartic_rigid_body(*INERTIA, k=QUARTIC_K, eps=eps)
    return Problem(
        "quartic_rigid_body",
        f"quartic rigid body (k = {QUARTIC_K:g}, eps = {eps:g})",
        system,
        RIGID_BODY_X0,
        attractor=rigid_body_attractor(system, RIGID_BODY_X0),
    )


def oscillator(eps, coefficient=1.0):
    """docs/references.md R5 with ``S = coefficient * z^2``; the attractor is the equator, tracked by the exact
    solution."""
    system = systems.dissipative_oscillator((0.0, 0.0, coefficient), eps=eps)
    return Problem(
        "dissipative_oscillator",
        f"dissipative oscillator (S = z^2, eps = {eps:g})",
        system,
        OSCILLATOR_X0,
        exact=lambda t: oscillator_exact(OSCILLATOR_X0, coefficient, eps, t),
    )
