"""Generic Runge-Kutta methods: the classical RK4 baseline and explicit embedded pairs."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .._kernels import layout
from . import tableaux
from .base import Integrator, Traits

if TYPE_CHECKING:
    from .base import StageData


@dataclass(frozen=True)
class RK4(Integrator):
    """The classical explicit Runge-Kutta method, order 4.

    Structure-blind: H drifts and S may rise.  Compiled in the same engine as
    geomint's methods, it is the baseline every benchmark compares against.
    Reference: Hairer, Norsett, Wanner, Solving ODEs I, section II.1.
    """

    name: ClassVar[str] = "rk4"
    traits: ClassVar[Traits] = Traits(order=4, energy_exact=False, dissipative=False, symmetric=False, implicit=False)

    def stage(self, system: Any) -> StageData:
        return layout.LEAF_RK4, 0, 0, 0, 0, ()

    def lower(self, system: Any) -> layout.RungeKutta4:
        return layout.RungeKutta4(4)


@dataclass(frozen=True)
class EmbeddedRungeKutta(Integrator):
    """An explicit Runge-Kutta pair: a step of order ``order`` and an error estimate of order ``error_order``.

    Structure-blind on its own (H drifts, S may rise), as scipy's ``RK23``,
    ``RK45`` and ``DOP853`` are; ``Projected(pair)`` makes it exact in H and
    monotone in S at every step while the pair's estimate steers the step size
    (``solve(..., h=None, rtol=..., atol=...)``).  With a fixed ``h`` it is the
    plain higher-order step (the estimate is not computed).  Tableaux:
    ``geomint.integrators.tableaux``.
    """

    tableau: ClassVar[tuple]

    @property
    def traits(self) -> Traits:
        return Traits(order=self.tableau[5], energy_exact=False, dissipative=False, symmetric=False, implicit=False)

    @property
    def error_order(self) -> float:
        """Order of the embedded solution the error estimate measures."""
        return self.tableau[6]

    def error_estimate(self) -> tuple[int, float]:
        return layout.EMBEDDED, self.error_order

    def lower(
        self,
        system: Any,
        projection: int = layout.NO_PROJECTION,
        max_iter: int = 50,
    ) -> layout.EmbeddedPairStep:
        b, e, e_low, starts, cols, values = _tableau_arrays(type(self))
        slots = math.ceil(3 * (len(b) + 1) / layout.WORK)
        return layout.EmbeddedPairStep(b, e, e_low, projection, max_iter, slots, starts, cols, values)


@functools.cache
def _tableau_arrays(pair: type[EmbeddedRungeKutta]) -> tuple[np.ndarray, ...]:
    """``(b, e, e_low, a_starts, a_cols, a_values)`` of a pair's tableau as arrays (``a`` by its nonzero entries
    row by row, ``layout.EmbeddedPairStep``), built once per class: a run's step data shares them (the kernels
    only read them)."""
    a_rows, b, _, e, e_low = pair.tableau[:5]
    s = len(b)
    a = np.zeros((s, s))
    for i, row in enumerate(a_rows):
        a[i, : len(row)] = row
    rows, cols = np.nonzero(a)  # row-major: j increasing within each row
    starts = np.searchsorted(rows, np.arange(s + 1)).astype(np.int64)
    weights = (np.array(v, dtype=np.float64) for v in (b, e, e_low))
    return *weights, starts, cols.astype(np.int64), a[rows, cols]


@dataclass(frozen=True)
class BogackiShampine32(EmbeddedRungeKutta):
    """Bogacki-Shampine 3(2), scipy's ``RK23``: order 3, 3 stages plus the field at the new state.
    Reference: Bogacki & Shampine, Appl. Math. Lett. 2 (1989) 321."""

    name: ClassVar[str] = "rk23"
    tableau: ClassVar[tuple] = tableaux.BOGACKI_SHAMPINE_32


@dataclass(frozen=True)
class DormandPrince54(EmbeddedRungeKutta):
    """Dormand-Prince 5(4), scipy's ``RK45``: order 5, 6 stages plus the field at the new state.
    Reference: Dormand & Prince, J. Comput. Appl. Math. 6 (1980) 19."""

    name: ClassVar[str] = "rk45"
    tableau: ClassVar[tuple] = tableaux.DORMAND_PRINCE_54


@dataclass(frozen=True)
class DormandPrince853(EmbeddedRungeKutta):
    """Dormand-Prince 8(5,3), scipy's ``DOP853``: order 8, 12 stages, a 5th- and a 3rd-order estimate
    blended as in Hairer's code.  Reference: Hairer, Norsett, Wanner, *Solving ODEs I*, section II.10."""

    name: ClassVar[str] = "dop853"
    tableau: ClassVar[tuple] = tableaux.DORMAND_PRINCE_853
