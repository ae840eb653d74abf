"""Closed-form reference solutions, for tests and experiments."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

from .._kernels import exact_flows as _exact


def rigid_body_exact(a: float, b: float, c: float, m0: npt.ArrayLike, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The free rigid body ``m' = grad H x m``, ``H = (a x^2 + b y^2 + c z^2) / 2``, at the times ``t``.

    Jacobi elliptic functions (sn, cn, dn by the AGM, the phase by Carlson's
    R_F); formulas in ``geomint._kernels.exact_flows.rigid_body_flow``.
    Reference: Celledoni, Fasso, Safstrom, Zanna, SIAM J. Sci. Comput. 30 (2008)
    2084, doi:10.1137/070704393.  Our field ``grad H x m`` is the time reverse
    of the book's ``m x grad H``.

    Parameters
    ----------
    a, b, c : float
        Positive coefficients of H (inverse principal moments of inertia).
    m0 : array_like, shape (3,)
        The state at ``t = 0``.
    t : float or array_like, shape (n,)

    Returns
    -------
    ndarray, shape (3,) for scalar ``t``, else (n, 3).

    Examples
    --------
    >>> import numpy as np, geomint
    >>> m = geomint.reference.rigid_body_exact(0.5, 1.0, 1.5, [np.cos(1.1), 0.0, np.sin(1.1)], [0.0, 10.7314652348828])
    >>> bool(np.allclose(m[0], m[1], atol=1e-12))  # one period (docs/references.md R1)
    True
    """
    coefficients = []
    for name, value in (("a", a), ("b", b), ("c", c)):
        value = float(value)
        if not (np.isfinite(value) and value > 0.0):
            raise ValueError(f"`{name}` must be a finite positive number; got {value!r}.")
        coefficients.append(value)
    m0 = np.asarray(m0, dtype=np.float64)
    if m0.shape != (3,) or not np.all(np.isfinite(m0)):
        raise ValueError(f"`m0` must be 3 finite numbers; got {m0.tolist()!r}.")
    times = np.asarray(t, dtype=np.float64)
    if times.ndim > 1 or not np.all(np.isfinite(times)):
        raise ValueError(f"`t` must be a finite number or 1-D array of them; got shape {times.shape}.")
    flat = np.ascontiguousarray(np.atleast_1d(times))
    out = np.empty((flat.size, 3))
    _exact.rigid_body_flow_at(*coefficients, (m0[0], m0[1], m0[2]), flat, out)  # pyright: ignore[reportCallIssue]
    return out[0] if times.ndim == 0 else out
