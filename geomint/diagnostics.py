"""Diagnostics of solutions: energy error, drift and its growth law, S rises, measured order, work-precision.

Every function takes ``geomint.Solution`` objects (or plain arrays where
noted), so results from ``solve``, scenes, ``geomint.load`` and wrapped
scipy runs are measured the same way.

- ``energy_error(sol)``: ``|H - H0| / |H0|`` at the saved states (absolute when H0 = 0).
- ``Windows`` / ``windowed_drift``: maxima of the energy error over log-spaced
  windows of time, and ``growth_law``: the fitted ``max ~ C t^p`` ("flat",
  "sqrt t" = random walk, "t" = linear drift; "round-off" when the maxima stay within 16 ulp).
- ``S_rises(sol)``: the saved steps where S rose by more than round-off.
- ``observed_order``: the slope of the error against h with the round-off plateau excluded (the
  GeometricIntegrators.jl audit habit).
- ``cost_to_reach`` / ``error_along`` / ``median_time``: the cost to reach an error, the error along a
  trajectory, a median wall time.

Runs about runs (``reference_solution``, ``measured_order``, ``work_precision``, ``Curve``) are in
``geomint.studies``: they call ``solve``, which this module, a measure of results, does not
(they stay reachable here under their earlier names).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from .results.solution import S_rises  # noqa: F401 (a measure of one Solution, defined beside it)

if TYPE_CHECKING:
    from typing import TypeVar

    import numpy.typing as npt

    from .results.solution import Solution

    _T = TypeVar("_T")

EPS = float(np.finfo(np.float64).eps)
#: a drift whose windowed maxima stay within this many ulp (multiples of EPS) is round-off: no law is fitted
ROUNDOFF_ULPS = 16


# -- energy --------------------------------------------------------------------------------
def energy_error(sol: Solution) -> npt.NDArray[np.float64]:
    """``|H(t) - H0| / |H0|`` at the saved times, shape ``(n,)`` (absolute error when ``H0 = 0``).

    >>> import geomint
    >>> body = geomint.systems.relaxing_rigid_body(eps=0.1)
    >>> float(energy_error(geomint.solve(body, [0.6, 0.0, 0.8], (0.0, 1.0), 0.1)).max()) < 1e-15
    True
    """
    H0 = sol.H[0]
    return np.abs(sol.H - H0) / (abs(H0) if H0 != 0 else 1.0)


@dataclass
class Windows:
    """Maxima of a quantity over log-spaced windows of time ``[edges[i], edges[i+1])`` (the first from 0).

    Fed chunk by chunk (``add``), so a run of any length is summarised in
    constant memory; empty windows stay NaN.
    """

    edges: np.ndarray
    maxima: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.maxima = np.full(self.edges.size - 1, np.nan)

    @classmethod
    def log_spaced(cls, t_first: float, t_end: float, count: int) -> Windows:
        """``count`` windows with edges from ``t_first`` to ``t_end`` in geometric progression."""
        return cls(np.geomspace(t_first, t_end, count + 1))

    def add(self, t: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Take the values at times ``t`` into their windows' maxima."""
        index = np.clip(np.searchsorted(self.edges, t, side="right") - 1, 0, self.maxima.size - 1)
        current = np.where(np.isnan(self.maxima), -np.inf, self.maxima)
        np.maximum.at(current, index, values)
        self.maxima = np.where(np.isfinite(current), current, np.nan)

    @property
    def centers(self) -> npt.NDArray[np.float64]:
        """Geometric centres of the windows (where their maxima are plotted and fitted)."""
        return np.sqrt(self.edges[:-1] * self.edges[1:])


def windowed_drift(
    sol: Solution,
    count: int = 20,
    t_first: float | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``(centers, maxima)``: the energy error's maxima over ``count`` log-spaced windows of ``sol.t``.

    ``t_first`` (default: the second saved time) is the first window edge
    after the start; earlier states fall into the first window.
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"`count` must be an integer >= 1 (the number of windows); got {count!r}.")
    t = sol.t - sol.t[0]
    if t.size < 2 or t[-1] <= 0:
        raise ValueError(f"`sol` must hold at least two saved times; got {t.size}.")
    t_first = cast(float, t[1]) if t_first is None else float(t_first)
    if not 0 < t_first < t[-1]:
        raise ValueError(f"`t_first` must lie in (0, {t[-1]:g}); got {t_first!r}.")
    windows = Windows.log_spaced(t_first, t[-1], count)
    windows.add(t, energy_error(sol))
    return windows.centers, windows.maxima


def growth_law(
    t: npt.NDArray[np.float64],
    maxima: npt.NDArray[np.float64],
    t_min: float,
    floor: float = 1e-17,
    roundoff: float = ROUNDOFF_ULPS,
) -> tuple[float, str]:
    """Fit ``max |H - H0| ~ C t^p`` over windows with ``t >= t_min``; returns ``(p, law)``.

    ``law`` is "flat" (p < 0.25), "sqrt t" (p < 0.75: a random walk of
    round-off), "t" (p < 1.25: linear drift) or ``"t^p"``; ``"n/a"`` with
    fewer than 3 windows; ``"round-off"`` (and ``p`` NaN) when no maximum
    exceeds ``roundoff`` ulp (``roundoff * EPS``): a slope through a few
    quantised ulp is noise, not a law.  Values are floored at ``floor``
    (exact zeros).

    >>> t = np.geomspace(1, 1e4, 20)
    >>> growth_law(t, 1e-16 * np.sqrt(t), 1.0)[1]
    'sqrt t'
    >>> growth_law(t, EPS * np.minimum(np.round(t ** 0.25), 4.0), 1.0)
    (nan, 'round-off')
    """
    keep = (t >= t_min) & np.isfinite(maxima)
    if np.count_nonzero(keep) < 3:
        return math.nan, "n/a"
    if np.max(maxima[keep]) <= roundoff * EPS:
        return math.nan, "round-off"
    p = float(np.polyfit(np.log(t[keep]), np.log(np.maximum(maxima[keep], floor)), 1)[0])
    if p < 0.25:
        return p, "flat"
    if p < 0.75:
        return p, "sqrt t"
    if p < 1.25:
        return p, "t"
    return p, f"t^{p:.1f}"


# -- orders --------------------------------------------------------------------------------
def observed_order(step_sizes: npt.ArrayLike, errors: npt.ArrayLike, floor: float = 1e-13) -> float:
    """Least-squares slope of ``log error`` against ``log h``, round-off plateau excluded.

    Points with ``error <= floor`` (relative round-off level) are dropped, and
    so is everything on the small-h side of the first point where the error
    stops decreasing.  Needs at least three points left (``ValueError``).

    >>> h = np.array([0.1, 0.05, 0.025, 0.0125])
    >>> round(observed_order(h, 3 * h**4), 6)
    4.0
    """
    h, e = _paired("step_sizes", step_sizes, "errors", errors)
    order = np.argsort(h)[::-1]
    h, e = h[order], e[order]
    keep = [0]
    for i in range(1, len(h)):
        if e[i] <= floor or e[i] >= e[keep[-1]]:
            break
        keep.append(i)
    if len(keep) < 3:
        raise ValueError(
            f"`step_sizes` must give >= 3 errors above the round-off floor {floor:g}, decreasing as h does; got "
            f"step_sizes = {h.tolist()}, errors = {e.tolist()}."
        )
    slope, _ = np.polyfit(np.log(h[keep]), np.log(e[keep]), 1)
    return float(slope)


# -- work and precision --------------------------------------------------------------------
def median_time(run: Callable[[], _T], repeats: int, budget: float = 2.0) -> tuple[float, _T]:
    """Median wall time of ``run()`` over ``repeats`` calls (fewer when they exceed ``budget`` s in all).

    Returns ``(median seconds, last result)``; call it after a warm-up call so
    compilation is excluded.
    """
    if isinstance(repeats, (bool, np.bool_)) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"`repeats` must be an integer >= 1; got {repeats!r}.")
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
        if sum(times) > budget:
            break
    # result is set: with no call, the median of no times raises
    return statistics.median(times), result  # pyright: ignore[reportReturnType]


def error_along(sol: Solution, reference: Callable[[npt.NDArray[np.float64]], Any]) -> float:
    """The largest distance ``|x_k - reference(t_k)|_2`` over the states of ``sol``; ``reference(t)`` gives
    ``(len(t), 3)`` states (e.g. a dense DOP853 solution, transposed)."""
    return float(np.max(np.linalg.norm(sol.x - reference(sol.t), axis=1)))


def cost_to_reach(cost: npt.ArrayLike, error: npt.ArrayLike, target: float) -> float:
    """Cost at which ``error`` first falls to ``target``, interpolated in log-log; NaN if never (or where a cost
    it needs is NaN, unknown).

    >>> round(cost_to_reach([1, 10, 100], [1e-2, 1e-4, 1e-6], 1e-5), 1)
    31.6
    """
    cost, error = _paired("cost", cost, "error", error, unknown_x=True)  # a cost not reported: NaN, unknown
    order = np.argsort(cost)
    cost, error = cost[order], error[order]
    below = np.flatnonzero(error <= target)
    if below.size == 0:
        return np.nan
    i = below[0]
    if i == 0 or error[i - 1] == error[i] or error[i] == 0.0:  # (no log-log line through an exact result)
        return float(cost[i])
    w = (np.log(target) - np.log(error[i - 1])) / (np.log(error[i]) - np.log(error[i - 1]))
    return float(np.exp(np.log(cost[i - 1]) + w * (np.log(cost[i]) - np.log(cost[i - 1]))))


def _paired(
    x_name: str, x: npt.ArrayLike, y_name: str, y: npt.ArrayLike, unknown_x: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Two 1-D float arrays of one length >= 1 for a log-log fit: ``x`` finite and > 0 (or NaN, unknown, where
    ``unknown_x``), ``y`` >= 0 (inf allowed, a run that blew up), no NaN; else a ValueError naming them."""
    a, b = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if a.ndim != 1 or a.size == 0 or b.shape != a.shape:
        raise ValueError(
            f"`{x_name}` and `{y_name}` must be 1-D of one length >= 1; got shapes {a.shape} and {b.shape}."
        )
    if not np.all((np.isfinite(a) & (a > 0.0)) | (unknown_x & np.isnan(a))):
        raise ValueError(f"`{x_name}` must be finite and > 0{' (or NaN)' if unknown_x else ''}; got {a.tolist()}.")
    if np.any(np.isnan(b)) or np.any(b < 0.0):
        raise ValueError(f"`{y_name}` must be >= 0 and not NaN; got {b.tolist()}.")
    return a, b


#: runs about runs that moved to ``geomint.studies``, reachable here under their earlier names
_MOVED_TO_STUDIES = ("Curve", "measured_order", "reference_solution", "work_precision")


def __getattr__(name: str) -> Any:
    """An earlier name of a run about runs, now in ``geomint.studies`` (PEP 562).  studies is imported here by
    name, on first use: it imports this module, and this module imports nothing that runs a solve."""
    if name in _MOVED_TO_STUDIES:
        import importlib

        return getattr(importlib.import_module(f"{__name__.rpartition('.')[0]}.studies"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_MOVED_TO_STUDIES})
