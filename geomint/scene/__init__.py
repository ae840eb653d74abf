"""Scenes: declarative runs that compute only what they call for.

A scene names a catalogue system (or writes one as formulas) and its
parameters, the effects to simulate, the initial states, the integrator and
what to record and draw.  As a TOML file (read with the standard library's
``tomllib``; nothing in it is evaluated as Python)::

    title = "Relaxing rigid body, a, b, c distinct"

    [system]
    name = "relaxing_rigid_body"
    parameters = { a = 0.5, b = 1.0, c = 1.5 }

    [effects]
    hamiltonian = true      # xi_P = grad H x J on/off
    eps = 1.0               # dissipation eps xi_g; 0 = off
    projection = false      # project every step back onto H = H0

    [initial]
    level_set = { H0 = 0.6471, n = 12 }    # or: points = [[0.45, 0.0, 0.89], ...]

    [integrator]
    method = "gonzalez"     # or { name = "gonzalez", max_newton_iter = 50 }
    h = 0.02
    duration = 30.0

    [output]
    record = ["x", "H", "S"]   # observables written to the .npz
    every = 5                  # save every 5th state; "final": initial and final only
    figures = ["overview"]

A system written as formulas (``geomint.model.expressions``: a whitelist grammar of
numbers, x, y, z, parameter names, + - * / ** and exp, log, sin, cosh, ...;
formulas are parsed, never evaluated) replaces ``name`` by ``H``, ``S`` and
``J`` (3 formulas) or ``P`` (3x3 formulas); ``name`` is then a label::

    [system]
    name = "lorenz_nevir"
    H = "(y**2 + z**2)/2 - r*z"
    S = "x**2/2 - sigma*z"
    J = ["-x", "0", "sigma"]
    parameters = { sigma = 10.0, r = 28.0 }

Every integrator can be named, with its options as further keys of
``[integrator]`` (or in a table ``method = { name = ..., ... }``);
sub-integrators are names or tables themselves (the method's plain-data form,
``geomint.integrators.data``)::

    method = "yoshida4"                      # a composition ...
    base = "symmetrized_itoh_abe"            # ... of the symmetrized Itoh-Abe step
    # method = "strang", hamiltonian_part = "rigid_body_flow", gradient_part = "gonzalez"
    # method = { name = "projected", method = "rk4", symmetric = false }

What is off is not computed: ``hamiltonian = false`` runs kernels that never
call ``J``; ``eps = 0`` runs kernels that never call ``grad S``
(``MetriplecticSystem.with_effects``); observables not in ``record`` are
neither computed nor stored, and ``every = "final"`` runs in constant memory.

The package, module by module:

* ``checks``  ``SceneError`` and the checks of every field, naming the key and the nearest known name;
* ``toml``    scene files read and written, bundled scenes found by name;
* ``schema``  ``Scene``: the fields, their file layout, resolution (once); ``load_scene``;
* ``run``     ``run_scene`` and ``SceneResult``; the checkpoint folder.
"""

from .checks import MAX_TRAJECTORIES, SceneError
from .run import ENSEMBLE_STEPS, CheckpointError, SceneResult, run_scene, runs_together, solve_together, versions
from .schema import FIGURES, OBSERVABLES, Built, Scene, load_scene
from .toml import bundled_scenes, read_toml, to_toml

#: ``load_scene`` by its earlier name (``geomint.load`` reads a saved Solution)
load = load_scene

__all__ = [
    "ENSEMBLE_STEPS",
    "FIGURES",
    "MAX_TRAJECTORIES",
    "OBSERVABLES",
    "Built",
    "CheckpointError",
    "Scene",
    "SceneError",
    "SceneResult",
    "bundled_scenes",
    "load",
    "load_scene",
    "read_toml",
    "run_scene",
    "runs_together",
    "solve_together",
    "to_toml",
    "versions",
]
