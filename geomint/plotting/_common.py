"""What the figure modules share: matplotlib imported on use, line styles and one key per line."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Sequence
    from types import ModuleType

    from matplotlib.axes import Axes

    from ..results.solution import Solution

_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "<", ">", "*")
_LINESTYLES = ("-", "--", ":", "-.")


def pyplot() -> ModuleType:
    """``matplotlib.pyplot``, imported on first use (``import geomint`` does not load it).

    Before pyplot's first import the backend is set to Agg, non-interactive: figures are written to files, no
    window opens and no GUI toolkit is imported.  A backend the user chose is kept: one named by ``MPLBACKEND``,
    or the one of a pyplot already imported (a notebook's, a script's).
    """
    if "matplotlib.pyplot" not in sys.modules and not os.environ.get("MPLBACKEND"):
        import matplotlib

        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def style(i: int, n: int = 1) -> dict[str, Any]:
    """Line style of the ``i``-th of ``n`` lines: colour, line style and marker, distinct up to 40.

    Lines 1-10 get the 10 colours of ``tab10``, solid; lines 11-20 the same
    colours dashed, and so on; the marker shifts by one every 10 lines, so
    colour and marker alone still tell 20 lines apart when a caller sets the
    line style itself.
    """
    plt = pyplot()
    colors = plt.get_cmap("tab10").colors
    return dict(
        color=colors[i % 10],
        linestyle=_LINESTYLES[(i // 10) % len(_LINESTYLES)],
        marker=_MARKERS[(i + i // 10) % len(_MARKERS)] if n > 1 else None,
    )


def as_list(solutions: Any) -> list[Any]:
    return list(solutions) if isinstance(solutions, (list, tuple)) else [solutions]


def line_labels(solutions: Sequence[Solution], labels: Sequence[str] | None) -> list[str]:
    """One key per line: the given labels, else the method (if methods differ) and/or the initial state;
    a failed run's key says where it stopped."""
    if labels is not None:
        if len(labels) != len(solutions):
            raise ValueError(f"`labels` must give one label per solution ({len(solutions)}); got {len(labels)}.")
        names = list(labels)
    else:
        methods = [getattr(sol.method, "name", str(sol.method)) for sol in solutions]
        starts = ["x0 = (" + ", ".join(f"{v:.3g}" for v in sol.x[0]) + ")" for sol in solutions]
        if len(set(methods)) == len(methods):
            names = methods
        elif len(set(methods)) == 1:
            names = starts
        else:
            names = [f"{method}, {start}" for method, start in zip(methods, starts)]
    return [name if sol.success else f"{name} failed, t = {sol.t_final:.3g}" for sol, name in zip(solutions, names)]


def new_axis(ax: Axes | None, projection: str | None = None) -> Axes:
    if ax is not None:
        return ax
    fig = pyplot().figure(figsize=(7.5, 5.0) if projection is None else (7.5, 7.0))
    return fig.add_subplot(projection=projection)
