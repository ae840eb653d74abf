"""Dense output: the cubic Hermite interpolant through the accepted steps.

On a step ``[t_n, t_{n+1}]`` of length ``h`` with states ``x_n``, ``x_{n+1}``
and fields ``f_n = xi(x_n)``, ``f_{n+1}``, at ``theta = (t - t_n) / h``

    u(t) = (1 - theta) x_n + theta x_{n+1}
           + theta (theta - 1) [ (1 - 2 theta) (x_{n+1} - x_n) + (theta - 1) h f_n + theta h f_{n+1} ]

(Hairer, Norsett, Wanner, *Solving ODEs I*, section II.6): it matches the
states and the field at both ends, and is O(h^4) from a smooth solution
through them, so over a run of order ``p`` it is accurate to
``O(h^min(p, 4))``.  Between steps it is **not** on ``H = H0`` and does not
keep S monotone: only the steps themselves carry the method's structure.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt


class Hermite:
    """``sol(t)``: the state at ``t`` (shape (n,)) or at each of an array of times (shape (n, m)), as
    scipy's ``OdeSolution``; times outside ``[t_0, t_end]`` are refused."""

    def __init__(self, t: npt.ArrayLike, x: npt.ArrayLike, f: npt.ArrayLike) -> None:
        self.t, self.x, self.f = np.asarray(t), np.asarray(x), np.asarray(f)
        self.t_min, self.t_max = float(min(self.t[0], self.t[-1])), float(max(self.t[0], self.t[-1]))
        self._forward = self.t[-1] >= self.t[0]

    def __call__(self, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        times = np.asarray(t, dtype=np.float64)
        if times.dtype.kind != "f" or not np.all(np.isfinite(times)):
            raise ValueError(f"`t` must be finite real times; got {t!r}.")
        if np.any(times < self.t_min) or np.any(times > self.t_max):
            raise ValueError(f"`t` must lie in the solved interval [{self.t_min!r}, {self.t_max!r}]; got {t!r}.")
        flat = times.reshape(-1)
        grid = self.t if self._forward else self.t[::-1]
        i = np.clip(np.searchsorted(grid, flat, side="right") - 1, 0, len(grid) - 2)
        if not self._forward:
            i = len(grid) - 2 - i
        values = self._evaluate(i, flat)
        return values[:, 0] if times.ndim == 0 else values

    def _evaluate(self, i, t):
        t0, t1 = self.t[i], self.t[i + 1]
        h = (t1 - t0)[:, None]
        theta = np.where(h[:, 0] != 0.0, (t - t0) / np.where(t1 != t0, t1 - t0, 1.0), 0.0)[:, None]
        x0, x1, f0, f1 = self.x[i], self.x[i + 1], self.f[i], self.f[i + 1]
        u = (
            (1 - theta) * x0
            + theta * x1
            + theta * (theta - 1) * ((1 - 2 * theta) * (x1 - x0) + (theta - 1) * h * f0 + theta * h * f1)
        )
        return u.T

    def step(self, i: int) -> Callable[[float], npt.NDArray[np.float64]]:
        """The interpolant on step ``i`` alone, as a function of one time: ``(n,)`` array."""
        return lambda t: self._evaluate(np.array([i]), np.array([t], dtype=np.float64))[:, 0]
