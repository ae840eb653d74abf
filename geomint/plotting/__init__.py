"""Figures of solutions and scene results (matplotlib, imported on use with the Agg backend).

One concept per module:

* ``series``: panels for any ``Solution`` (or a list of them, one line each, with a key for
  every line; up to 20 distinct styles from ``style``):

  - ``plot_energy_error(solutions)``: the running maximum of ``|H - H0| / |H0|`` (log scale);
  - ``casimir(solutions)``: ``S(t)`` with every rise beyond round-off marked;
  - ``drift(solutions)``: windowed maxima of the energy error with the fitted growth law
    (``drift_windows`` for maxima already taken, e.g. of runs too long to keep);
  - ``plot_work_precision(curves)``: global error against cost (``geomint.studies.work_precision``).

* ``surface`` [R3]: ``level_surface(system, solutions)``, trajectories on the level surface
  ``H = H0`` in 3-D with the equilibria of the field on it (filled = stable, open = unstable,
  grey = neutral; a curve of equilibria drawn as a curve; those behind the surface are left out
  and counted in the key); failed trajectories end in a red cross and are counted in the title;
  on an unbounded level set the axes fit the trajectories and the surface is clipped to them.
* ``figures``: ``draw(result, directory)`` writes a scene's figures (``geomint.scene.FIGURES``)
  as ``<name>.<figure>.png``; ``trajectories`` and ``invariants`` are its panels.
* ``continuation``: ``continuation_figure`` plots the eigenvalue real parts of a
  ``geomint.continuation.continuation`` against eps.
* ``coordinates`` (any dimension, coordinates by name, ``system.variables``):
  ``coordinate_series`` (chosen coordinates against t; a family name such as ``q`` draws
  q1 ... qN), ``series_grid`` (a panel per coordinate for several trajectories),
  ``phase_projection`` (trajectories projected onto 2 or 3 coordinates).
* ``relaxation`` (any dimension): ``energy_ulps`` (the energy error in ulps of its terms),
  ``entropy`` (S with its limits S∞), ``entropy_gap`` (``|S - S∞|`` on a log axis with the
  fitted exponential rate; ``geomint.scene.relaxation`` estimates S∞ and fits the rate).
* ``vorticity``: ``vorticity_field``, 2-D Euler's vorticity on the torus
  (``geomint.systems.euler_vorticity``).

Each panel function returns the axis it drew on (a new figure's when ``ax`` is None).
``energy_error`` and ``work_precision`` are the earlier names of ``plot_energy_error`` and
``plot_work_precision``, kept as aliases: ``geomint.diagnostics.energy_error`` (an array) and
``geomint.studies.work_precision`` (the runs) are what these functions draw.
"""

from ._common import style
from .continuation import continuation_figure
from .coordinates import coordinate_series, phase_projection, series_grid
from .figures import draw, invariants, trajectories
from .relaxation import energy_ulps, entropy, entropy_gap
from .series import casimir, drift, drift_windows, plot_energy_error, plot_work_precision
from .surface import level_surface
from .vorticity import vorticity_field

energy_error = plot_energy_error
"""Alias of ``plot_energy_error``, the earlier name (``diagnostics.energy_error`` is the array it draws)."""

work_precision = plot_work_precision
"""Alias of ``plot_work_precision``, the earlier name (``studies.work_precision`` makes the curves it draws)."""

__all__ = [
    "casimir",
    "continuation_figure",
    "coordinate_series",
    "draw",
    "drift",
    "drift_windows",
    "energy_error",
    "energy_ulps",
    "entropy",
    "entropy_gap",
    "invariants",
    "level_surface",
    "phase_projection",
    "plot_energy_error",
    "plot_work_precision",
    "series_grid",
    "style",
    "trajectories",
    "vorticity_field",
    "work_precision",
]
