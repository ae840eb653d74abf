"""geomint: structure-preserving integrators for metriplectic systems in R^3."""

from . import level_set, systems
from .integrators import AVF, RK4, DampedGonzalez, Gonzalez, Integrator, ItohAbe, SymmetrizedItohAbe
from .scene import Scene, SceneError, SceneResult, run_scene
from .solution import Solution
from .solve import solve
from .system import MetriplecticSystem

__version__ = "0.1.0"

__all__ = [
    "AVF", "RK4", "DampedGonzalez", "Gonzalez", "Integrator", "ItohAbe", "MetriplecticSystem", "Scene", "SceneError",
    "SceneResult", "Solution", "SymmetrizedItohAbe", "__version__", "level_set", "run_scene", "solve", "systems",
]
