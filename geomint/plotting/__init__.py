"""Figures of solutions and scene results (matplotlib, imported lazily with the Agg backend).

Functions that take any ``Solution`` (or a list of them, one line each, with
a key for every line; up to 20 distinct styles from ``style``):

- ``level_surface(system, solutions)``: trajectories on the level surface ``H = H0``
  in 3-D with the equilibria of the field on it (filled = stable, open =
  unstable, grey = neutral; a curve of equilibria drawn as a curve; those
  behind the surface are left out and counted in the key); failed
  trajectories end in a red cross and are counted in the title; on an
  unbounded level set the axes fit the trajectories and the surface is
  clipped to them.
- ``energy_error(solutions)``: the running maximum of ``|H - H0| / |H0|`` (log scale).
- ``casimir(solutions)``: ``S(t)`` with every rise beyond round-off marked.
- ``drift(solutions)``: windowed maxima of the energy error with the fitted growth law
  (``drift_windows`` for maxima already taken, e.g. of runs too long to keep).
- ``work_precision(curves)``: global error against cost (``geomint.studies.work_precision``).

Each returns the axis it drew on (a new figure's when ``ax`` is None).
``draw(result, directory)`` writes a scene's figures (``geomint.scene.FIGURES``)
as ``<name>.<figure>.png``.
``continuation_figure`` plots the eigenvalue real parts of a
``geomint.continuation.continuation`` against eps.
"""

from pathlib import Path

import numpy as np

from .. import analysis as _analysis
from .. import diagnostics as _diagnostics
from ..analysis import level_set as _level_set
from .._files import atomic

_EQUILIBRIUM_STYLE = {
    "stable": dict(marker="o", s=46, facecolor="black", edgecolor="black"),
    "unstable": dict(marker="o", s=46, facecolor="white", edgecolor="crimson", linewidths=1.6),
    "neutral": dict(marker="D", s=36, facecolor="grey", edgecolor="black"),
}
_CURVE_COLOR = {"stable": "black", "unstable": "crimson", "neutral": "grey"}
_MAX_SURFACES = 3
_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "<", ">", "*")
_LINESTYLES = ("-", "--", ":", "-.")
_TINY = _diagnostics.EPS / 8  # where exact zeros of an error sit on a log axis
_ULP_LABEL = "1 ulp (machine epsilon)"  # ε is the dissipation parameter; multiples of machine epsilon are ulp
_CURVE_POINTS = 6  # this many equilibria of one kind, evenly spaced, are drawn as a curve
_FAR = 1e3  # H < H0 this many mesh radii out: the level set is unbounded


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def style(i, n=1):
    """Line style of the ``i``-th of ``n`` lines: colour, line style and marker, distinct up to 40.

    Lines 1-10 get the 10 colours of ``tab10``, solid; lines 11-20 the same
    colours dashed, and so on; the marker shifts by one every 10 lines, so
    colour and marker alone still tell 20 lines apart when a caller sets the
    line style itself.
    """
    plt = _pyplot()
    colors = plt.get_cmap("tab10").colors
    return dict(color=colors[i % 10], linestyle=_LINESTYLES[(i // 10) % len(_LINESTYLES)],
                marker=_MARKERS[(i + i // 10) % len(_MARKERS)] if n > 1 else None)


def _as_list(solutions):
    return list(solutions) if isinstance(solutions, (list, tuple)) else [solutions]


def _labels(solutions, labels):
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
    return [name if sol.success else f"{name} failed, t = {sol.t_final:.3g}"
            for sol, name in zip(solutions, names)]


def _new_axis(ax, projection=None):
    if ax is not None:
        return ax
    fig = _pyplot().figure(figsize=(7.5, 5.0) if projection is None else (7.5, 7.0))
    return fig.add_subplot(projection=projection)


def _failed(solutions):
    return [sol for sol in solutions if not sol.success]


# -- the level surface --------------------------------------------------------------------
def level_surface(system, solutions, ax=None, *, labels=None, center=None, view=(30.0, -60.0), sections=(),
                  legend=True):
    """Trajectories on the level surfaces ``H = H0`` (the distinct initial energies, at most 3) in 3-D.

    Parameters
    ----------
    system : MetriplecticSystem
        The simulated system (its field decides the equilibria).
    solutions : Solution or list of Solution
    ax : 3-D axis, optional
    labels : list of str, optional
        One per solution; default: the methods, or the initial states.
    center : (3,) array, optional
        Centre of the rays that mesh the surface (default: the minimiser of H).
    view : (elevation, azimuth) in degrees
    sections : sequence of (a, b, c, d)
        Planes ``a x + b y + c z = d`` whose intersections with the surface are drawn.
    legend : bool
        Draw the key on ``ax`` (a caller may place one itself).
    """
    solutions = _as_list(solutions)
    ax = _new_axis(ax, "3d")
    ax.view_init(*view)
    center = _level_set.energy_minimiser(system) if center is None else np.asarray(center, dtype=np.float64)
    paths = np.vstack([sol.x for sol in solutions])
    box = _fitted_box(paths)
    eye = _eye(view)
    behind = 0
    levels = _distinct_energies(solutions)
    cube = _around(box)
    for H0 in levels[:_MAX_SURFACES]:
        surface = _surface(system, H0, center, box)
        if surface is None or _unbounded(system, H0, center, _finite(surface)):
            # not a ray mesh (not star-shaped, or unbounded: a cylinder): the surface in a cube around the trajectories
            box = np.minimum(box[0], cube[0]), np.maximum(box[1], cube[1])
            _draw_isosurface(ax, system, H0, box)
            if surface is None:
                continue
        else:
            box = _fitted_box(np.vstack([_finite(surface), box[0], box[1]]), margin=0.03)
            ax.plot_surface(*_clip(surface, box), color="steelblue", alpha=0.12, linewidth=0.2,
                            edgecolor="lightsteelblue", shade=False, rstride=2, cstride=2)
        for plane in sections:
            for curve in _level_set.section(system, H0, center, plane):
                ax.plot(*_clip_points(curve, box).T, color="darkorange", linewidth=1.4, linestyle="--",
                        label="plane section" if plane == sections[0] else None)
        behind += _draw_equilibria(ax, system, H0, center, eye, box)
    if behind:
        ax.plot([], [], " ", label=f"({behind} {'equilibrium' if behind == 1 else 'equilibria'} hidden behind the surface)")
    names = _labels(solutions, labels)
    for i, (sol, name) in enumerate(zip(solutions, names)):
        line = style(i)
        ax.plot(sol.x[:, 0], sol.x[:, 1], sol.x[:, 2], color=line["color"], linestyle=line["linestyle"],
                linewidth=1.1, label=name)
        ax.scatter(*sol.x[0], color=line["color"], marker="^", s=22, depthshade=False)
    failed = _failed(solutions)
    if failed:
        ends = np.array([sol.x_final for sol in failed])
        ax.scatter(*ends.T, color="red", marker="X", s=70, depthshade=False, zorder=6,
                   label=f"failed: last state reached ({len(failed)})")
    ax.scatter([], [], color="grey", marker="^", s=22, label="initial states")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1.0, 1.0, 1.0))
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(_pyplot().MaxNLocator(5))
    _set_limits(ax, box)
    if legend:
        ax.legend(loc="upper left", fontsize=7, ncol=1 if len(solutions) <= 8 else 2)
    count = f"; {len(failed)} of {len(solutions)} failed" if failed else ""
    ax.set_title(f"trajectories on {_levels_text(levels)}{count}", fontsize=10, color="red" if failed else "black")
    return ax


def _distinct_energies(solutions):
    """The distinct initial energies, in the order of the solutions (all of them; surfaces are drawn for the
    first ``_MAX_SURFACES``)."""
    energies = []
    for sol in solutions:
        H0 = float(sol.H[0])
        if all(abs(H0 - E) > 1e-9 * max(abs(E), 1.0) for E in energies):
            energies.append(H0)
    return energies


def _levels_text(levels):
    """``H = 0.1, 0.2`` for up to 4 levels, else ``7 levels of H from 0.1 to 0.9``; says when only the first
    ``_MAX_SURFACES`` surfaces are drawn."""
    if len(levels) <= 4:
        text = "H = " + ", ".join(f"{H0:.4g}" for H0 in levels)
    else:
        text = f"{len(levels)} levels of H from {min(levels):.4g} to {max(levels):.4g}"
    return text + (f" (surfaces of the first {_MAX_SURFACES})" if len(levels) > _MAX_SURFACES else "")


def _surface(system, H0, center, box):
    """The mesh of ``H = H0`` as an ``(m, n, 3)`` array, or None when it cannot be meshed from ``center``."""
    try:
        X, Y, Z = _level_set.mesh(system, H0, center)
    except ValueError:  # not star-shaped about the centre, or unbounded along a ray: trajectories only
        return None
    return np.stack([X, Y, Z], axis=-1)


def _fitted_box(points, margin=0.08):
    """``(low, high)``: the bounding box of ``points`` grown by ``margin`` of its largest side."""
    low, high = points.min(axis=0), points.max(axis=0)
    pad = margin * max(float(np.max(high - low)), 1e-12 * max(1.0, float(np.max(np.abs(points)))))
    return low - pad, high + pad


def _finite(surface):
    flat = surface.reshape(-1, 3)
    return flat[np.all(np.isfinite(flat), axis=1)]


def _around(box):
    """A cube around ``box``, grown a little: where an unbounded level set is drawn."""
    middle = 0.5 * (box[0] + box[1])
    half = 0.6 * max(float(np.max(box[1] - box[0])), 1e-12)
    return middle - half, middle + half


def _draw_isosurface(ax, system, H0, box):
    """``H = H0`` inside ``box`` as triangles (``geomint.level_set.isosurface``), drawn like the ray meshes."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    with np.errstate(all="ignore"):  # the box may reach where H overflows: those cells draw nothing
        triangles = _level_set.isosurface(system, H0, box[0], box[1])
    triangles = triangles[np.all(np.isfinite(triangles), axis=(1, 2))]
    if len(triangles):
        ax.add_collection3d(Poly3DCollection(triangles, facecolor="steelblue", alpha=0.12, edgecolor="none"))


def _unbounded(system, H0, center, mesh_points):
    """Whether ``H < H0`` somewhere far out (``_FAR`` times the mesh's median radius): then the level
    set is unbounded, and the ray mesh reaches out only as far as its rays happen to meet it."""
    radius = float(np.median(np.linalg.norm(mesh_points - center, axis=1)))
    directions = np.vstack([np.eye(3), -np.eye(3), _level_set.fibonacci_directions(400)])
    return bool(np.any(system.H(center + _FAR * radius * directions) < H0))


def _inside(points, box):
    return np.all((points >= box[0]) & (points <= box[1]), axis=-1)


def _clip(surface, box):
    """``X, Y, Z`` of the surface with the points outside ``box`` set to NaN (not drawn)."""
    clipped = np.where(_inside(surface, box)[..., None], surface, np.nan)
    return clipped[..., 0], clipped[..., 1], clipped[..., 2]


def _clip_points(points, box):
    return np.where(_inside(points, box)[:, None], points, np.nan)


def _eye(view):
    """Unit vector from the scene towards the viewer for matplotlib's ``(elevation, azimuth)``."""
    elevation, azimuth = np.radians(view)
    return np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])


def _draw_equilibria(ax, system, H0, center, eye, box):
    """Equilibria on the visible side of the surface (points, or the visible part of a curve).

    Returns how many isolated equilibria lie behind the surface (left out).
    """
    found = [(x, kind) for x, kind in _analysis.equilibrium_points(system, H0, center) if _inside(x, box)]
    behind = 0
    for kind in ("stable", "unstable", "neutral"):
        points = np.array([x for x, k in found if k == kind]).reshape(-1, 3)
        if points.size == 0:
            continue
        drawn = set(ax.get_legend_handles_labels()[1])
        ordered = _chain(points) if len(points) >= _CURVE_POINTS else None
        if ordered is not None:
            label = f"curve of {kind} equilibria"
            visible = np.where((((ordered - center) @ eye) >= 0.0)[:, None], ordered, np.nan)
            ax.plot(*visible.T, color=_CURVE_COLOR[kind], linewidth=2.6, zorder=5,
                    label=None if label in drawn else label)
            continue
        front = (points - center) @ eye >= 0.0
        behind += int(np.count_nonzero(~front))
        label = f"{kind} equilibrium"
        if np.any(front):
            ax.scatter(*points[front].T, depthshade=False, zorder=5, label=None if label in drawn else label,
                       **_EQUILIBRIUM_STYLE[kind])
    return behind


def _chain(points):
    """The points in nearest-neighbour order as a polyline (closed when the ends are close, NaN across gaps),
    or None when they are isolated points rather than samples of a curve (median step > 15% of their spread)."""
    left = list(range(1, len(points)))
    order = [0]
    while left:
        last = points[order[-1]]
        nearest = min(left, key=lambda j: np.linalg.norm(points[j] - last))
        order.append(nearest)
        left.remove(nearest)
    path = points[order]
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    step = float(np.median(steps))
    if step > 0.15 * float(np.max(np.ptp(points, axis=0))):
        return None
    if np.linalg.norm(path[-1] - path[0]) <= 2.0 * step:
        path = np.vstack([path, path[:1]])
        steps = np.append(steps, np.linalg.norm(path[-1] - path[-2]))
    pieces = np.split(path, np.flatnonzero(steps > 4.0 * step) + 1)
    return np.vstack([np.vstack([piece, np.full((1, 3), np.nan)]) for piece in pieces])[:-1]


def _set_limits(ax, box):
    """Equal scales on the three axes: a cube around ``box``."""
    mid, half = 0.5 * (box[0] + box[1]), 0.5 * float(np.max(box[1] - box[0]))
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)


# -- invariants over time -----------------------------------------------------------------
def energy_error(solutions, ax=None, *, labels=None, legend=True):
    """The running maximum of ``|H - H0| / |H0|`` against t, log scale; 1 ulp (machine epsilon) marked.

    Exact zeros are drawn at 1/8 ulp, the bottom of the axis.  (Figures write the dissipation
    parameter as ε and multiples of machine epsilon as ulp.)
    """
    solutions = _as_list(solutions)
    ax = _new_axis(ax)
    for i, (sol, name) in enumerate(zip(solutions, _labels(solutions, labels))):
        running = np.maximum.accumulate(_diagnostics.energy_error(sol))
        line = style(i, len(solutions))
        ax.semilogy(sol.t, np.maximum(running, _TINY), color=line["color"], linestyle=line["linestyle"],
                    linewidth=1.2, label=name, drawstyle="steps-post")
    ulp = _diagnostics.EPS
    ax.axhline(ulp, color="0.4", linewidth=0.9, linestyle=":", label=_ULP_LABEL)
    worst = max(float(_diagnostics.energy_error(sol).max()) for sol in solutions)
    top = max(worst * 4, ulp * 4)
    ax.set_ylim(_TINY / 1.5, top)
    return _finish(ax, "t", "running max |H - H0| / |H0|",
                   f"energy: max |H - H0|/|H0| = {worst:.2g} ({worst / ulp:.3g} ulp)", legend and "lower right",
                   len(solutions))


def casimir(solutions, ax=None, *, labels=None, legend=True):
    """``S(t)``, one line per solution; every saved step where S rose beyond round-off is marked."""
    solutions = _as_list(solutions)
    ax = _new_axis(ax)
    rises = 0
    for i, (sol, name) in enumerate(zip(solutions, _labels(solutions, labels))):
        line = style(i, len(solutions))
        ax.plot(sol.t, sol.S, color=line["color"], linestyle=line["linestyle"], linewidth=1.2, label=name)
        up = _diagnostics.S_rises(sol) + 1
        rises += len(up)
        ax.scatter(sol.t[up], sol.S[up], color="red", marker="x", s=18, zorder=4)
    if rises:
        ax.scatter([], [], color="red", marker="x", s=18, label="S rose (beyond 16 ulps)")
    return _finish(ax, "t", "S", f"Casimir S: {rises} {'rise' if rises == 1 else 'rises'} beyond round-off", legend and "upper right",
                   len(solutions), "red" if rises else "black")


def drift(solutions, ax=None, *, labels=None, count=20, t_min=None, legend=True):
    """Windowed maxima of ``|H - H0| / |H0|`` on log-log axes, each key with its fitted growth law.

    ``count`` log-spaced windows (``geomint.diagnostics.windowed_drift``); the
    law ``max ~ C t^p`` is fitted for ``t >= t_min`` (default: a tenth of the run).
    """
    solutions = _as_list(solutions)
    series, short = [], []
    for sol, name in zip(solutions, _labels(solutions, labels)):
        if len(sol.t) < 3:  # a run that failed at once has no drift to show
            short.append(name)
            continue
        centers, maxima = _diagnostics.windowed_drift(sol, count)
        series.append((name, centers, maxima, 0.1 * (sol.t[-1] - sol.t[0]) if t_min is None else t_min))
    ax = _new_axis(ax)
    for name in short:
        ax.plot([], [], " ", label=f"{name}: fewer than 3 saved states, not drawn")
    return drift_windows(series, ax, legend=legend)


def drift_windows(series, ax=None, *, legend=True, law_in_key=True, linestyles=None):
    """``drift`` for maxima already taken: ``series`` holds ``(label, centers, maxima, t_min)`` per line.

    For long runs summarised chunk by chunk in a ``geomint.diagnostics.Windows``.
    ``law_in_key=False`` keys lines by label alone (a key shared by panels of
    different problems); ``linestyles`` (one per line) overrides the styles'
    line styles, e.g. to tell two kinds of method apart.
    """
    ax = _new_axis(ax)
    for i, (name, centers, maxima, t_min) in enumerate(series):
        p, law = _diagnostics.growth_law(centers, maxima, t_min)
        keep = np.isfinite(maxima)
        line = style(i, len(series))
        if linestyles is not None:
            line["linestyle"] = linestyles[i]
        fit = f": {_law_text(p, law)}" if law_in_key else ""
        ax.loglog(centers[keep], np.maximum(maxima[keep], _TINY), markersize=4, linewidth=1.2, label=name + fit,
                  **line)
    ax.axhline(_diagnostics.EPS, color="0.4", linewidth=0.9, linestyle=":", label=_ULP_LABEL)
    return _finish(ax, "t", "windowed max |H - H0| / |H0|",
                   "energy drift: windowed maxima and growth law (zeros drawn at 1/8 ulp)", legend and "best",
                   len(series))


def _law_text(p, law):
    """A growth law for a key: ``t (p = 1.02)``; none is claimed at round-off."""
    if law == "round-off":
        return f"at round-off (within {_diagnostics.ROUNDOFF_ULPS} ulp), no growth law"
    return law + (f" (p = {p:.2f})" if np.isfinite(p) else "")


def work_precision(curves, ax=None, *, cost="wall", legend=True, error="global error |x(T) - x_ref(T)|"):
    """Error against cost for ``geomint.studies.Curve`` objects, one line and key each.

    ``cost`` is ``"wall"`` (median seconds) or ``"nfev"`` (field evaluations);
    ``error`` labels the vertical axis (what the curves' errors measure).
    Structure-preserving methods (exact H, S never rising) are drawn solid.
    """
    if cost not in ("wall", "nfev"):
        raise ValueError(f"`cost` must be \"wall\" or \"nfev\"; got {cost!r}.")
    curves = _as_list(curves)
    ax = _new_axis(ax)
    for i, curve in enumerate(curves):
        line = style(i, len(curves))
        line["linestyle"] = "-" if curve.structure_preserving else "--"
        ax.loglog(getattr(curve, cost), curve.error, markersize=4, linewidth=1.2, label=curve.label, **line)
    return _finish(ax, "wall time [s] (median)" if cost == "wall" else "field evaluations",
                   error, "work-precision (solid: exact H and monotone S)",
                   legend and "lower left", len(curves))


def _finish(ax, xlabel, ylabel, title, legend_at, lines, title_color="black"):
    """Labels, title, grid, and the key at ``legend_at`` (none when falsy; two columns past 10 lines)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10, color=title_color)
    ax.grid(True, which="major", linewidth=0.4, alpha=0.6)
    if legend_at:
        ax.legend(loc=legend_at, fontsize=7, ncol=1 if lines <= 10 else 2)
    return ax


# -- scene figures ------------------------------------------------------------------------
def draw(result, directory):
    """Write the scene's figures under ``directory``; returns their paths."""
    plt = _pyplot()
    directory = Path(directory)
    paths = []
    for figure in result.scene.figures:
        fig = _FIGURES[figure](plt, result)
        path = directory / f"{result.scene.name}.{figure}.png"
        try:
            with atomic(path) as temporary:
                fig.savefig(temporary, dpi=130, format="png", bbox_inches="tight", pad_inches=0.15)
        finally:
            plt.close(fig)
        paths.append(path)
    return paths


def trajectories(result, ax, legend=True):
    """A scene's trajectories on its level surfaces (``level_surface`` with the scene's centre, view, sections)."""
    return level_surface(result.system, result.solutions, ax, labels=_scene_labels(result), center=_center(result),
                         view=result.scene.view, sections=result.scene.sections, legend=legend)


def invariants(result, ax_H, ax_S, legend=True):
    """A scene's energy error and S against t (``energy_error`` and ``casimir``)."""
    labels = _scene_labels(result)
    energy_error(result.solutions, ax_H, labels=labels, legend=legend)
    casimir(result.solutions, ax_S, labels=labels, legend=legend)
    ax_H.set_xlabel("")


def _overview(plt, result):
    fig = plt.figure(figsize=(12.0, 6.6))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.05, 1.0), hspace=0.42, wspace=0.25, left=0.0, right=1.0,
                            top=0.86, bottom=0.09)
    ax3d = fig.add_subplot(grid[:, 0], projection="3d")
    trajectories(result, ax3d, legend=False)
    ax_H, ax_S = fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, 1])
    invariants(result, ax_H, ax_S, legend=False)
    _shared_key(fig, [ax3d, ax_H, ax_S], [ax_H, ax_S])
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _shared_key(fig, axes, beside):
    """One key for the panels ``axes``: every labelled line and marker, once, just right of the panels
    ``beside`` (the figure is saved with a tight bounding box, so the key sets its right edge: no empty
    column is left between the panels and the key, nor after it)."""
    handles, labels = {}, []
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            if label not in handles:
                handles[label] = handle
                labels.append(label)
    boxes = [ax.get_position() for ax in beside]
    right = max(box.x1 for box in boxes)
    middle = 0.5 * (min(box.y0 for box in boxes) + max(box.y1 for box in boxes))
    fig.legend([handles[label] for label in labels], labels, loc="center left", bbox_to_anchor=(right + 0.01, middle),
               fontsize=7, frameon=False, ncol=1 if len(labels) <= 24 else 2)


def _trajectories_figure(plt, result):
    fig = plt.figure(figsize=(8.0, 7.0))
    ax = fig.add_axes((0.0, 0.04, 1.0, 0.84), projection="3d")
    trajectories(result, ax, legend=False)
    _shared_key(fig, [ax], [ax])
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _invariants_figure(plt, result):
    fig = plt.figure(figsize=(8.0, 6.4))
    grid = fig.add_gridspec(2, 1, hspace=0.3, left=0.1, right=0.98, top=0.84)
    ax_H, ax_S = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0])
    invariants(result, ax_H, ax_S, legend=False)
    _shared_key(fig, [ax_H, ax_S], [ax_H, ax_S])
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _drift_figure(plt, result):
    fig = plt.figure(figsize=(8.0, 5.0))
    grid = fig.add_gridspec(1, 1, left=0.12, right=0.98, top=0.8)
    ax = fig.add_subplot(grid[0, 0])
    drift(result.solutions, ax, labels=_scene_labels(result), legend=False)
    _shared_key(fig, [ax], [ax])
    fig.suptitle(_title(result), fontsize=11)
    return fig


def _scene_labels(result):
    return ["x0 = (" + ", ".join(f"{v:.3g}" for v in sol.x[0]) + ")" for sol in result.solutions]


def _title(result):
    scene = result.scene
    effects = [name for name, on in (("Hamiltonian", scene.hamiltonian), (f"dissipation ε = {scene.eps:g}",
                                                                           scene.eps > 0)) if on]
    return (f"{scene.title or scene.name}\n{result.system.name}, {' + '.join(effects) or 'no effect'}, "
            f"{result.method.name}, h = {scene.h:g}")


def _center(result):
    level_set = result.scene.level_set
    if level_set is not None and level_set.get("center") is not None:
        return np.array(level_set["center"], dtype=np.float64)
    return _level_set.energy_minimiser(result.system)


_FIGURES = {"overview": _overview, "trajectories": _trajectories_figure, "invariants": _invariants_figure,
            "drift": _drift_figure}


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
    >>> from geomint.analysis.continuation import continuation
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
    for ax in axes.ravel()[len(results):]:
        ax.set_visible(False)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=130)
    return fig
