"""Generic Runge-Kutta baseline."""

from dataclasses import dataclass
from typing import ClassVar

from .._kernels import layout
from .base import Integrator, Traits


@dataclass(frozen=True)
class RK4(Integrator):
    """The classical explicit Runge-Kutta method, order 4.

    Structure-blind: H drifts and S may rise.  Compiled in the same engine as
    geomint's methods, it is the baseline every benchmark compares against.
    Reference: Hairer, Norsett, Wanner, Solving ODEs I, section II.1.
    """

    name: ClassVar[str] = "rk4"
    traits: ClassVar[Traits] = Traits(order=4, energy_exact=False, dissipative=False, symmetric=False, implicit=False)

    def stage(self, system):
        return layout.LEAF_RK4, 0, 0, 0, 0, ()

    def lower(self, system):
        return layout.RungeKutta4(4)
