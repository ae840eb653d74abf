"""Relaxation to an equilibrium, measured on a run: the limit S_inf of S (given, known in closed form, or
estimated from the tail), the rate of ``|S - S_inf|`` fitted on a log axis, and for 2-D Euler the distance of
a state from the span of the lowest shell ``|k|^2 = 1``.

Nothing here depends on the dimension of the state; the figures (``geomint.plotting``) and the summaries of
scenes read these.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..systems import euler_modes

if TYPE_CHECKING:
    import numpy.typing as npt

EPS = float(np.finfo(np.float64).eps)
#: a gap |S - S_inf| below this many ulps of S's size is round-off: left out of fits and log axes
FLOOR_ULPS = 64.0


class Limit(NamedTuple):
    """S_inf of one trajectory and where it comes from: ``"given"``, ``"known"`` (closed form) or ``"tail"``."""

    value: float
    source: str
    why: str


def tail_limit(t: npt.ArrayLike, S: npt.ArrayLike) -> Limit:
    """S_inf estimated from the last half of a run: Aitken's extrapolation of three equally spaced values
    ``S_inf = S_2 - d_2^2 / (d_2 - d_1)`` where the differences shrink geometrically (``0 < d_2 / d_1 < 1``);
    the last value where they are at round-off (the run has arrived) or do not shrink (no estimate: the last
    value, said so)."""
    t, S = np.asarray(t, dtype=np.float64), np.asarray(S, dtype=np.float64)
    keep = np.isfinite(S)
    t, S = t[keep], S[keep]
    if len(S) < 3:
        return Limit(float(S[-1]), "tail", "S_inf = the last value of S (too few saved states to extrapolate)")
    # three saved states a quarter of the run apart, ending at the last (equally spaced where the states are
    # saved at a fixed step, as a scene saves them)
    last = len(S) - 1
    k = max(1, last // 4)
    rows = [last - 2 * k, last - k, last]
    S0, S1, S2 = S[rows]
    d1, d2 = S1 - S0, S2 - S1
    roundoff = FLOOR_ULPS * EPS * max(abs(S2), abs(S0), 1e-300)
    if abs(d2) <= roundoff:
        return Limit(float(S[-1]), "tail", "S_inf = the last value of S (S has stopped moving beyond round-off)")
    ratio = d2 / d1 if d1 != 0.0 else np.inf
    if 0.0 < ratio < 1.0:
        return Limit(
            float(S2 + d2 * ratio / (1.0 - ratio)),
            "tail",
            "S_inf estimated from the tail of the run (Aitken's extrapolation over its last half)",
        )
    return Limit(float(S[-1]), "tail", "S_inf = the last value of S (not yet relaxing geometrically: a guess)")


class Rate(NamedTuple):
    """``|S - S_inf| ~ C exp(-rate t)`` fitted over ``t_from <= t <= t_to`` (``points`` saved states)."""

    rate: float
    log_C: float
    t_from: float
    t_to: float
    points: int


def gap(S: npt.ArrayLike, S_inf: float, direction: float) -> np.ndarray:
    """``S - S_inf`` where S falls to its limit (Fish form, ``direction`` -1), ``S_inf - S`` where it rises
    (GENERIC); positive on the way."""
    return (np.asarray(S, dtype=np.float64) - S_inf) * (-direction)


def floor(S: npt.ArrayLike, S_inf: float) -> float:
    """The smallest gap that is not round-off: ``FLOOR_ULPS`` ulps of the size of S."""
    S = np.asarray(S, dtype=np.float64)
    return FLOOR_ULPS * EPS * max(float(np.nanmax(np.abs(S))), abs(S_inf), 1e-300)


def decay_rate(t: npt.ArrayLike, S: npt.ArrayLike, S_inf: float, direction: float) -> Rate | None:
    """The rate of the final exponential approach: a least-squares line through ``log |S - S_inf|`` against t
    over the saved states where the gap lies between 1e-3 of its largest value (past the transient) and 1e4
    times the round-off floor; None with fewer than 5 such states (or none decaying)."""
    t = np.asarray(t, dtype=np.float64)
    g = gap(S, S_inf, direction)
    low = 1e4 * floor(S, S_inf)
    finite = np.isfinite(g)
    if not finite.any():
        return None
    high = 1e-3 * float(np.max(g[finite]))
    keep = finite & (g > low) & (g < high)
    # the last such stretch: the approach, not an earlier excursion
    if keep.sum() < 5:
        return None
    slope, intercept = np.polyfit(t[keep], np.log(g[keep]), 1)
    if not slope < 0.0:
        return None
    return Rate(float(-slope), float(intercept), float(t[keep][0]), float(t[keep][-1]), int(keep.sum()))


def lowest_shell(N: int) -> np.ndarray:
    """The coordinates of the lowest shell ``|k|^2 = 1`` of the N x N Euler truncation (a boolean mask over the
    n = N^2 - 1 coordinates: Re and Im of the modes (0, 1) and (1, 0))."""
    modes = euler_modes(N)
    return np.repeat((modes**2).sum(axis=1) == 1, 2)


def lowest_shell_distance(x: npt.ArrayLike) -> Any:
    """The distance of an Euler state (n = N^2 - 1; or of each of states (m, n)) from the span of the lowest
    shell: the norm of its coordinates outside ``|k|^2 = 1`` (the span's orthogonal projection keeps those
    inside).  A float for one state, an array of m for m."""
    x = np.asarray(x, dtype=np.float64)
    N = int(round(np.sqrt(x.shape[-1] + 1)))
    distance = np.linalg.norm(x[..., ~lowest_shell(N)], axis=-1)
    return float(distance) if x.ndim == 1 else distance
