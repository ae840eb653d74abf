"""What a method is: small declarative objects with an order and traits; no step loops.

Each integrator lowers itself to ``(code, coeffs, iopts)`` for the shared
engine in ``geomint._kernels``.
"""

from .base import Integrator, resolve
from .discrete_gradient import AVF, DampedGonzalez, DiscreteGradient, Gonzalez, ItohAbe, SymmetrizedItohAbe
from .runge_kutta import RK4

__all__ = [
    "AVF", "DampedGonzalez", "DiscreteGradient", "Gonzalez", "Integrator", "ItohAbe", "RK4", "SymmetrizedItohAbe", "resolve",
]
