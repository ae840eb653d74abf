"""Figures of scene results (matplotlib, imported lazily with the Agg backend).

``draw(result, directory)`` writes every figure the scene asks for
(``geomint.scene.FIGURES``) as ``<name>.<figure>.png``.  The 3-D panel shows
the level surface ``H = H0`` of each distinct initial energy (at most three),
the trajectories on it (start marked), and the equilibria of the simulated
field on it, found and classified by ``geomint.analysis.equilibria``:
filled = stable, open = unstable, grey = neutral; a curve of equilibria is drawn
as a line.  ``continuation_figure`` plots the eigenvalue real parts of a
``geomint.continuation.continuation`` against eps.
"""

from pathlib import Path

import numpy as np

from . import level_set as _level_set

_EQUILIBRIUM_STYLE = {
    "stable": dict(marker="o", s=46, facecolor="black", edgecolor="black"),
    "unstable": dict(marker="o", s=46, facecolor="white", edgecolor="crimson", linewidths=1.6),
    "neutral": dict(marker="D", s=36, facecolor="grey", edgecolor="black"),
}
_MAX_SURFACES = 3


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw(result, directory):
    """Write the scene's figures under ``directory``; returns their paths."""
    plt = _pyplot()
    directory = Path(directory)
    paths = []
    for figure in result.scene.figures:
        fig = _FIGURES[figure](plt, result)
        path = directory / f"{result.scene.name}.{figure}.png"
        fig.savefig(path, dpi=130)
        plt.close(fig)
        paths.append(path)
    return paths


def _overview(plt, result):
    fig = plt.figure(figsize=(12.0, 6.4))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.1, 1.0), hspace=0.4, wspace=0.12, left=0.0, right=0.97,
                            top=0.86, bottom=0.09)
    trajectories(result, fig.add_subplot(grid[:, 0], projection="3d"))
    invariants(result, fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, 1]))
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _trajectories_figure(plt, result):
    fig = plt.figure(figsize=(7.5, 7.0))
    fig.subplots_adjust(left=0.0, right=0.95, top=0.88, bottom=0.04)
    trajectories(result, fig.add_subplot(projection="3d"))
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _invariants_figure(plt, result):
    fig, (ax_H, ax_S) = plt.subplots(2, 1, figsize=(7.5, 6.4), sharex=True)
    fig.subplots_adjust(top=0.84, hspace=0.3)
    invariants(result, ax_H, ax_S)
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _title(result):
    scene = result.scene
    effects = [name for name, on in (("Hamiltonian", scene.hamiltonian), (f"eps = {scene.eps:g}", scene.eps > 0))
               if on]
    return (f"{scene.title or scene.name}\n{result.system.name}, {' + '.join(effects) or 'no effect'}, "
            f"{result.method.name}, h = {scene.h:g}")


def trajectories(result, ax):
    """Level surfaces, trajectories and equilibria on a 3-D axis."""
    system = result.system
    center = _center(result)
    drawn = [sol.x for sol in result.solutions]
    for H0 in _distinct_energies(result):
        X, Y, Z = _level_set.mesh(system, H0, center)
        drawn.append(np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1))
        for plane in result.scene.sections:
            for curve in _level_set.section(system, H0, center, plane):
                ax.plot(*curve.T, color="darkorange", linewidth=1.4, linestyle="--",
                        label="plane section" if plane == result.scene.sections[0] else None)
        ax.plot_surface(X, Y, Z, color="steelblue", alpha=0.12, linewidth=0.2, edgecolor="lightsteelblue",
                        shade=False, rstride=2, cstride=2)
        _equilibria(ax, system, H0, center)
    colors = _colors(len(result.solutions))
    for i, sol in enumerate(result.solutions):
        ax.plot(sol.x[:, 0], sol.x[:, 1], sol.x[:, 2], color=colors[i], linewidth=1.1)
        ax.scatter(*sol.x[0], color=colors[i], marker="^", s=22, depthshade=False,
                   label="initial state" if i == 0 else None)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.view_init(*result.scene.view)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(_pyplot().MaxNLocator(5))
    _equal_limits(ax, np.vstack(drawn))
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title("trajectories on H = H0", fontsize=10)


def _equilibria(ax, system, H0, center):
    from . import analysis

    marked = set()
    for found in analysis.equilibria(system, H0, "xi", center):
        kind, curve = found.verdict, isinstance(found, analysis.EquilibriumCurve)
        label = f"{kind} equilibri{'a (curve)' if curve else 'um'}"
        label = label if label not in marked else None
        marked.add(label)
        if curve:
            points = np.vstack([found.points, found.points[:1]]) if found.closed else found.points
            color = _EQUILIBRIUM_STYLE.get(kind, _EQUILIBRIUM_STYLE["neutral"])["edgecolor"]
            ax.plot(*points.T, color=color, linewidth=2.4, zorder=5, label=label)
        else:
            ax.scatter(*found.x, depthshade=False, zorder=5, label=label, **_EQUILIBRIUM_STYLE[kind])


def continuation_figure(results, path=None, columns=3):
    """Eigenvalue real parts against eps, one panel per ``Continuation`` in ``results``.

    For an isolated equilibrium both tangent-plane eigenvalues' real parts are
    drawn (solid, dashed), for a curve of equilibria its normal eigenvalue, for
    a rest cycle its Floquet exponent (dotted); a vertical line marks each
    change of verdict or kind found at ``eps > 0``.  The eps axis is symmetric-log
    so that ``eps = 0`` shows.  Returns the figure; writes it to ``path`` if given.

    Parameters
    ----------
    results : sequence of geomint.continuation.Continuation
    path : str or Path, optional
    columns : int

    Examples
    --------
    >>> import geomint
    >>> from geomint.continuation import continuation
    >>> body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5)
    >>> fig = continuation_figure([continuation(body, 0.75, [0.0, 0.1, 1.0, 4.0], n=400)])
    >>> len(fig.axes[0].get_lines())   # 6 equilibria x 2 eigenvalues, zero line, 4 focus-node changes
    17
    """
    plt = _pyplot()
    results = list(results)
    rows = -(-len(results) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.6 * columns, 3.6 * rows), squeeze=False)
    for ax, result in zip(axes.ravel(), results):
        colors = _colors(len(result.branches))
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
    for ax in axes.ravel()[len(results):]:
        ax.set_visible(False)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=130)
    return fig


def invariants(result, ax_H, ax_S):
    """``(H - H0)/|H0|`` and ``S`` against t, one line per trajectory."""
    colors = _colors(len(result.solutions))
    for i, sol in enumerate(result.solutions):
        scale = abs(sol.H[0]) or 1.0
        ax_H.plot(sol.t, (sol.H - sol.H[0]) / scale, color=colors[i], linewidth=1.0)
        ax_S.plot(sol.t, sol.S, color=colors[i], linewidth=1.0)
    eps = np.finfo(np.float64).eps
    ax_H.axhspan(-eps, eps, color="0.85", zorder=0, label="|error| < machine eps")
    worst = max(sol.energy_error for sol in result.solutions)
    ax_H.set_ylabel("(H - H0) / |H0|")
    ax_H.set_title(f"energy: max |H - H0|/|H0| = {worst:.2g} ({worst / eps:.1f} eps)", fontsize=10)
    ax_H.legend(loc="upper right", fontsize=8)
    rises = sum(sol.S_rises for sol in result.solutions)
    ax_S.set_ylabel("S")
    ax_S.set_xlabel("t")
    ax_S.set_title(f"Casimir S: {rises} rises beyond round-off", fontsize=10)
    for ax in (ax_H, ax_S):
        ax.grid(True, linewidth=0.4, alpha=0.6)


def _distinct_energies(result):
    energies = []
    for sol in result.solutions:
        H0 = float(sol.H[0])
        if all(abs(H0 - E) > 1e-9 * max(abs(E), 1.0) for E in energies):
            energies.append(H0)
    return energies[:_MAX_SURFACES]


def _center(result):
    level_set = result.scene.level_set
    if level_set is not None and level_set.get("center") is not None:
        return np.array(level_set["center"], dtype=np.float64)
    return _level_set.energy_minimiser(result.system)


def _equal_limits(ax, points):
    """Equal scales on the three axes: a cube around the bounding box of ``points``."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.525 * float(np.max(hi - lo))
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)


def _colors(n):
    plt = _pyplot()
    return plt.get_cmap("viridis")(np.linspace(0.0, 0.9, max(n, 1)))


_FIGURES = {"overview": _overview, "trajectories": _trajectories_figure, "invariants": _invariants_figure}
