"""[R3] The axial-vector arithmetic of a metriplectic system in R^3: ``P v = v x J``, cross products, ``curl J``.

In R^3 a skew matrix acts as ``P v = v x J`` with the axial vector
``J = (P_23, -P_13, P_12)``; the fields of the paper are then

    xi_P = grad H x J,   xi_g = grad H x (grad H x grad S),

and Jacobi's identity for P reads ``J . curl J = 0``.  Vectors are 3-tuples of
components: floats at one state, arrays over many.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    #: a vector as 3 components: floats at one state, arrays over many
    Components = tuple[Any, Any, Any]


def components(v: npt.ArrayLike) -> tuple[Any, ...]:
    """A user function's vector (3-tuple or array; a 3x3 ``P`` gives its axial vector) as a 3-tuple of floats."""
    if type(v) is tuple:
        return v
    a = np.asarray(v, dtype=np.float64)
    if a.shape == (3, 3):
        return (float(a[1, 2]), -float(a[0, 2]), float(a[0, 1]))
    return tuple(a.reshape(3).tolist())


def cross(u: Components, v: Components) -> Components:
    """``u x v`` on 3-tuples of components (floats, or arrays over states): plain arithmetic, because on
    one pair ``np.cross``'s checks and broadcasting cost far more than the six products."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def xi_of(gh: Components, gs: Components, j: Components | None, eps: float) -> Components:
    """``grad H x J + eps grad H x (grad H x grad S)`` on 3-tuples of components (floats for one state, arrays
    for many; ``j`` None: without the first term).  Written out once for both: on one state this arithmetic
    and the user calls are all ``xi`` costs."""
    a = (gh[1] * gs[2] - gh[2] * gs[1], gh[2] * gs[0] - gh[0] * gs[2], gh[0] * gs[1] - gh[1] * gs[0])
    d = (gh[1] * a[2] - gh[2] * a[1], gh[2] * a[0] - gh[0] * a[2], gh[0] * a[1] - gh[1] * a[0])
    if j is None:
        return (0.0 + eps * d[0], 0.0 + eps * d[1], 0.0 + eps * d[2])
    return (
        gh[1] * j[2] - gh[2] * j[1] + eps * d[0],
        gh[2] * j[0] - gh[0] * j[2] + eps * d[1],
        gh[0] * j[1] - gh[1] * j[0] + eps * d[2],
    )


def curl(system: Any, points: npt.NDArray[np.float64], step: float) -> npt.NDArray[np.float64]:  # a MetriplecticSystem
    """``curl J`` at ``points`` (n, 3) by central differences of step ``step``, shape (n, 3)."""
    D = np.stack([(system.J(points + step * e) - system.J(points - step * e)) / (2 * step) for e in np.eye(3)], axis=2)
    # D[n, i, j] = d J_i / d x_j
    return np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]], axis=1)
