"""Rigid bodies in the Lie-Poisson bracket of so(3)*: ``J(m) = m``, Casimir a function of |m|^2."""

from numba import njit

from .._cache import CACHE
from .._validate import real
from ..model.system import MetriplecticSystem


@njit(cache=CACHE)
def _quadratic_H(m, p):
    return 0.5 * (p[0] * m[0] * m[0] + p[1] * m[1] * m[1] + p[2] * m[2] * m[2])


@njit(cache=CACHE)
def _quadratic_grad_H(m, p):
    return (p[0] * m[0], p[1] * m[1], p[2] * m[2])


@njit(cache=CACHE)
def _sphere_S(m, p):
    return 0.5 * (m[0] * m[0] + m[1] * m[1] + m[2] * m[2])


@njit(cache=CACHE)
def _sphere_grad_S(m, p):
    return (m[0], m[1], m[2])


@njit(cache=CACHE)
def _identity_J(m, p):
    return (m[0], m[1], m[2])


def _check_coefficient(name, value):
    value = real(name, value)
    if not value > 0.0 or value == float("inf"):
        raise ValueError(f"`{name}` must be a finite positive number; got {value!r}.")
    return value


def relaxing_rigid_body(a: float = 0.5, b: float = 1.0, c: float = 1.5, eps: float = 1.0) -> MetriplecticSystem:
    """Morrison's relaxing rigid body (paper section 2.1).

        H = (a x^2 + b y^2 + c z^2) / 2,   S = |m|^2 / 2,   J = m,

    ``a, b, c > 0`` are the inverse principal moments of inertia.  With
    ``eps = 0`` it is the free rigid body.  For distinct coefficients the
    trajectory relaxes to the pole on the axis of the largest coefficient, where
    ``S = H0 / c_max``; with two equal coefficients there is a circle of
    equilibria.  Defaults are problem R2 of docs/references.md.
    """
    params = [_check_coefficient(k, v) for k, v in (("a", a), ("b", b), ("c", c))]
    return MetriplecticSystem(
        H=_quadratic_H,
        grad_H=_quadratic_grad_H,
        S=_sphere_S,
        grad_S=_sphere_grad_S,
        J=_identity_J,
        eps=eps,
        params=params,
        name="relaxing_rigid_body",
        exact_flows={"rigid_body_flow": params, "rotor_splitting": ()},
    )


@njit(cache=CACHE)
def _quartic_H(m, p):
    x, y, z = m[0], m[1], m[2]
    return 0.5 * (p[0] * x * x + p[1] * y * y + p[2] * z * z) + 0.25 * p[3] * (x**4 + y**4 + z**4)


@njit(cache=CACHE)
def _quartic_grad_H(m, p):
    x, y, z = m[0], m[1], m[2]
    return (p[0] * x + p[3] * x**3, p[1] * y + p[3] * y**3, p[2] * z + p[3] * z**3)


@njit(cache=CACHE)
def _quartic_S(m, p):
    r2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2]
    return 0.5 * r2 + 0.25 * r2 * r2


@njit(cache=CACHE)
def _quartic_grad_S(m, p):
    f = 1.0 + m[0] * m[0] + m[1] * m[1] + m[2] * m[2]
    return (f * m[0], f * m[1], f * m[2])


def quartic_rigid_body(
    a: float = 0.5,
    b: float = 1.0,
    c: float = 1.5,
    k: float = 0.5,
    eps: float = 1.0,
) -> MetriplecticSystem:
    """A rigid body with quartic anisotropy and a quartic Casimir: neither H nor S is quadratic.

        H = (a x^2 + b y^2 + c z^2) / 2 + k (x^4 + y^4 + z^4) / 4,
        S = |m|^2 / 2 + |m|^4 / 4,      J = m.

    S is a function of |m|^2, hence a Casimir of the rigid-body bracket.  This
    is geomint's test bed for discrete gradients: on quadratic H and S every
    symmetric discrete gradient is the midpoint gradient, so only here does a
    missing Gonzalez correction show up as energy drift.  ``k >= 0``.
    """
    params = [_check_coefficient(n, v) for n, v in (("a", a), ("b", b), ("c", c))]
    k = real("k", k)
    if not 0.0 <= k < float("inf"):
        raise ValueError(f"`k` must be finite and >= 0; got {k!r}.")
    return MetriplecticSystem(
        H=_quartic_H,
        grad_H=_quartic_grad_H,
        S=_quartic_S,
        grad_S=_quartic_grad_S,
        J=_identity_J,
        eps=eps,
        params=params + [k],
        name="quartic_rigid_body",
        exact_flows={"rotor_splitting": ()},
    )
