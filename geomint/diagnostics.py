"""Diagnostics of solutions: energy error, drift and its growth law, S rises, measured order, work-precision.

Every function takes ``geomint.Solution`` objects (or plain arrays where
noted), so results from ``solve``, scenes, ``geomint.load`` and wrapped
scipy runs are measured the same way.

- ``energy_error(sol)``: ``|H - H0| / |H0|`` at the saved states (absolute when H0 = 0).
- ``Windows`` / ``windowed_drift``: maxima of the energy error over log-spaced
  windows of time, and ``growth_law``: the fitted ``max ~ C t^p`` ("flat",
  "sqrt t" = random walk, "t" = linear drift; "round-off" when the maxima stay within 16 ulp).
- ``S_rises(sol)``: the saved steps where S rose by more than round-off.
- ``observed_order`` / ``measured_order``: the slope of the error against h
  with the round-off plateau excluded (the GeometricIntegrators.jl audit habit).
- ``work_precision`` / ``cost_to_reach`` / ``error_along``: error (at T or along the trajectory)
  against wall time and field evaluations over a sweep of step sizes or
  tolerances, and the cost to reach an error.
"""

import math
import statistics
import time
from dataclasses import dataclass, field

import numpy as np

from .integrators import resolve
from .solve import solve

EPS = float(np.finfo(np.float64).eps)
#: a drift whose windowed maxima stay within this many ulp (multiples of EPS) is round-off: no law is fitted
ROUNDOFF_ULPS = 16


# -- energy --------------------------------------------------------------------------------
def energy_error(sol):
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

    def __post_init__(self):
        self.maxima = np.full(self.edges.size - 1, np.nan)

    @classmethod
    def log_spaced(cls, t_first, t_end, count):
        """``count`` windows with edges from ``t_first`` to ``t_end`` in geometric progression."""
        return cls(np.geomspace(t_first, t_end, count + 1))

    def add(self, t, values):
        """Take the values at times ``t`` into their windows' maxima."""
        index = np.clip(np.searchsorted(self.edges, t, side="right") - 1, 0, self.maxima.size - 1)
        current = np.where(np.isnan(self.maxima), -np.inf, self.maxima)
        np.maximum.at(current, index, values)
        self.maxima = np.where(np.isfinite(current), current, np.nan)

    @property
    def centers(self):
        """Geometric centres of the windows (where their maxima are plotted and fitted)."""
        return np.sqrt(self.edges[:-1] * self.edges[1:])


def windowed_drift(sol, count=20, t_first=None):
    """``(centers, maxima)``: the energy error's maxima over ``count`` log-spaced windows of ``sol.t``.

    ``t_first`` (default: the second saved time) is the first window edge
    after the start; earlier states fall into the first window.
    """
    t = sol.t - sol.t[0]
    if t.size < 2 or t[-1] <= 0:
        raise ValueError(f"`sol` must hold at least two saved times; got {t.size}.")
    t_first = t[1] if t_first is None else float(t_first)
    if not 0 < t_first < t[-1]:
        raise ValueError(f"`t_first` must lie in (0, {t[-1]:g}); got {t_first!r}.")
    windows = Windows.log_spaced(t_first, t[-1], count)
    windows.add(t, energy_error(sol))
    return windows.centers, windows.maxima


def growth_law(t, maxima, t_min, floor=1e-17, roundoff=ROUNDOFF_ULPS):
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


# -- the Casimir ---------------------------------------------------------------------------
def S_rises(sol, ulps=16):
    """Indices ``k`` of the saved pairs where S rose in forward time: ``d (S_{k+1} - S_k) > ulps * eps *
    max(|S_k|, |S_{k+1}|)``, ``d`` the sign of ``t_{k+1} - t_k`` (a backward run sees S rise as t falls).

    ``len(S_rises(sol))`` is ``sol.count_S_rises(ulps)``; the indices say where
    (``sol.t[k + 1]``), for plots.
    """
    S = sol.S
    tol = ulps * EPS * np.maximum(np.abs(S[:-1]), np.abs(S[1:]))
    return np.flatnonzero(np.sign(np.diff(sol.t)) * np.diff(S) > tol)


# -- orders --------------------------------------------------------------------------------
def observed_order(step_sizes, errors, floor=1e-13):
    """Least-squares slope of ``log error`` against ``log h``, round-off plateau excluded.

    Points with ``error <= floor`` (relative round-off level) are dropped, and
    so is everything on the small-h side of the first point where the error
    stops decreasing.  Needs at least three points left (``ValueError``).

    >>> h = np.array([0.1, 0.05, 0.025, 0.0125])
    >>> round(observed_order(h, 3 * h**4), 6)
    4.0
    """
    h = np.asarray(step_sizes, dtype=float)
    e = np.asarray(errors, dtype=float)
    order = np.argsort(h)[::-1]
    h, e = h[order], e[order]
    keep = [0]
    for i in range(1, len(h)):
        if e[i] <= floor or e[i] >= e[keep[-1]]:
            break
        keep.append(i)
    if len(keep) < 3:
        raise ValueError(f"need >= 3 points above the round-off plateau; errors = {e.tolist()}")
    slope, _ = np.polyfit(np.log(h[keep]), np.log(e[keep]), 1)
    return float(slope)


def reference_solution(system, x0, t_end, rtol=1e-13, atol=1e-15):
    """``x(t_end)`` by scipy's DOP853 at tight tolerances (structure-blind, for error measurements)."""
    from scipy.integrate import solve_ivp

    result = solve_ivp(
        lambda t, x: system.xi(x), (0.0, t_end), np.asarray(x0, dtype=float), method="DOP853", rtol=rtol, atol=atol
    )
    if not result.success:
        raise RuntimeError(f"the DOP853 reference failed: {result.message}")
    return result.y[:, -1]


def measured_order(system, method, x0, t_end, step_sizes, reference=None, floor=1e-13):
    """Observed order of ``method`` on ``system`` from ``x0`` to ``t_end``: the slope of the
    relative final-state error against ``h`` (``observed_order``), against ``reference``
    (default: ``reference_solution``).  Returns ``(order, errors)``.
    """
    method = resolve(method)
    reference = reference_solution(system, x0, t_end) if reference is None else np.asarray(reference)
    errors = []
    for h in step_sizes:
        sol = solve(system, x0, (0.0, t_end), h, method=method, save_every=None)
        if not sol.success:
            raise RuntimeError(f"h = {h:g}: {sol.message}")
        errors.append(float(np.max(np.abs(sol.x_final - reference)) / np.max(np.abs(reference))))
    return observed_order(step_sizes, errors, floor), errors


# -- work and precision --------------------------------------------------------------------
@dataclass
class Curve:
    """One method's work-precision sweep: per run its setting (h or rtol), wall time, field evaluations, error."""

    label: str
    kind: str = "geomint"
    structure_preserving: bool = False
    wall: list = field(default_factory=list)
    nfev: list = field(default_factory=list)
    error: list = field(default_factory=list)
    setting: list = field(default_factory=list)


def median_time(run, repeats, budget=2.0):
    """Median wall time of ``run()`` over ``repeats`` calls (fewer when they exceed ``budget`` s in all).

    Returns ``(median seconds, last result)``; call it after a warm-up call so
    compilation is excluded.
    """
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
        if sum(times) > budget:
            break
    return statistics.median(times), result


def error_along(sol, reference):
    """The largest distance ``|x_k - reference(t_k)|_2`` over the states of ``sol``; ``reference(t)`` gives
    ``(len(t), 3)`` states (e.g. a dense DOP853 solution, transposed)."""
    return float(np.max(np.linalg.norm(sol.x - reference(sol.t), axis=1)))


def work_precision(system, x0, t_end, method, step_counts, reference, repeats=3, point_budget=2.0,
                   sweep_budget=math.inf, label=None, *, tolerances=None, samples=1000):
    """Error against cost over a sweep of fixed steps ``h = T / n`` or of tolerances ``rtol = atol``.

    Parameters
    ----------
    system, x0, method
        As for ``geomint.solve``.
    t_end : float
        The end time ``T``.
    step_counts : sequence of int, or None
        Numbers of fixed steps ``n``, coarse to fine; ``None`` with ``tolerances``.
    reference : (3,) array, or callable
        ``x(T)`` (e.g. ``reference_solution``): the error is ``|x(T) - reference|_2``.
        Or ``reference(t) -> (len(t), 3)`` (e.g. a dense DOP853 solution's ``sol``):
        the error is measured **along the trajectory**, ``max_k |x_k - reference(t_k)|_2``
        over the returned states (fixed steps save about ``samples`` of them, adaptive
        runs every accepted step).
    repeats, point_budget
        Median wall time over ``repeats`` runs, fewer past ``point_budget`` seconds.
    sweep_budget : float
        Stop refining after this many seconds; refining stops also once two
        consecutive errors are below 1e-13 (round-off).
    tolerances : sequence of float, optional
        Adaptive runs (``h=None``) with ``rtol = atol`` = each value, loose to tight.
    samples : int
        Saved states per fixed-step run when the error is measured along the trajectory.

    Returns a ``Curve`` whose ``setting`` holds h or rtol (failed runs are left out).
    """
    method = resolve(method)
    if (step_counts is None) == (tolerances is None):
        raise ValueError("work_precision: give exactly one of `step_counts` (fixed steps) and `tolerances` "
                         f"(adaptive steps); got step_counts={step_counts!r}, tolerances={tolerances!r}.")
    along = callable(reference)
    curve = Curve(label or method.name, "geomint", bool(method.energy_exact and method.dissipative))

    def run(setting):
        if tolerances is not None:
            return solve(system, x0, (0.0, t_end), rtol=setting, atol=setting, method=method,
                         save_every=1 if along else None)
        n = round(t_end / setting)
        return solve(system, x0, (0.0, t_end), setting, method=method,
                     save_every=max(1, n // samples) if along else None)

    def error(sol):
        return error_along(sol, reference) if along else float(np.linalg.norm(sol.x_final - reference))

    settings = tolerances if tolerances is not None else [t_end / n for n in step_counts]
    run(settings[0])  # warm-up: compile
    plateau, start = 0, time.perf_counter()
    for setting in settings:
        if time.perf_counter() - start > sweep_budget:
            break
        seconds, sol = median_time(lambda: run(setting), repeats, point_budget)
        if not sol.success:
            continue
        curve.wall.append(seconds)
        curve.nfev.append(sol.nfev)
        curve.error.append(error(sol))
        curve.setting.append(setting)
        plateau = plateau + 1 if curve.error[-1] < 1e-13 else 0
        if plateau == 2:
            break
    return curve


def cost_to_reach(cost, error, target):
    """Cost at which ``error`` first falls to ``target``, interpolated in log-log; NaN if never.

    >>> round(cost_to_reach([1, 10, 100], [1e-2, 1e-4, 1e-6], 1e-5), 1)
    31.6
    """
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    order = np.argsort(cost)
    cost, error = cost[order], error[order]
    below = np.flatnonzero(error <= target)
    if below.size == 0:
        return np.nan
    i = below[0]
    if i == 0 or error[i - 1] == error[i]:
        return float(cost[i])
    w = (np.log(target) - np.log(error[i - 1])) / (np.log(error[i]) - np.log(error[i - 1]))
    return float(np.exp(np.log(cost[i - 1]) + w * (np.log(cost[i]) - np.log(cost[i - 1]))))
