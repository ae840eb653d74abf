"""Panels over time or cost for any solutions: energy error, Casimir, energy drift, work-precision.

Each function takes a ``Solution`` or a list of them (one line each, with a
key for every line) and returns the axis it drew on (a new figure's when
``ax`` is None).  Nothing here depends on the dimension of the state.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import diagnostics as _diagnostics
from ..results import solution as _solution
from ._common import as_list, line_labels, new_axis, style

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy.typing as npt
    from matplotlib.axes import Axes

    from ..results.solution import Solution
    from ..studies import Curve

_TINY = _diagnostics.EPS / 8  # where exact zeros of an error sit on a log axis
_ULP_LABEL = "1 ulp (machine epsilon)"  # ε is the dissipation parameter; multiples of machine epsilon are ulp


def plot_energy_error(
    solutions: Solution | Sequence[Solution],
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
) -> Axes:
    """The running maximum of ``|H - H0| / |H0|`` against t, log scale; 1 ulp (machine epsilon) marked.

    Exact zeros are drawn at 1/8 ulp, the bottom of the axis.  (Figures write the dissipation
    parameter as ε and multiples of machine epsilon as ulp.)
    """
    solutions = as_list(solutions)
    ax = new_axis(ax)
    for i, (sol, name) in enumerate(zip(solutions, line_labels(solutions, labels))):
        running = np.maximum.accumulate(_diagnostics.energy_error(sol))
        line = style(i, len(solutions))
        ax.semilogy(
            sol.t,
            np.maximum(running, _TINY),
            color=line["color"],
            linestyle=line["linestyle"],
            linewidth=1.2,
            label=name,
            drawstyle="steps-post",
        )
    ulp = _diagnostics.EPS
    ax.axhline(ulp, color="0.4", linewidth=0.9, linestyle=":", label=_ULP_LABEL)
    worst = max(float(_diagnostics.energy_error(sol).max()) for sol in solutions)
    top = max(worst * 4, ulp * 4)
    ax.set_ylim(_TINY / 1.5, top)
    return _finish(
        ax,
        "t",
        "running max |H - H0| / |H0|",
        f"energy: max |H - H0|/|H0| = {worst:.2g} ({worst / ulp:.3g} ulp)",
        legend and "lower right",
        len(solutions),
    )


def casimir(
    solutions: Solution | Sequence[Solution],
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
) -> Axes:
    """``S(t)``, one line per solution; every saved step where S moved against its direction beyond round-off
    is marked: a rise where S never rises (the Fish form), a fall where it never falls (a GENERIC entropy,
    ``sol.S_direction`` +1)."""
    solutions = as_list(solutions)
    ax = new_axis(ax)
    against = 0
    generic = all(getattr(sol, "S_direction", -1.0) > 0 for sol in solutions)
    for i, (sol, name) in enumerate(zip(solutions, line_labels(solutions, labels))):
        line = style(i, len(solutions))
        ax.plot(sol.t, sol.S, color=line["color"], linestyle=line["linestyle"], linewidth=1.2, label=name)
        moves = _solution.S_falls(sol) if getattr(sol, "S_direction", -1.0) > 0 else _diagnostics.S_rises(sol)
        up = moves + 1
        against += len(up)
        if len(up):  # (an empty scatter draws nothing, and would still be drawn: one per solution)
            ax.scatter(sol.t[up], sol.S[up], color="red", marker="x", s=18, zorder=4)
    word = ("fall", "falls", "fell") if generic else ("rise", "rises", "rose")
    if against:
        ax.scatter([], [], color="red", marker="x", s=18, label=f"S {word[2]} (beyond 16 ulps)")
    what = "entropy S" if generic else "Casimir S"
    return _finish(
        ax,
        "t",
        "S",
        f"{what}: {against} {word[0] if against == 1 else word[1]} beyond round-off",
        legend and ("lower right" if generic else "upper right"),
        len(solutions),
        "red" if against else "black",
    )


def drift(
    solutions: Solution | Sequence[Solution],
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    count: int = 20,
    t_min: float | None = None,
    legend: bool = True,
) -> Axes:
    """Windowed maxima of ``|H - H0| / |H0|`` on log-log axes, each key with its fitted growth law.

    ``count`` log-spaced windows (``geomint.diagnostics.windowed_drift``); the
    law ``max ~ C t^p`` is fitted for ``t >= t_min`` (default: a tenth of the run).
    """
    solutions = as_list(solutions)
    series, short = [], []
    for sol, name in zip(solutions, line_labels(solutions, labels)):
        if len(sol.t) < 3:  # a run that failed at once has no drift to show
            short.append(name)
            continue
        centers, maxima = _diagnostics.windowed_drift(sol, count)
        series.append((name, centers, maxima, 0.1 * (sol.t[-1] - sol.t[0]) if t_min is None else t_min))
    ax = new_axis(ax)
    for name in short:
        ax.plot([], [], " ", label=f"{name}: fewer than 3 saved states, not drawn")
    return drift_windows(series, ax, legend=legend)


def drift_windows(
    series: Sequence[tuple[str, npt.NDArray[np.float64], npt.NDArray[np.float64], float]],
    ax: Axes | None = None,
    *,
    legend: bool = True,
    law_in_key: bool = True,
    linestyles: Sequence[str] | None = None,
) -> Axes:
    """``drift`` for maxima already taken: ``series`` holds ``(label, centers, maxima, t_min)`` per line.

    For long runs summarised chunk by chunk in a ``geomint.diagnostics.Windows``.
    ``law_in_key=False`` keys lines by label alone (a key shared by panels of
    different problems); ``linestyles`` (one per line) overrides the styles'
    line styles, e.g. to tell two kinds of method apart.
    """
    ax = new_axis(ax)
    for i, (name, centers, maxima, t_min) in enumerate(series):
        p, law = _diagnostics.growth_law(centers, maxima, t_min)
        keep = np.isfinite(maxima)
        line = style(i, len(series))
        if linestyles is not None:
            line["linestyle"] = linestyles[i]
        fit = f": {_law_text(p, law)}" if law_in_key else ""
        ax.loglog(centers[keep], np.maximum(maxima[keep], _TINY), markersize=4, linewidth=1.2, label=name + fit, **line)
    ax.axhline(_diagnostics.EPS, color="0.4", linewidth=0.9, linestyle=":", label=_ULP_LABEL)
    return _finish(
        ax,
        "t",
        "windowed max |H - H0| / |H0|",
        "energy drift: windowed maxima and growth law (zeros drawn at 1/8 ulp)",
        legend and "best",
        len(series),
    )


def _law_text(p, law):
    """A growth law for a key: ``t (p = 1.02)``; none is claimed at round-off."""
    if law == "round-off":
        return f"at round-off (within {_diagnostics.ROUNDOFF_ULPS} ulp), no growth law"
    return law + (f" (p = {p:.2f})" if np.isfinite(p) else "")


def plot_work_precision(
    curves: Curve | Sequence[Curve],
    ax: Axes | None = None,
    *,
    cost: str = "wall",
    legend: bool = True,
    error: str = "global error |x(T) - x_ref(T)|",
) -> Axes:
    """Error against cost for ``geomint.studies.Curve`` objects, one line and key each.

    ``cost`` is ``"wall"`` (median seconds) or ``"nfev"`` (field evaluations);
    ``error`` labels the vertical axis (what the curves' errors measure).
    Structure-preserving methods (exact H, S never rising) are drawn solid.
    """
    if cost not in ("wall", "nfev"):
        raise ValueError(f'`cost` must be "wall" or "nfev"; got {cost!r}.')
    curves = as_list(curves)
    ax = new_axis(ax)
    for i, curve in enumerate(curves):
        line = style(i, len(curves))
        line["linestyle"] = "-" if curve.structure_preserving else "--"
        ax.loglog(getattr(curve, cost), curve.error, markersize=4, linewidth=1.2, label=curve.label, **line)
    return _finish(
        ax,
        "wall time [s] (median)" if cost == "wall" else "field evaluations",
        error,
        "work-precision (solid: exact H and monotone S)",
        legend and "lower left",
        len(curves),
    )


def _finish(ax, xlabel, ylabel, title, legend_at, lines, title_color="black"):
    """Labels, title, grid, and the key at ``legend_at`` (none when falsy; two columns past 10 lines)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10, color=title_color)
    ax.grid(True, which="major", linewidth=0.4, alpha=0.6)
    if legend_at:
        ax.legend(loc=legend_at, fontsize=7, ncol=1 if lines <= 10 else 2)
    return ax
