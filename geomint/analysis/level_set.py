"""[R3] Points on, meshes and plane sections of a level set ``{H = H0}`` of the energy in R^3.

The level set is assumed star-shaped about a centre ``c`` with ``H(c) < H0``
(every catalogue system: ellipsoids and spheres about the minimiser of H).  A
direction ``u`` is mapped onto it by solving ``H(c + r u) = H0`` for ``r > 0``:
bracket by doubling, then bisection to the last bit, vectorised over all rays.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

    Array = npt.NDArray[np.float64]

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def fibonacci_directions(n: int) -> Array:
    """``n`` unit vectors spread almost uniformly over the sphere (Fibonacci lattice).

    ``z_k = 1 - (2k + 1)/n``, azimuth ``k * pi (3 - sqrt 5)``, ``k = 0 .. n-1``;
    every point has area ``4 pi / n`` to within a few per cent (Gonzalez 2010,
    Math. Geosci. 42, 49-64, doi:10.1007/s11004-009-9257-x).
    """
    k = np.arange(n, dtype=np.float64)
    z = 1.0 - (2.0 * k + 1.0) / n
    rho = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = k * _GOLDEN_ANGLE
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)


def energy_minimiser(system: MetriplecticSystem) -> Array:
    """The minimiser of H found from the origin (BFGS with the exact gradient): the default centre.

    Where H has no minimiser (unbounded below) the search ends wherever BFGS gave up, far out; the level
    set is then not star-shaped about it, and callers that mesh by rays fall back or refuse.
    """
    from scipy import optimize  # imported on use: a new process need not load it

    # H unbounded below (x^2/2 + z): BFGS runs off towards infinity and squares huge steps on the way; that
    # overflow is the expected outcome of the search, not the user's doing, so numpy is not to warn about it
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        result = optimize.minimize(
            lambda x: float(system.H(x)),
            np.zeros(3),
            jac=lambda x: np.asarray(system.grad_H(x), dtype=float),
            method="BFGS",
            options={"gtol": 1e-12},
        )
    return np.asarray(result.x, dtype=np.float64)


def on_rays(system: MetriplecticSystem, H0: float, directions: npt.ArrayLike, center: npt.ArrayLike) -> Array:
    """The points ``c + r u`` with ``H(c + r u) = H0``, one per row ``u`` of ``directions``.

    Raises ``ValueError`` when ``H(center) >= H0`` or a ray does not reach the
    level set within ``|r| <= 2^40`` (the set is then not star-shaped about
    ``center`` or not bounded).
    """
    center = np.asarray(center, dtype=np.float64)
    U = np.asarray(directions, dtype=np.float64)
    H_center = float(system.H(center))
    if not H_center < H0:
        raise ValueError(
            f"the level set H = {H0!r} must enclose its centre {center.tolist()}, where H = {H_center!r}; "
            "choose a larger H0 or another centre."
        )
    low = np.zeros(len(U))
    high = np.ones(len(U))
    for _ in range(80):
        outside = system.H(center + high[:, None] * U) >= H0
        if outside.all():
            break
        low = np.where(outside, low, high)
        high = np.where(outside, high, 2.0 * high)
    else:
        raise ValueError(f"the level set H = {H0!r} is not bounded in direction {U[~outside][0].tolist()}.")  # pyright: ignore[reportOperatorIssue]  # the loop ran
    for _ in range(1100):  # bisection until the bracket stops shrinking (at most ~1100 halvings of a double)
        mid = 0.5 * (low + high)
        if np.all((mid == low) | (mid == high)):
            break
        outside = system.H(center + mid[:, None] * U) >= H0
        low = np.where(outside, low, mid)
        high = np.where(outside, mid, high)
    closer = np.abs(system.H(center + low[:, None] * U) - H0) <= np.abs(system.H(center + high[:, None] * U) - H0)
    return center + np.where(closer, low, high)[:, None] * U


def sample(system: MetriplecticSystem, H0: float, n: int, center: npt.ArrayLike | None = None) -> Array:
    """``n`` points spread over the level set ``H = H0``: Fibonacci directions mapped along rays."""
    center = energy_minimiser(system) if center is None else center
    return on_rays(system, H0, fibonacci_directions(n), center)


def mesh(
    system: MetriplecticSystem,
    H0: float,
    center: npt.ArrayLike,
    n_theta: int = 48,
    n_phi: int = 96,
) -> tuple[Array, Array, Array]:
    """``(X, Y, Z)`` arrays of shape ``(n_theta, n_phi)``: a latitude-longitude grid on the level set."""
    theta = np.linspace(0.0, np.pi, n_theta)
    phi = np.linspace(0.0, 2.0 * np.pi, n_phi)
    T, F = np.meshgrid(theta, phi, indexing="ij")
    U = np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], axis=-1).reshape(-1, 3)
    P = on_rays(system, H0, U, center).reshape(n_theta, n_phi, 3)
    return P[..., 0], P[..., 1], P[..., 2]


def isosurface(
    system: MetriplecticSystem,
    H0: float,
    low: npt.ArrayLike,
    high: npt.ArrayLike,
    n: int = 28,
) -> Array:
    """Triangles of the level set ``H = H0`` inside the box ``[low, high]``, shape ``(k, 3, 3)``.

    For level sets that are not star-shaped or not bounded (a cylinder), where
    ``mesh`` cannot parametrise them by rays: marching tetrahedra on an
    ``n``-point grid per axis (each cube cut into 6 tetrahedra around its main
    diagonal, so neighbouring cubes agree on their faces), each vertex
    interpolated linearly on its edge and moved onto the level set by one
    Newton step along ``grad H``.
    """
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    axes = [np.linspace(low[i], high[i], n) for i in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    values = np.asarray(system.H(points), dtype=np.float64) - H0
    base = np.stack(np.meshgrid(*[np.arange(n - 1)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) @ [n * n, n, 1]
    corner = np.array([[(c >> 2) & 1, (c >> 1) & 1, c & 1] for c in range(8)]) @ [n * n, n, 1]
    kuhn = corner[np.array([[0, 4, 6, 7], [0, 4, 5, 7], [0, 2, 6, 7], [0, 2, 3, 7], [0, 1, 5, 7], [0, 1, 3, 7]])]
    tets = (base[:, None, None] + kuhn[None]).reshape(-1, 4)
    positive = values[tets] > 0.0  # pyright: ignore[reportCallIssue, reportArgumentType]  # tets: integers
    count = positive.sum(axis=1)

    def cut(a, b):  # the crossings on the edges a-b of the selected tetrahedra
        fa, fb = values[a], values[b]
        return points[a] + (fa / (fa - fb))[:, None] * (points[b] - points[a])

    lone = tets[(count == 1) | (count == 3)]
    odd = positive[(count == 1) | (count == 3)]
    odd = np.where((odd.sum(axis=1) == 1)[:, None], odd, ~odd)
    lone = np.take_along_axis(lone, np.argsort(~odd, axis=1, kind="stable"), axis=1)
    pair = tets[count == 2]
    pair = np.take_along_axis(pair, np.argsort(~positive[count == 2], axis=1, kind="stable"), axis=1)
    quads = [
        cut(pair[:, 0], pair[:, 2]),
        cut(pair[:, 0], pair[:, 3]),
        cut(pair[:, 1], pair[:, 3]),
        cut(pair[:, 1], pair[:, 2]),
    ]
    triangles = np.concatenate(
        [
            np.stack([cut(lone[:, 0], lone[:, k]) for k in (1, 2, 3)], axis=1),
            np.stack(quads[:3], axis=1),
            np.stack([quads[0], quads[2], quads[3]], axis=1),
        ]
    )
    vertices = triangles.reshape(-1, 3)
    if len(vertices):
        gradient = np.atleast_2d(np.asarray(system.grad_H(vertices), dtype=np.float64))
        norm2 = np.sum(gradient * gradient, axis=1)
        residual = np.asarray(system.H(vertices), dtype=np.float64) - H0
        step = np.divide(residual, norm2, out=np.zeros_like(residual), where=norm2 > 0.0)
        vertices = vertices - step[:, None] * gradient
    return vertices.reshape(-1, 3, 3)


def section(
    system: MetriplecticSystem,
    H0: float,
    center: npt.ArrayLike,
    plane: Sequence[float],
    n_theta: int = 181,
    n_phi: int = 361,
) -> list[Array]:
    """Curves ``{H = H0} n {a x + b y + c z = d}`` as a list of ``(m, 3)`` arrays, ``plane = (a, b, c, d)``.

    The zero contour of ``a x + b y + c z - d`` on a latitude-longitude grid of
    ray directions, each vertex mapped back onto the level set by ``on_rays``
    (so the points lie on H = H0 to round-off and on the plane to the grid's
    interpolation error).
    """
    import contourpy  # a dependency of matplotlib: marching squares without a figure

    X, Y, Z = mesh(system, H0, center, n_theta, n_phi)
    distance = plane[0] * X + plane[1] * Y + plane[2] * Z - plane[3]
    theta, phi = np.linspace(0.0, np.pi, n_theta), np.linspace(0.0, 2.0 * np.pi, n_phi)
    lines = contourpy.contour_generator(phi, theta, distance).lines(0.0)
    curves = []
    for line in lines:
        f, t = line[:, 0], line[:, 1]  # pyright: ignore[reportCallIssue, reportArgumentType]  # an (m, 2) array
        U = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], axis=1)
        curves.append(on_rays(system, H0, U, center))
    return curves
