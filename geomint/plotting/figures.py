"""A scene's figure sheets: ``draw`` writes each of ``geomint.scene.FIGURES`` as ``<name>.<figure>.png``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic
from ..analysis import level_set as _level_set
from ._common import pyplot
from .series import casimir, drift, plot_energy_error
from .surface import level_surface

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
    return ["x0 = (" + ", ".join(f"{v:.3g}" for v in sol.x[0]) + ")" for sol in result.solutions]


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
}
