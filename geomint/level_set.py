"""Points on, meshes of, and equilibria on a level set ``{H = H0}`` of the energy.

The level set is assumed star-shaped about a centre ``c`` with ``H(c) < H0``
(every catalogue system: ellipsoids and spheres about the minimiser of H).  A
direction ``u`` is mapped onto it by solving ``H(c + r u) = H0`` for ``r > 0``:
bracket by doubling, then bisection to the last bit, vectorised over all rays.
"""

import numpy as np

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def fibonacci_directions(n):
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


def energy_minimiser(system):
    """The minimiser of H found from the origin (BFGS with the exact gradient): the default centre."""
    from scipy import optimize  # imported on use: it costs a new process ~0.3 s

    result = optimize.minimize(
        lambda x: float(system.H(x)), np.zeros(3), jac=lambda x: np.asarray(system.grad_H(x), dtype=float),
        method="BFGS", options={"gtol": 1e-12},
    )
    return np.asarray(result.x, dtype=np.float64)


def on_rays(system, H0, directions, center):
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
        raise ValueError(f"the level set H = {H0!r} is not bounded in direction {U[~outside][0].tolist()}.")
    for _ in range(1100):  # bisection until the bracket stops shrinking (at most ~1100 halvings of a double)
        mid = 0.5 * (low + high)
        if np.all((mid == low) | (mid == high)):
            break
        outside = system.H(center + mid[:, None] * U) >= H0
        low = np.where(outside, low, mid)
        high = np.where(outside, mid, high)
    closer = np.abs(system.H(center + low[:, None] * U) - H0) <= np.abs(system.H(center + high[:, None] * U) - H0)
    return center + np.where(closer, low, high)[:, None] * U


def sample(system, H0, n, center=None):
    """``n`` points spread over the level set ``H = H0``: Fibonacci directions mapped along rays."""
    center = energy_minimiser(system) if center is None else center
    return on_rays(system, H0, fibonacci_directions(n), center)


def mesh(system, H0, center, n_theta=48, n_phi=96):
    """``(X, Y, Z)`` arrays of shape ``(n_theta, n_phi)``: a latitude-longitude grid on the level set."""
    theta = np.linspace(0.0, np.pi, n_theta)
    phi = np.linspace(0.0, 2.0 * np.pi, n_phi)
    T, F = np.meshgrid(theta, phi, indexing="ij")
    U = np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], axis=-1).reshape(-1, 3)
    P = on_rays(system, H0, U, center).reshape(n_theta, n_phi, 3)
    return P[..., 0], P[..., 1], P[..., 2]


def section(system, H0, center, plane, n_theta=181, n_phi=361):
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
        f, t = line[:, 0], line[:, 1]
        U = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], axis=1)
        curves.append(on_rays(system, H0, U, center))
    return curves


def equilibria(system, H0, center, n=4000):
    """Equilibria of the field on ``H = H0`` with their stability: ``[(x, kind), ...]``.

    Candidates are the local minima of ``|xi|`` (over each point's 8 nearest
    neighbours) of an ``n``-point Fibonacci sample with ``|xi| < 0.2 max |xi|``; each is refined by least squares on
    ``(xi(x), H(x) - H0) = 0`` and kept when ``|xi| <= 1e-9 max |xi|``.  ``kind``
    comes from the linearisation restricted to the tangent plane ``grad H^perp``
    (central differences): ``"stable"`` when both eigenvalues have real part
    below ``-tol``, ``"unstable"`` when one is above ``tol``, else ``"neutral"``
    (centres, and the zero direction along a curve of equilibria), with
    ``tol = 1e-5 * |Df|``.  A curve of equilibria comes back as points along it.
    """
    from scipy import optimize, spatial  # imported on use: they cost a new process ~0.3 s

    points = on_rays(system, H0, fibonacci_directions(n), center)
    speed = np.linalg.norm(system.xi(points), axis=1)
    scale = float(speed.max())
    if scale == 0.0:
        return []
    found = []
    radius = float(np.max(np.linalg.norm(points - center, axis=1)))
    _, neighbours = spatial.cKDTree(points).query(points, k=9)
    candidates = (speed <= speed[neighbours].min(axis=1)) & (speed < 0.2 * scale)
    for x0 in points[candidates]:
        x = optimize.least_squares(
            lambda x: np.append(system.xi(x), system.H(x) - H0), x0, xtol=1e-15, ftol=1e-15, gtol=1e-15
        ).x
        if np.linalg.norm(system.xi(x)) > 1e-9 * scale:
            continue
        if any(np.linalg.norm(x - y) < 1e-3 * radius for y, _ in found):
            continue
        found.append((x, _stability(system, x, radius)))
    return found


def _stability(system, x, radius):
    step = 1e-6 * radius
    Df = np.stack([(system.xi(x + step * e) - system.xi(x - step * e)) / (2.0 * step) for e in np.eye(3)], axis=1)
    normal = np.asarray(system.grad_H(x), dtype=float)
    normal = normal / np.linalg.norm(normal)
    tangent = np.linalg.svd(np.eye(3) - np.outer(normal, normal))[0][:, :2]
    real = np.linalg.eigvals(tangent.T @ Df @ tangent).real
    tol = 1e-5 * (np.linalg.norm(Df) + 1e-300)
    if np.all(real < -tol):
        return "stable"
    return "unstable" if np.any(real > tol) else "neutral"
