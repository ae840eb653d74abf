"""geomint: structure-preserving integrators for metriplectic systems in R^3 and R^n (docs/engine_rn.md).

The package, layer by layer (each imports only the layers below it; ``tests/test_architecture.py``):

* ``_kernels/``     how a step is computed: numba only;
* ``model/``        what the equation is: ``MetriplecticSystem``, ``GenericSystem``, systems written as formulas;
* ``systems/``      the catalogue, and closed-form reference solutions;
* ``integrators/``  what a method is: methods as data on the one engine, and their plain-data form;
* ``results/``      what a run gives back: ``Solution``, dense output, save and load;
* ``run/``          how a run is driven: ``solve``, outcomes (``Status``), events, ensembles;
* ``diagnostics``, ``studies``: measures on results, and runs about runs;
* ``analysis/``     the paper's propositions, equilibria and their stability, continuation in eps;
* ``scene/``, ``plotting/``, ``cli``: declarative runs, figures, the command line;
* ``testing``       hypothesis strategies and ulp-scaled assertions for users' tests.
"""

import sys as _sys

from . import analysis, diagnostics, integrators, studies, systems
from ._user_errors import UserFunctionError
from ._version import __version__
from .analysis import continuation, level_set
from .integrators import (
    AVF,
    RK4,
    BogackiShampine32,
    Composition,
    DampedGonzalez,
    DormandPrince54,
    DormandPrince853,
    Gonzalez,
    Integrator,
    ItohAbe,
    KahanLi6,
    KahanLi8,
    Lie,
    OscillatorRotation,
    Projected,
    RigidBodyFlow,
    RotorSplitting,
    Strang,
    Suzuki4,
    SuzukiUmeno8,
    SymmetrizedItohAbe,
    Yoshida4,
    Yoshida6,
)
from .model.system import MetriplecticSystem
from .model.system_n import GenericSystem, MetriplecticSystemN
from .results.solution import AccuracyWarning, Solution, load
from .run import events
from .run.ensemble import Ensemble, solve_ensemble, sweep
from .run.solve import solve
from .run.status import Status
from .scene import Scene, SceneError, SceneResult, run_scene
from .systems import reference

# the public modules that moved into a layer stay importable under their earlier names
for _name, _module in (
    ("continuation", continuation),
    ("level_set", level_set),
    ("events", events),
    ("reference", reference),
):
    _sys.modules[f"{__name__}.{_name}"] = _module
# runs about runs moved from diagnostics to studies; reachable where they were
for _name in ("Curve", "measured_order", "reference_solution", "work_precision"):
    setattr(diagnostics, _name, getattr(studies, _name))
# and S_rise_statistics, which runs a method, from integrators to studies (set here on purpose: integrators/
# imports no studies; pyright sees no such attribute of the module)
integrators.S_rise_statistics = studies.S_rise_statistics  # pyright: ignore[reportAttributeAccessIssue]
del _name, _module

__all__ = [
    "AVF",
    "RK4",
    "AccuracyWarning",
    "BogackiShampine32",
    "Composition",
    "DampedGonzalez",
    "DormandPrince54",
    "DormandPrince853",
    "Ensemble",
    "GenericSystem",
    "Gonzalez",
    "Integrator",
    "ItohAbe",
    "KahanLi6",
    "KahanLi8",
    "Lie",
    "MetriplecticSystem",
    "MetriplecticSystemN",
    "OscillatorRotation",
    "Projected",
    "RigidBodyFlow",
    "RotorSplitting",
    "Scene",
    "SceneError",
    "SceneResult",
    "Solution",
    "Status",
    "Strang",
    "Suzuki4",
    "SuzukiUmeno8",
    "SymmetrizedItohAbe",
    "UserFunctionError",
    "Yoshida4",
    "Yoshida6",
    "__version__",
    "analysis",
    "continuation",
    "diagnostics",
    "events",
    "level_set",
    "load",
    "reference",
    "run_scene",
    "solve",
    "solve_ensemble",
    "studies",
    "sweep",
    "systems",
]
