"""The integrator protocol: what a method declares, and how it reaches the engine."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from .._kernels import layout

if TYPE_CHECKING:
    #: ``Integrator.stage``: (leaf code, discrete-gradient kind, max_iter, damped, compensated, coefficients)
    StageData = tuple[int, int, int, int, int, Any]


@dataclass(frozen=True)
class Traits:
    """What a method guarantees; the tests check every declaration (orders by measurement,
    invariants per step).

    Attributes
    ----------
    order : int or float
        Classical order of accuracy (``math.inf`` for an exact flow).
    energy_exact : bool
        H(x_{n+1}) = H(x_n) to round-off at every step.
    dissipative : bool
        S(x_{n+1}) <= S(x_n) (to round-off) at every step.
    symmetric : bool
        The method is its own adjoint (time-reversible).
    implicit : bool
        Each step solves a nonlinear equation (Newton iterations are counted).
    """

    order: float
    energy_exact: bool
    dissipative: bool
    symmetric: bool
    implicit: bool


class Integrator:
    """A one-step method as data: a short ``name``, its ``traits`` and how it lowers to the engine.

    Leaf methods declare ``traits`` as a class constant; wrappers (splittings,
    compositions, projections) compute them from their parts.  ``order``,
    ``energy_exact``, ``dissipative``, ``symmetric`` and ``implicit`` read
    ``traits`` on an instance.
    """

    name: ClassVar[str]
    #: integrates only one part of the field (a sub-flow of a splitting): ``"hamiltonian"`` or ``"gradient"``
    flows: ClassVar[tuple] = ("full", "hamiltonian", "gradient")

    @property
    def traits(self) -> Traits:
        raise NotImplementedError

    order = property(lambda self: _traits(self).order, doc="Classical order of accuracy.")
    energy_exact = property(lambda self: _traits(self).energy_exact, doc="H kept to round-off at every step.")
    dissipative = property(lambda self: _traits(self).dissipative, doc="S never rises (to round-off).")
    symmetric = property(lambda self: _traits(self).symmetric, doc="The method is its own adjoint.")
    implicit = property(lambda self: _traits(self).implicit, doc="Each step solves a nonlinear equation.")

    @property
    def whole_field(self) -> bool:
        """True when the method integrates the whole metriplectic field (not a sub-flow only)."""
        return "full" in self.flows

    def check_system(self, system: Any) -> None:  # system: a MetriplecticSystem (integrators import no model)
        """Raise ``ValueError`` when the method (or a part of it) does not apply to ``system``."""

    def stage(self, system: Any) -> StageData:
        """``(leaf code, discrete-gradient kind, max_iter, damped, compensated, coefficients)``: this method
        as one stage of a composed program (``program.Program``)."""
        raise TypeError(f"{self!r} cannot be a stage of a splitting or composition: use it on the whole field.")

    def error_estimate(self) -> tuple[int, float]:
        """``(estimator, order of the estimate)`` for adaptive steps (``geomint._kernels.control``):
        step doubling (``layout.DOUBLING``) at the method's order, unless the method has a cheaper
        estimate of its own."""
        return layout.DOUBLING, self.order

    def lower(self, system: Any) -> tuple:
        """The step data (the lowered method: a named tuple of ``geomint._kernels.layout``) for a run of ``system``.
        Caller: ``geomint.solve``, after ``check_system``."""
        raise NotImplementedError


def _traits(integrator: Integrator) -> Traits:
    """``integrator.traits``, worked out once per instance: an integrator is frozen, so its traits cannot change,
    and a wrapper's are built from its parts' (``solve`` reads them several times a call)."""
    kept = integrator.__dict__.get("_traits")
    if kept is None:
        kept = integrator.__dict__["_traits"] = integrator.traits
    return kept
