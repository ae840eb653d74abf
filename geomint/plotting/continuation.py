"""Eigenvalue real parts against eps, from ``geomint.continuation.continuation``."""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np

from ._common import pyplot

if TYPE_CHECKING:
    import os
    from collections.abc import Iterable

    from matplotlib.figure import Figure

    from ..analysis.continuation import Continuation


def continuation_figure(
    results: Continuation | Iterable[Continuation],
    path: str | os.PathLike[str] | None = None,
    columns: int = 3,
) -> Figure:
    """Eigenvalue real parts against eps, one panel per ``Continuation`` in ``results``.

    For an isolated equilibrium both tangent-plane eigenvalues' real parts are
    drawn (solid, dashed), for a curve of equilibria its normal eigenvalue, for
    a rest cycle its Floquet exponent (dotted); a vertical line marks each
    change of verdict or kind found at ``eps > 0``.  The eps axis is symmetric-log
    so that ``eps = 0`` shows.  Returns the figure; writes it to ``path`` if given.

    Parameters
    ----------
    results : geomint.continuation.Continuation, or a sequence of them
    path : str or Path, optional
    columns : int

    Examples
    --------
    >>> import geomint
    >>> from geomint.analysis.continuation import continuation
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5)
    >>> fig = continuation_figure([continuation(body, 0.75, [0.0, 0.1, 1.0, 4.0], n=400)])
    >>> len(fig.axes[0].get_lines())   # 6 equilibria x 2 eigenvalues, zero line, 4 focus-node changes
    17
    """
    plt = pyplot()
    one = hasattr(results, "branches")  # one Continuation, or several
    runs = cast("list[Continuation]", [results] if one else list(cast("Iterable[Continuation]", results)))
    rows = -(-len(runs) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.6 * columns, 3.6 * rows), squeeze=False)
    for ax, result in zip(axes.ravel(), runs):
        colors = plt.get_cmap("tab20")(np.arange(len(result.branches)) % 20)
        for color, branch in zip(colors, result.branches):
            real = branch.eigenvalues.real
            style = ":" if branch.object == "cycle" else "-"
            ax.plot(branch.eps, real[:, -1], style, color=color, linewidth=1.4, label=branch.label)
            if branch.object == "equilibrium":
                ax.plot(branch.eps, real[:, 0], "--", color=color, linewidth=1.0)
            for change in branch.changes:
                if not change.at_zero:
                    ax.axvline(change.eps, color=color, linewidth=0.8, alpha=0.6)
        ax.axhline(0.0, color="black", linewidth=0.6)
        eps = result.branches[0].eps
        ax.set_xscale("symlog", linthresh=float(np.min(eps[eps > 0])))
        ax.set_xlim(0.0, float(eps.max()))
        ax.set_xlabel("eps")
        ax.set_ylabel("Re(eigenvalue)")
        ax.set_title(f"{result.name}, H0 = {result.H0:g}", fontsize=9)
        ax.grid(True, linewidth=0.4, alpha=0.6)
        ax.legend(fontsize=5.5, loc="best")
    for ax in axes.ravel()[len(runs) :]:
        ax.set_visible(False)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=130)
    return fig
