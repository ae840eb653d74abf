"""geomint: structure-preserving integrators for metriplectic systems in R^3."""

from . import systems
from .integrators import AVF, RK4, DampedGonzalez, Gonzalez, Integrator, ItohAbe, SymmetrizedItohAbe
from .solution import Solution
from .solve import solve
from .system import MetriplecticSystem

__version__ = "0.1.0"

__all__ = [
    "AVF", "RK4", "DampedGonzalez", "Gonzalez", "Integrator", "ItohAbe", "MetriplecticSystem", "Solution",
    "SymmetrizedItohAbe", "__version__", "solve", "systems",
]
