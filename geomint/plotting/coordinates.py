"""Panels of named coordinates in any dimension: time series of chosen coordinates, and trajectories
projected onto two or three of them.

Each function takes a ``Solution`` or a list of them and the system's coordinate names
(``system.variables``), and returns the axis it drew on (a new figure's when ``ax`` is None).
A name is a coordinate or a family: ``q`` draws q1 ... qN (``geomint.scene.states.expand``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..scene.states import expand
from ._common import as_list, line_labels, new_axis, pyplot, style

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes

    from ..results.solution import Solution


def _columns(variables, names):
    names = expand(names, variables)
    unknown = [name for name in names if name not in variables]
    if unknown:
        raise ValueError(f"`names`: {unknown[0]!r} is not a coordinate; the coordinates are {list(variables)}.")
    return names, [list(variables).index(name) for name in names]


def coordinate_series(
    solutions: Solution | Sequence[Solution],
    variables: Sequence[str],
    names: Sequence[str],
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
    ylabel: str | None = None,
) -> Axes:
    """The coordinates ``names`` against t.

    One solution: a line per coordinate, keyed by its name.  Several: a line per
    solution (keyed by ``labels``) for each coordinate, the coordinates told apart
    by line style.
    """
    solutions = as_list(solutions)
    names, columns = _columns(variables, names)
    ax = new_axis(ax)
    keys = line_labels(solutions, labels)
    single = len(solutions) == 1
    for i, (sol, key) in enumerate(zip(solutions, keys)):
        for j, (name, column) in enumerate(zip(names, columns)):
            line = style(j if single else i, len(names) if single else len(solutions))
            if not single:
                line["linestyle"] = ("-", "--", ":", "-.")[j % 4]
            label = name if single else (key if j == 0 else None)
            ax.plot(
                sol.t, sol.x[:, column], color=line["color"], linestyle=line["linestyle"], linewidth=1.1, label=label
            )
    if not single and len(names) > 1:
        for j, name in enumerate(names[:4]):
            ax.plot([], [], color="0.3", linestyle=("-", "--", ":", "-.")[j], label=name)
    ax.set_xlabel("t")
    ax.set_ylabel(ylabel or (names[0] if len(names) == 1 else "coordinates (see the key)"))
    ax.grid(True, linewidth=0.4, alpha=0.6)
    if legend:
        count = len(names) if single else len(solutions)
        ax.legend(loc="best", fontsize=7, ncol=1 if count <= 8 else 2)
    return ax


def phase_projection(
    solutions: Solution | Sequence[Solution],
    variables: Sequence[str],
    names: Sequence[str],
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    legend: bool = True,
    view: tuple[float, float] = (30.0, -60.0),
) -> Axes:
    """The trajectories projected onto the 2 or 3 coordinates ``names``: a line each, its start a circle and
    its end a filled square (a failed run's end a red cross)."""
    solutions = as_list(solutions)
    names, columns = _columns(variables, names)
    if len(names) not in (2, 3):
        raise ValueError(f"`names` must give 2 or 3 coordinates to project onto; got {names}.")
    three = len(names) == 3
    ax = new_axis(ax, "3d" if three else None)
    for i, (sol, key) in enumerate(zip(solutions, line_labels(solutions, labels))):
        line = style(i, len(solutions))
        points = [sol.x[:, c] for c in columns]
        ax.plot(*points, color=line["color"], linestyle=line["linestyle"], linewidth=1.0, label=key)
        start = [p[:1] for p in points]
        end = [p[-1:] for p in points]
        ax.scatter(*start, color=line["color"], marker="o", s=22, facecolors="none", zorder=4)
        if sol.success:
            ax.scatter(*end, color=line["color"], marker="s", s=22, zorder=4)
        else:
            ax.scatter(*end, color="red", marker="x", s=40, zorder=5)
    ax.scatter([], [], color="0.3", marker="o", facecolors="none", s=22, label="start")
    ax.scatter([], [], color="0.3", marker="s", s=22, label="end")
    ax.set_xlabel(names[0])
    ax.set_ylabel(names[1])
    if three:
        ax.set_zlabel(names[2])  # pyright: ignore[reportAttributeAccessIssue]  # a 3-D axis
        ax.view_init(*view)  # pyright: ignore[reportAttributeAccessIssue]
    else:
        ax.grid(True, linewidth=0.4, alpha=0.6)
    ax.set_title(f"projection onto ({', '.join(names)})", fontsize=10)
    if legend:
        ax.legend(loc="best", fontsize=7, ncol=1 if len(solutions) <= 10 else 2)
    return ax


def series_grid(
    solutions: Solution | Sequence[Solution],
    variables: Sequence[str],
    names: Sequence[str],
    *,
    labels: Sequence[str] | None = None,
    most: int = 8,
    title: str | None = None,
):
    """A figure of time series: one panel (a line per coordinate) for one solution; for several, a panel per
    coordinate (at most ``most``), a line per solution, one key; ``title`` above.  Returns the figure."""
    plt = pyplot()
    solutions = as_list(solutions)
    names, _ = _columns(variables, names)
    if len(solutions) == 1 or len(names) == 1:
        fig = plt.figure(figsize=(8.5, 4.6))
        ax = fig.add_subplot()
        coordinate_series(solutions, variables, names, ax, labels=labels, legend=False)
        ax.legend(
            loc="center left",
            bbox_to_anchor=(1.01, 0.5),
            fontsize=7,
            frameon=False,
            ncol=1 if len(ax.get_legend_handles_labels()[1]) <= 20 else 2,
        )
        if title:
            fig.suptitle(title, fontsize=10)
        return fig
    shown = names[:most]
    columns = 2 if len(shown) > 3 else 1
    rows = int(np.ceil(len(shown) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(6.0 * columns, 2.1 * rows + 0.9), sharex=True, squeeze=False)
    for k, name in enumerate(shown):
        ax = axes[k // columns, k % columns]
        coordinate_series(solutions, variables, [name], ax, labels=labels, legend=False)
        if k // columns < rows - 1:
            ax.set_xlabel("")
    for k in range(len(shown), rows * columns):
        axes[k // columns, k % columns].set_visible(False)
    handles, keys = axes[0, 0].get_legend_handles_labels()
    fig.legend(
        handles,
        keys,
        loc="center left",
        bbox_to_anchor=(1.0, 0.5),
        fontsize=7,
        frameon=False,
        ncol=1 if len(keys) <= 20 else 2,
    )
    if len(names) > most:
        fig.text(0.01, 0.005, f"first {most} of {len(names)} coordinates drawn", fontsize=7, color="0.3")
    top = 1.0 - 0.75 / fig.get_figheight() if title else 1.0
    fig.tight_layout(rect=(0.0, 0.0, 1.0, top))
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
