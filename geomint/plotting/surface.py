"""[R3] Trajectories on the level surface ``H = H0`` in 3-D, with the equilibria of the field on it.

The surface is meshed by rays from a centre (``analysis.level_set.mesh``),
or, where it is not star-shaped or not bounded, by marching tetrahedra in a
box around the trajectories (``analysis.level_set.isosurface``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np

from .. import analysis as _analysis
from ..analysis import level_set as _level_set
from ._common import as_list, line_labels, new_axis, pyplot, style

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy.typing as npt
    from matplotlib.axes import Axes
    from mpl_toolkits.mplot3d.axes3d import Axes3D

    from ..model.system import MetriplecticSystem
    from ..results.solution import Solution

_EQUILIBRIUM_STYLE = {
    "stable": dict(marker="o", s=46, facecolor="black", edgecolor="black"),
    "unstable": dict(marker="o", s=46, facecolor="white", edgecolor="crimson", linewidths=1.6),
    "neutral": dict(marker="D", s=36, facecolor="grey", edgecolor="black"),
}
_CURVE_COLOR = {"stable": "black", "unstable": "crimson", "neutral": "grey"}
_MAX_SURFACES = 3
_CURVE_POINTS = 6  # this many equilibria of one kind, evenly spaced, are drawn as a curve
_FAR = 1e3  # H < H0 this many mesh radii out: the level set is unbounded


def _failed(solutions):
    return [sol for sol in solutions if not sol.success]


def level_surface(
    system: MetriplecticSystem,
    solutions: Solution | Sequence[Solution],
    ax: Axes | None = None,
    *,
    labels: Sequence[str] | None = None,
    center: npt.ArrayLike | None = None,
    view: tuple[float, float] = (30.0, -60.0),
    sections: Sequence[Sequence[float]] = (),
    legend: bool = True,
) -> Axes:
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
    solutions = as_list(solutions)
    ax = cast("Axes3D", new_axis(ax, "3d"))
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
            ax.plot_surface(
                *_clip(surface, box),
                color="steelblue",
                alpha=0.12,
                linewidth=0.2,
                edgecolor="lightsteelblue",
                shade=False,
                rstride=2,
                cstride=2,
            )
        for plane in sections:
            for curve in _level_set.section(system, H0, center, plane):
                ax.plot(
                    *_clip_points(curve, box).T,
                    color="darkorange",
                    linewidth=1.4,
                    linestyle="--",
                    label="plane section" if plane == sections[0] else None,
                )
        behind += _draw_equilibria(ax, system, H0, center, eye, box)
    if behind:
        ax.plot(
            [], [], " ", label=f"({behind} {'equilibrium' if behind == 1 else 'equilibria'} hidden behind the surface)"
        )
    names = line_labels(solutions, labels)
    for i, (sol, name) in enumerate(zip(solutions, names)):
        line = style(i)
        ax.plot(
            sol.x[:, 0],
            sol.x[:, 1],
            sol.x[:, 2],
            color=line["color"],
            linestyle=line["linestyle"],
            linewidth=1.1,
            label=name,
        )
        ax.scatter(*sol.x[0], color=line["color"], marker="^", s=22, depthshade=False)
    failed = _failed(solutions)
    if failed:
        ends = np.array([sol.x_final for sol in failed])
        ax.scatter(
            *ends.T,
            color="red",
            marker="X",
            s=70,
            depthshade=False,
            zorder=6,
            label=f"failed: last state reached ({len(failed)})",
        )
    ax.scatter([], [], color="grey", marker="^", s=22, label="initial states")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1.0, 1.0, 1.0))
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(pyplot().MaxNLocator(5))
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
            ax.plot(
                *visible.T, color=_CURVE_COLOR[kind], linewidth=2.6, zorder=5, label=None if label in drawn else label
            )
            continue
        front = (points - center) @ eye >= 0.0
        behind += int(np.count_nonzero(~front))
        label = f"{kind} equilibrium"
        if np.any(front):
            ax.scatter(
                *points[front].T,
                depthshade=False,
                zorder=5,
                label=None if label in drawn else label,
                **_EQUILIBRIUM_STYLE[kind],
            )
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
