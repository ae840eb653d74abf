"""geomint: structure-preserving integrators for metriplectic systems in R^3."""

from . import level_set, systems
from .integrators import RK4, Gonzalez, Integrator
from .scene import Scene, SceneError, SceneResult, run_scene
from .solution import Solution
from .solve import solve
from .system import MetriplecticSystem

__version__ = "0.1.0"

__all__ = [
    "RK4", "Gonzalez", "Integrator", "MetriplecticSystem", "Scene", "SceneError", "SceneResult", "Solution",
    "__version__", "level_set", "run_scene", "solve", "systems",
]
