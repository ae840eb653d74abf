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

from __future__ import annotations

import importlib as _importlib
import importlib.machinery as _machinery
import sys as _sys
from typing import TYPE_CHECKING

from ._version import __version__

# ``import geomint`` loads only this file and ``_version``: every public name is imported on first use (PEP 562,
# ``__getattr__`` below).  The layers below import numba (which imports scipy), the kernels package, and through
# the face sympy and matplotlib: ~0.5 s that a process which only names a class, or runs ``--help``, need not pay.
# docs/startup.md has the measurements; tests/test_compilation.py checks what ``import geomint`` loads.

#: the public modules that moved into a layer, importable under their earlier names too: ``import geomint.events``
#: gives ``geomint.run.events`` itself (``_MovedModules`` resolves them on first import)
_MOVED = {
    "continuation": f"{__name__}.analysis.continuation",
    "level_set": f"{__name__}.analysis.level_set",
    "events": f"{__name__}.run.events",
    "reference": f"{__name__}.systems.reference",
}

#: public name -> (the module that defines it, its attribute there; None: the module itself)
_PUBLIC: dict[str, tuple[str, str | None]] = {
    # the layers (model, results, run and scene were reachable as attributes before, imported by this file)
    **{
        name: (f"{__name__}.{name}", None)
        for name in ("analysis", "diagnostics", "integrators", "model", "results", "run", "scene", "studies", "systems")
    },
    **{name: (f"{__name__}.{name}", None) for name in _MOVED},
    **{
        name: (f"{__name__}.integrators", name)
        for name in (
            "AVF",
            "RK4",
            "BogackiShampine32",
            "Composition",
            "DampedGonzalez",
            "DormandPrince54",
            "DormandPrince853",
            "Gonzalez",
            "Integrator",
            "ItohAbe",
            "KahanLi6",
            "KahanLi8",
            "Lie",
            "OscillatorRotation",
            "Projected",
            "RigidBodyFlow",
            "RotorSplitting",
            "Strang",
            "Suzuki4",
            "SuzukiUmeno8",
            "SymmetrizedItohAbe",
            "Yoshida4",
            "Yoshida6",
        )
    },
    "UserFunctionError": (f"{__name__}._user_errors", "UserFunctionError"),
    "MetriplecticSystem": (f"{__name__}.model.system", "MetriplecticSystem"),
    "GenericSystem": (f"{__name__}.model.system_n", "GenericSystem"),
    "MetriplecticSystemN": (f"{__name__}.model.system_n", "MetriplecticSystemN"),
    "AccuracyWarning": (f"{__name__}.results.solution", "AccuracyWarning"),
    "Solution": (f"{__name__}.results.solution", "Solution"),
    "load": (f"{__name__}.results.solution", "load"),
    "Ensemble": (f"{__name__}.run.ensemble", "Ensemble"),
    "solve_ensemble": (f"{__name__}.run.ensemble", "solve_ensemble"),
    "sweep": (f"{__name__}.run.ensemble", "sweep"),
    "solve": (f"{__name__}.run.solve", "solve"),
    "Status": (f"{__name__}.run.status", "Status"),
    **{name: (f"{__name__}.scene", name) for name in ("Scene", "SceneError", "SceneResult", "run_scene")},
}


def __getattr__(name: str) -> object:
    """A public name, imported on first use and then kept in the module's namespace (PEP 562)."""
    try:
        module, attribute = _PUBLIC[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = _importlib.import_module(module)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC})


class _MovedModules:
    """Finds ``geomint.continuation``, ``level_set``, ``events`` and ``reference`` (no files of their own): the
    module imported in their place is the one in its layer, the same object under both names."""

    @classmethod
    def find_spec(cls, fullname: str, path: object = None, target: object = None) -> _machinery.ModuleSpec | None:
        if fullname.startswith(f"{__name__}.") and fullname[len(__name__) + 1 :] in _MOVED:
            return _machinery.ModuleSpec(fullname, cls())  # pyright: ignore[reportArgumentType]
        return None

    def create_module(self, spec: _machinery.ModuleSpec) -> None:
        return None  # a placeholder module, replaced by exec_module

    def exec_module(self, module: ModuleType) -> None:
        # the import system returns what sys.modules holds under the name once this returns: the layer's module
        name = module.__name__
        _sys.modules[name] = _importlib.import_module(_MOVED[name[len(__name__) + 1 :]])


_sys.meta_path[:] = [finder for finder in _sys.meta_path if getattr(finder, "__qualname__", "") != "_MovedModules"]
_sys.meta_path.append(_MovedModules)  # last: it answers only for the four names above, which have no file

if TYPE_CHECKING:  # what the names are, for type checkers and the API reference (none is imported at run time)
    from types import ModuleType

    from . import analysis, diagnostics, studies, systems
    from . import integrators as integrators  # public as before, though not in __all__
    from . import model as model
    from . import results as results
    from . import run as run
    from . import scene as scene
    from ._user_errors import UserFunctionError
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
