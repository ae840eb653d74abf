"""Generic Runge-Kutta baseline."""

from dataclasses import dataclass
from typing import ClassVar

from .._kernels import steps as _steps
from .base import Integrator


@dataclass(frozen=True)
class RK4(Integrator):
    """The classical explicit Runge-Kutta method, order 4.

    Structure-blind: H drifts and S may rise.  Compiled in the same engine as
    geomint's methods, it is the baseline every benchmark compares against.
    Reference: Hairer, Norsett, Wanner, Solving ODEs I, section II.1.
    """

    name: ClassVar[str] = "rk4"
    order: ClassVar[int] = 4
    energy_exact: ClassVar[bool] = False
    dissipative: ClassVar[bool] = False
    symmetric: ClassVar[bool] = False
    implicit: ClassVar[bool] = False

    def lower(self):
        return self._data(_steps.RK4)
