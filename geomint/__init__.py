"""geomint: structure-preserving integrators for metriplectic systems in R^3."""

from . import systems
from .integrators import RK4, Gonzalez, Integrator
from .solution import Solution
from .solve import solve
from .system import MetriplecticSystem

__version__ = "0.1.0"

__all__ = ["RK4", "Gonzalez", "Integrator", "MetriplecticSystem", "Solution", "__version__", "solve", "systems"]
