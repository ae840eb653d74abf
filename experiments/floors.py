"""Hand-written numba loops: the cost floors geomint's engine is measured against.

* ``rk4_inlined``: classical RK4 on the relaxing rigid body with the field written
  out in the loop (no function calls at all): what the hardware allows.
* ``rk4_first_class``: the same RK4, reaching H, grad H, S, grad S and J through
  numba first-class function types (``system.model``), exactly as geomint's
  kernels reach a user's functions, with the subnormal flush geomint applies:
  the floor for an engine that calls user functions.
* ``midpoint_batch_inlined``: an ensemble of implicit-midpoint trajectories over
  numba's parallel range, field inlined: the floor for ``solve_ensemble``.

Both run ``n`` steps from ``x0`` and return the final state; they take the
parameters as arguments and compile once (``cache=True``).

The floors share one private helper of the engine (``geomint._kernels.vec3.flush_tiny``), so that a floor
rounds tiny values as the engine does: the comparison is of the same arithmetic.
"""

import numpy as np
from numba import njit, prange

from geomint._kernels.vec3 import flush_tiny


@njit(cache=True)
def rk4_inlined(a, b, c, eps, x0, h, n):
    """RK4 on ``m' = grad H x m + eps grad H x (grad H x m)``, ``H = (a x^2 + b y^2 + c z^2)/2``, field inlined."""
    x, y, z = x0[0], x0[1], x0[2]
    for _ in range(n):
        k = np.empty((4, 3))
        px, py, pz = x, y, z
        for s in range(4):
            gx, gy, gz = a * px, b * py, c * pz
            # grad H x m, and grad H x (grad H x m)
            cx, cy, cz = gy * pz - gz * py, gz * px - gx * pz, gx * py - gy * px
            k[s, 0] = cx + eps * (gy * cz - gz * cy)
            k[s, 1] = cy + eps * (gz * cx - gx * cz)
            k[s, 2] = cz + eps * (gx * cy - gy * cx)
            w = 0.5 * h if s < 2 else h
            if s < 3:
                px, py, pz = x + w * k[s, 0], y + w * k[s, 1], z + w * k[s, 2]
        x += h / 6.0 * (k[0, 0] + 2.0 * k[1, 0] + 2.0 * k[2, 0] + k[3, 0])
        y += h / 6.0 * (k[0, 1] + 2.0 * k[1, 1] + 2.0 * k[2, 1] + k[3, 1])
        z += h / 6.0 * (k[0, 2] + 2.0 * k[1, 2] + 2.0 * k[2, 2] + k[3, 2])
    return np.array([x, y, z])


@njit(inline="always")
def _field(model, eps, buf, x):
    buf[0], buf[1], buf[2] = x
    gh = model.grad_H(buf, model.params)
    gs = model.grad_S(buf, model.params)
    j = model.J(buf, model.params)
    c = (gh[1] * j[2] - gh[2] * j[1], gh[2] * j[0] - gh[0] * j[2], gh[0] * j[1] - gh[1] * j[0])
    d = (gh[1] * gs[2] - gh[2] * gs[1], gh[2] * gs[0] - gh[0] * gs[2], gh[0] * gs[1] - gh[1] * gs[0])
    g = (gh[1] * d[2] - gh[2] * d[1], gh[2] * d[0] - gh[0] * d[2], gh[0] * d[1] - gh[1] * d[0])
    return (c[0] + eps * g[0], c[1] + eps * g[1], c[2] + eps * g[2])


@njit(cache=True)
def rk4_first_class(model, eps, x0, h, n):
    """RK4 with the user functions reached as first-class functions through ``model``, and the flush."""
    buf = np.empty(3)
    x = (x0[0], x0[1], x0[2])
    zero = (0.0, 0.0, 0.0)
    for _ in range(n):
        k1 = _field(model, eps, buf, x)
        k2 = _field(model, eps, buf, (x[0] + 0.5 * h * k1[0], x[1] + 0.5 * h * k1[1], x[2] + 0.5 * h * k1[2]))
        k3 = _field(model, eps, buf, (x[0] + 0.5 * h * k2[0], x[1] + 0.5 * h * k2[1], x[2] + 0.5 * h * k2[2]))
        k4 = _field(model, eps, buf, (x[0] + h * k3[0], x[1] + h * k3[1], x[2] + h * k3[2]))
        x = (
            x[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            x[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            x[2] + h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
        )
        x, _ = flush_tiny(x, zero)
    return np.array(x)


@njit(cache=True, parallel=True)
def midpoint_batch_inlined(a, b, c, eps, X0, h, n):
    """Implicit midpoint on the relaxing rigid body for every row of ``X0`` (prange over trajectories), the field
    written out and the midpoint equation solved by fixed-point iteration to round-off: the ensemble floor
    (the implicit midpoint is Gonzalez's step for this quadratic H with the same Newton cost per iteration)."""
    out = np.empty_like(X0)
    for i in prange(X0.shape[0]):
        x, y, z = X0[i, 0], X0[i, 1], X0[i, 2]
        for _ in range(n):
            nx, ny, nz = x, y, z
            for _ in range(50):
                px, py, pz = 0.5 * (x + nx), 0.5 * (y + ny), 0.5 * (z + nz)
                gx, gy, gz = a * px, b * py, c * pz
                cx, cy, cz = gy * pz - gz * py, gz * px - gx * pz, gx * py - gy * px
                fx = x + h * (cx + eps * (gy * cz - gz * cy))
                fy = y + h * (cy + eps * (gz * cx - gx * cz))
                fz = z + h * (cz + eps * (gx * cy - gy * cx))
                change = abs(fx - nx) + abs(fy - ny) + abs(fz - nz)
                nx, ny, nz = fx, fy, fz
                if change <= 4e-16 * (abs(nx) + abs(ny) + abs(nz)):
                    break
            x, y, z = nx, ny, nz
        out[i, 0], out[i, 1], out[i, 2] = x, y, z
    return out
