"""A scene's figure sheets: ``draw`` writes each of ``geomint.scene.FIGURES`` as ``<name>.<figure>.png``.

``overview`` and ``trajectories`` draw level surfaces in R^3; ``invariants`` and ``drift`` any dimension, as do
the sheets of named coordinates and relaxation (``series``, ``phase``, ``relaxation``, ``energy_ulps``) and
2-D Euler's ``vorticity``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic
from ..analysis import level_set as _level_set
from ..scene import relaxation as _relaxation
from ..scene import states as _states
from ._common import pyplot
from .coordinates import phase_projection, series_grid
from .relaxation import energy_ulps, entropy, entropy_gap
from .series import casimir, drift, plot_energy_error
from .surface import level_surface
from .vorticity import vorticity_field

if TYPE_CHECKING:
    import os

    from matplotlib.axes import Axes

    from ..scene.run import SceneResult


def draw(result: SceneResult, directory: str | os.PathLike[str]) -> list[Path]:
    """Write the scene's figures under ``directory``; returns their paths."""
    plt = pyplot()
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


def trajectories(result: SceneResult, ax: Axes | None, legend: bool = True) -> Axes:
    """A scene's trajectories on its level surfaces (``level_surface`` with the scene's centre, view, sections)."""
    return level_surface(
        result.system,
        result.solutions,
        ax,
        labels=_scene_labels(result),
        center=_center(result),
        view=result.scene.view,
        sections=result.scene.sections,
        legend=legend,
    )


def invariants(result: SceneResult, ax_H: Axes, ax_S: Axes, legend: bool = True) -> None:
    """A scene's energy error and S against t (``plot_energy_error`` and ``casimir``)."""
    labels = _scene_labels(result)
    plot_energy_error(result.solutions, ax_H, labels=labels, legend=legend)
    casimir(result.solutions, ax_S, labels=labels, legend=legend)
    ax_H.set_xlabel("")


def _overview(plt, result):
    fig = plt.figure(figsize=(12.0, 6.6))
    grid = fig.add_gridspec(
        2, 2, width_ratios=(1.05, 1.0), hspace=0.42, wspace=0.25, left=0.0, right=1.0, top=0.86, bottom=0.09
    )
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
    fig.legend(
        [handles[label] for label in labels],
        labels,
        loc="center left",
        bbox_to_anchor=(right + 0.01, middle),
        fontsize=7,
        frameon=False,
        ncol=1 if len(labels) <= 24 else 2,
    )


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
    if result.scene.in_rn:
        return _labels_n(result)
    return ["x0 = (" + ", ".join(f"{v:.3g}" for v in sol.x[0]) + ")" for sol in result.solutions]


def _labels_n(result):
    """A key per trajectory in R^n: its start by name where n <= 4, else its number and its E0 and S0."""
    variables = result.system.variables
    energy = _energy_name(result)
    if len(variables) <= 4:
        return [
            "(" + ", ".join(variables) + ") = (" + ", ".join(f"{v:.3g}" for v in sol.x[0]) + ")"
            for sol in result.solutions
        ]
    return [f"#{i}: {energy}0 = {sol.H[0]:.4g}, S0 = {sol.S[0]:.4g}" for i, sol in enumerate(result.solutions)]


def _energy_name(result):
    return "E" if getattr(result.system, "direction", -1.0) > 0 else "H"


def _title_n(result, what):
    scene = result.scene
    system = result.system
    form = "GENERIC" if system.direction > 0 else "Fish form"
    if system.direction > 0:
        effects = [
            name
            for name, on in (
                ("L∇E", scene.hamiltonian),
                ("M∇S" + ("" if scene.eps == 1.0 else f" (×{scene.eps:g})"), scene.eps > 0),
            )
            if on
        ]
    else:
        effects = [
            name for name, on in (("P∇H", scene.hamiltonian), (f"dissipation ε = {scene.eps:g}", scene.eps > 0)) if on
        ]
    return (
        f"{scene.title or scene.name}: {what}\n{system.name} ({form}, n = {system.dim}), {' + '.join(effects)}, "
        f"{result.method.name}, h = {scene.h:g}"
    )


def _series_figure(plt, result):
    variables = result.system.variables
    names = result.scene.series or _states.default_series(variables)
    title = _title_n(result, "coordinates against t") if result.scene.in_rn else _title(result)
    return series_grid(result.solutions, variables, names, labels=_scene_labels(result), title=title)


def _phase_figure(plt, result):
    variables = result.system.variables
    names = _states.expand(result.scene.phase or _states.default_phase(variables), variables)
    three = len(names) == 3
    fig = plt.figure(figsize=(7.5, 6.6) if three else (7.2, 5.6))
    ax = fig.add_subplot(projection="3d" if three else None)
    phase_projection(
        result.solutions, variables, names, ax, labels=_scene_labels(result), legend=False, view=result.scene.view
    )
    ax.legend(loc="center left", bbox_to_anchor=(1.02 if not three else 1.08, 0.5), fontsize=7, frameon=False)
    fig.suptitle(_title_n(result, "projected trajectories") if result.scene.in_rn else _title(result), fontsize=10)
    return fig


def _scales(result):
    """The size of the energy's terms at each start: ``max(|H0|, |grad H(x0)| |x0|)`` (the ulps of
    ``energy_ulps``)."""
    out = []
    for sol in result.solutions:
        x0 = sol.x[0]
        grad = np.asarray(result.system.grad_H(x0), dtype=np.float64)
        out.append(max(abs(float(sol.H[0])), float(np.linalg.norm(grad) * np.linalg.norm(x0))))
    return out


def _energy_figure(plt, result):
    fig = plt.figure(figsize=(8.5, 4.4))
    ax = fig.add_subplot()
    energy_ulps(
        result.solutions, _scales(result), ax, labels=_scene_labels(result), legend=False, energy=_energy_name(result)
    )
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=7, frameon=False)
    fig.suptitle(
        _title_n(result, "energy error in ulps") if result.scene.in_rn else _title(result), fontsize=10, y=1.02
    )
    return fig


def _reference_rate(result):
    """The rate the catalogue expects near the limit (``geomint.scene.catalogue_n.expected_rate``: 2-D Euler's
    linearised ``8 eps H0``, the heat bath's ``gamma / m``, the pendula's ``gamma``) to compare the fit with;
    None for other systems."""
    return result.scene.expected_rate(float(result.solutions[0].H[0]))


def _relaxation_figure(plt, result):
    limits = result.limits()
    values = [limit.value for limit in limits]
    labels = _scene_labels(result)
    energy = _energy_name(result)
    direction = float(result.system.direction)
    fig, (ax_E, ax_S, ax_gap) = plt.subplots(
        3, 1, figsize=(8.5, 9.0), sharex=True, gridspec_kw={"height_ratios": (1.0, 1.3, 1.7)}
    )
    energy_ulps(result.solutions, _scales(result), ax_E, labels=labels, legend=False, energy=energy)
    ax_E.set_title(ax_E.get_title(), fontsize=9)
    entropy(
        result.solutions,
        values,
        ax_S,
        labels=labels,
        legend=False,
        what="S (entropy, never falls)" if direction > 0 else "S (never rises)",
    )
    ax_S.set_title(
        f"S and its limit: {_shown(limits[0].why)}" if len({lim.why for lim in limits}) == 1 else "S and its limits S∞",
        fontsize=9,
    )
    entropy_gap(
        result.solutions, values, direction, ax_gap, labels=labels, legend=False, reference=_reference_rate(result)
    )
    ax_gap.set_title("the approach to S∞, log scale (dashed: the fitted exponential)", fontsize=9)
    for ax in (ax_E, ax_S):
        ax.set_xlabel("")
    ax_gap.legend(loc="upper right", fontsize=7, ncol=1 if len(result.solutions) <= 6 else 2, framealpha=0.9)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.94))
    fig.suptitle(_title_n(result, "relaxation") if result.scene.in_rn else _title(result), fontsize=10)
    return fig


def _shown(text):
    """A summary's ASCII as figures write it: S_inf as S∞, ^2 as ²."""
    return text.replace("S_inf", "S∞").replace("^2", "²")


def _vorticity_figure(plt, result):
    """The vorticity of the first trajectory at the scene's snapshot times (one colour scale), its distance
    from the lowest shell in each title, and |S - S_inf| against t with the snapshot times marked."""
    sol = result.solutions[0]
    N = int(round(np.sqrt(result.system.dim + 1)))
    times = list(result.scene.snapshots or (0.0, sol.t[-1]))
    rows = [int(np.argmin(np.abs(sol.t - t))) for t in times]
    fields = len(rows)
    fig = plt.figure(figsize=(2.5 * fields + 1.2, 6.6))
    grid = fig.add_gridspec(
        2, fields + 1, width_ratios=[1.0] * fields + [0.06], height_ratios=(1.0, 1.05), hspace=0.45, wspace=0.3
    )
    vmax = max(float(np.max(np.abs(_field(sol.x[r], N)))) for r in rows)
    image = None
    for k, r in enumerate(rows):
        ax = fig.add_subplot(grid[0, k])
        distance = _relaxation.lowest_shell_distance(sol.x[r])
        image = vorticity_field(
            sol.x[r], N, ax, vmax=vmax, title=f"t = {sol.t[r]:.4g}\ndist. to |k|²=1: {distance:.1e}"
        )
        if k:
            ax.set_ylabel("")
    colorbar = fig.colorbar(image, cax=fig.add_subplot(grid[0, fields]))
    colorbar.set_label("vorticity ω(θ)")
    ax_gap = fig.add_subplot(grid[1, :fields])
    limits = result.limits()
    entropy_gap(
        [sol],
        [limits[0].value],
        float(result.system.direction),
        ax_gap,
        labels=["S - S∞, the enstrophy above the lowest shell"],
        legend=False,
        reference=_reference_rate(result),
    )
    distance = _relaxation.lowest_shell_distance(sol.x)
    ax_gap.semilogy(
        sol.t,
        np.where(distance > 0, distance, np.nan),
        color="tab:purple",
        linewidth=1.3,
        label=f"distance of the state from the lowest shell's span (final {distance[-1]:.1e})",
    )
    for r in rows:
        ax_gap.axvline(sol.t[r], color="0.6", linewidth=0.7, linestyle="-", zorder=0)
    ax_gap.plot([], [], color="0.6", linewidth=0.7, label="snapshot times")
    ax_gap.legend(loc="upper right", fontsize=7, framealpha=0.9)
    ax_gap.set_ylabel("S - S∞;  distance")
    ax_gap.set_title(
        f"enstrophy S relaxing to S∞ = H0 = {limits[0].value:.6g} ({limits[0].source}); the state to "
        "the lowest shell |k|² = 1",
        fontsize=9,
    )
    more = f" (trajectory 0 of {len(result.solutions)})" if len(result.solutions) > 1 else ""
    fig.suptitle(_title_n(result, f"vorticity at chosen times{more}"), fontsize=10)
    return fig


def _field(x, N):
    from ..systems import euler_vorticity

    return euler_vorticity(x, N, size=max(64, N))


def _title(result):
    scene = result.scene
    effects = [
        name
        for name, on in (("Hamiltonian", scene.hamiltonian), (f"dissipation ε = {scene.eps:g}", scene.eps > 0))
        if on
    ]
    return (
        f"{scene.title or scene.name}\n{result.system.name}, {' + '.join(effects) or 'no effect'}, "
        f"{result.method.name}, h = {scene.h:g}"
    )


def _center(result):
    level_set = result.scene.level_set
    if level_set is not None and level_set.get("center") is not None:
        return np.array(level_set["center"], dtype=np.float64)
    return _level_set.energy_minimiser(result.system)


_FIGURES = {
    "overview": _overview,
    "trajectories": _trajectories_figure,
    "invariants": _invariants_figure,
    "drift": _drift_figure,
    "series": _series_figure,
    "relaxation": _relaxation_figure,
    "energy_ulps": _energy_figure,
    "phase": _phase_figure,
    "vorticity": _vorticity_figure,
}
