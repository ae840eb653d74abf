"""What a method is: small declarative objects with an order and traits; no step loops.

Each integrator lowers itself to ``(code, coeffs, iopts)`` for the shared
engine in ``geomint._kernels``.
"""

from .base import Integrator, resolve
from .composition import SCHEMES, Composition, KahanLi6, KahanLi8, Suzuki4, SuzukiUmeno8, Yoshida4, Yoshida6
from .discrete_gradient import AVF, DampedGonzalez, DiscreteGradient, Gonzalez, ItohAbe, SymmetrizedItohAbe
from .exact_flows import OscillatorRotation, RigidBodyFlow, RotorSplitting
from .program import S_rise_statistics
from .projection import Projected
from .runge_kutta import RK4
from .splitting import Lie, Strang

__all__ = [
    "AVF", "Composition", "DampedGonzalez", "DiscreteGradient", "Gonzalez", "Integrator", "ItohAbe", "KahanLi6",
    "KahanLi8", "Lie", "OscillatorRotation", "Projected", "RK4", "RigidBodyFlow", "RotorSplitting", "SCHEMES",
    "S_rise_statistics", "Strang", "Suzuki4", "SuzukiUmeno8", "SymmetrizedItohAbe", "Yoshida4", "Yoshida6", "resolve",
]
