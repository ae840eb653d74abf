"""geomint: structure-preserving integrators for metriplectic systems in R^3."""

from . import analysis, continuation, diagnostics, events, level_set, reference, systems
from .integrators import (
    AVF, RK4, BogackiShampine32, Composition, DampedGonzalez, DormandPrince54, DormandPrince853, Gonzalez, Integrator, ItohAbe, KahanLi6, KahanLi8, Lie, OscillatorRotation,
    Projected, RigidBodyFlow, RotorSplitting, Strang, Suzuki4, SuzukiUmeno8, SymmetrizedItohAbe, Yoshida4, Yoshida6,
)
from ._user_errors import UserFunctionError
from .ensemble import Ensemble, solve_ensemble, sweep
from .io import load
from .scene import Scene, SceneError, SceneResult, run_scene
from .solution import AccuracyWarning, Solution
from .solve import solve
from .system import MetriplecticSystem

__version__ = "0.1.0"

__all__ = [
    "AccuracyWarning",
    "AVF", "RK4", "BogackiShampine32", "Composition", "DampedGonzalez", "DormandPrince54", "DormandPrince853",
    "Ensemble", "Gonzalez", "Integrator", "ItohAbe", "KahanLi6",
    "KahanLi8", "Lie", "MetriplecticSystem", "OscillatorRotation", "Projected", "RigidBodyFlow", "RotorSplitting",
    "Scene", "SceneError", "SceneResult", "Solution", "Strang", "Suzuki4", "SuzukiUmeno8", "SymmetrizedItohAbe",
    "UserFunctionError", "Yoshida4", "Yoshida6", "__version__", "analysis", "continuation", "diagnostics", "events", "level_set",
    "load", "reference", "run_scene", "solve", "solve_ensemble", "sweep", "systems",
]
