"""Panels of relaxation to an equilibrium, in any dimension: the energy error in ulps, S with its limit, and
``|S - S_inf|`` on a log axis with the fitted exponential rate.

Each function takes a ``Solution`` or a list of them and returns the axis it drew on (a new figure's when
``ax`` is None).  S_inf comes from ``geomint.scene.relaxation`` (a scene's ``limit``) or from the caller.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..scene import relaxation as _relaxation
from ._common import as_list, line_labels, new_axis, style

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes

    from ..results.solution import Solution

EPS = _relaxation.EPS


def energy_ulps(
    solutions: Solution | Sequence[Solution],
    scales: Sequence[float] | None = None,
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
    energy: str = "H",
) -> Axes:
    """``(H - H0) / (eps_mach * scale)`` against t: the energy error in ulps, step by step (thin) and its running
    maximum of the absolute value (thick, steps).

    ``scales`` (one per solution) is the size of the energy's terms the ulps are counted in, default ``|H0|``;
    a scene gives ``max(|H0|, |grad H(x0)| |x0|)``, the size whose rounding a value of H carries (where H0 is
    small beside its terms, ulps of H0 would overstate the error).  ``energy`` names it (``"E"`` in GENERIC
    form).
    """
    solutions = as_list(solutions)
    ax = new_axis(ax)
    worst = 0.0
    for i, (sol, key) in enumerate(zip(solutions, line_labels(solutions, labels))):
        scale = abs(float(sol.H[0])) if scales is None else float(scales[i])
        scale = scale if scale > 0.0 else 1.0
        ulps = (sol.H - sol.H[0]) / (EPS * scale)
        line = style(i, len(solutions))
        ax.plot(sol.t, ulps, color=line["color"], linewidth=0.5, alpha=0.5)
        running = np.maximum.accumulate(np.abs(np.nan_to_num(ulps)))
        ax.plot(
            sol.t,
            running,
            color=line["color"],
            linestyle=line["linestyle"],
            linewidth=1.4,
            drawstyle="steps-post",
            label=key,
        )
        worst = max(worst, float(np.nanmax(np.abs(ulps))))
    ax.axhline(0.0, color="0.5", linewidth=0.6)
    for level in (1.0, -1.0):
        ax.axhline(level, color="0.4", linewidth=0.8, linestyle=":")
    ax.plot([], [], color="0.4", linewidth=0.8, linestyle=":", label="±1 ulp")
    ax.plot([], [], color="0.4", linewidth=0.5, alpha=0.6, label=f"{energy} - {energy}0 (each saved step)")
    ax.plot([], [], color="0.2", linewidth=1.4, label=f"running max |{energy} - {energy}0|")
    top = max(2.0, 1.2 * worst)
    ax.set_ylim(-top, top)
    ax.set_xlabel("t")
    ax.set_ylabel(f"({energy} - {energy}0) [ulp of {energy}'s terms]")
    ax.set_title(
        f"energy {energy}: max |{energy} - {energy}0| = {worst:.3g} ulp (1 ulp = 2^-52 of the terms' size)", fontsize=10
    )
    ax.grid(True, linewidth=0.4, alpha=0.6)
    if legend:
        ax.legend(loc="upper left", fontsize=7, ncol=1 if len(solutions) <= 8 else 2)
    return ax


def entropy(
    solutions: Solution | Sequence[Solution],
    limits: Sequence[float] | None = None,
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
    what: str = "S",
) -> Axes:
    """S against t, one line per solution, each limit S_inf a dashed line of its colour."""
    solutions = as_list(solutions)
    ax = new_axis(ax)
    for i, (sol, key) in enumerate(zip(solutions, line_labels(solutions, labels))):
        line = style(i, len(solutions))
        ax.plot(sol.t, sol.S, color=line["color"], linestyle=line["linestyle"], linewidth=1.2, label=key)
        if limits is not None:
            ax.axhline(limits[i], color=line["color"], linewidth=0.8, linestyle=(0, (4, 3)), alpha=0.8)
    if limits is not None:
        ax.plot([], [], color="0.3", linewidth=0.8, linestyle=(0, (4, 3)), label="S∞")
    ax.set_xlabel("t")
    ax.set_ylabel(what)
    ax.grid(True, linewidth=0.4, alpha=0.6)
    if legend:
        ax.legend(loc="best", fontsize=7, ncol=1 if len(solutions) <= 8 else 2)
    return ax


def entropy_gap(
    solutions: Solution | Sequence[Solution],
    limits: Sequence[float],
    direction: float = -1.0,
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
    fit: bool = True,
    reference: tuple[float, str] | None = None,
) -> Axes:
    """``|S - S_inf|`` against t on a log axis (``S - S_inf`` where S falls to it, ``direction`` -1; ``S_inf - S``
    where it rises), down to round-off (``geomint.scene.relaxation.floor``, dotted); with ``fit``, the fitted
    exponential ``C exp(-rate t)`` of each (``decay_rate``) dashed, its rate in the key.  ``reference = (rate,
    label)`` draws a slope to compare with (e.g. the linearised ``8 eps H0`` of 2-D Euler), through the first
    fitted line's end."""
    solutions = as_list(solutions)
    ax = new_axis(ax)
    lowest = np.inf
    anchor = None
    for i, (sol, key) in enumerate(zip(solutions, line_labels(solutions, labels))):
        line = style(i, len(solutions))
        g = _relaxation.gap(sol.S, limits[i], direction)
        floor = _relaxation.floor(sol.S, limits[i])
        lowest = min(lowest, floor)
        shown = np.where(g > floor, g, np.nan)
        rate = _relaxation.decay_rate(sol.t, sol.S, limits[i], direction) if fit else None
        text = key if rate is None else f"{key}: rate {rate.rate:.4g}"
        ax.semilogy(sol.t, shown, color=line["color"], linestyle=line["linestyle"], linewidth=1.3, label=text)
        if rate is not None:
            t = np.linspace(rate.t_from, rate.t_to, 50)
            ax.semilogy(t, np.exp(rate.log_C - rate.rate * t), color="black", linewidth=0.9, linestyle="--", alpha=0.7)
            anchor = anchor or (rate.t_to, float(np.exp(rate.log_C - rate.rate * rate.t_to)), rate.t_from)
    if fit:
        ax.plot([], [], color="black", linewidth=0.9, linestyle="--", alpha=0.7, label="fit C exp(-rate t)")
    if reference is not None and anchor is not None:
        t_to, g_to, t_from = anchor
        t = np.linspace(t_from, t_to, 50)
        ax.semilogy(
            t,
            g_to * np.exp(reference[0] * (t_to - t)),
            color="tab:red",
            linewidth=1.0,
            linestyle=":",
            label=reference[1],
        )
    if np.isfinite(lowest):
        ax.axhline(lowest, color="0.5", linewidth=0.8, linestyle=":")
        ax.plot(
            [],
            [],
            color="0.5",
            linewidth=0.8,
            linestyle=":",
            label=f"round-off ({_relaxation.FLOOR_ULPS:g} ulp of S): below it, not drawn",
        )
    ax.set_xlabel("t")
    ax.set_ylabel("S - S∞" if direction < 0 else "S∞ - S")
    ax.grid(True, which="major", linewidth=0.4, alpha=0.6)
    if legend:
        ax.legend(loc="upper right", fontsize=7, ncol=1 if len(solutions) <= 8 else 2)
    return ax
