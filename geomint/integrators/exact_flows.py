"""[R3] Exact and explicit Hamiltonian sub-flows in R^3 that a system declares it admits.

Each applies to the Hamiltonian part ``xi_P`` only: inside ``Lie``/``Strang``
as the Hamiltonian sub-integrator, or alone on a system with ``eps = 0``.  A
system admits one by declaring it (``MetriplecticSystem(exact_flows={...})``,
checked at sample points when the system is built; the catalogue's rigid
bodies and oscillator declare theirs); ``solve`` raises ``ValueError`` for a
system that does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from .._kernels import layout
from .base import Integrator, Traits
from .program import Program

if TYPE_CHECKING:
    from .base import StageData


@dataclass(frozen=True)
class _HamiltonianFlow(Integrator):
    """A leaf method of the Hamiltonian flow alone, for systems that declare it."""

    flows: ClassVar[tuple] = ("hamiltonian",)
    leaf_code: ClassVar[int]
    applies_to: ClassVar[str]

    def check_system(self, system: Any) -> None:
        if self.name not in system.exact_flows:
            raise ValueError(
                f"`method` {self!r} applies only to systems that declare exact_flows={{'{self.name}': ...}} "
                f"({self.applies_to}); {system!r} declares {sorted(system.exact_flows) or 'none'}. "
                "Use Gonzalez() for this flow."
            )

    def stage(self, system: Any) -> StageData:
        return self.leaf_code, 0, 0, 0, 0, system.exact_flows[self.name]

    def program(self) -> Program:
        return Program(((self, "hamiltonian", 1.0),))

    def lower(self, system: Any) -> tuple:
        if system.eps != 0.0:
            raise ValueError(
                f"`method` {self!r} integrates the Hamiltonian part only, so alone it needs eps = 0; got eps = "
                f"{system.eps!r}. Use it inside Strang(...) or on system.with_effects(eps=0)."
            )
        return self.program().lower(system)


@dataclass(frozen=True)
class RigidBodyFlow(_HamiltonianFlow):
    """The exact flow of the free rigid body ``m' = grad H x m``, ``H = (a x^2 + b y^2 + c z^2)/2``,
    by Jacobi elliptic functions (formulas in ``geomint._kernels.exact_flows.rigid_body_flow``).

    Keeps H and ``|m|`` to round-off; exact, so it has no finite order.
    Reference: Celledoni, Fasso, Safstrom, Zanna, SIAM J. Sci. Comput. 30 (2008)
    2084, doi:10.1137/070704393.  A system admits it by declaring
    ``exact_flows={"rigid_body_flow": (a, b, c)}`` (``relaxing_rigid_body`` does).
    """

    name: ClassVar[str] = "rigid_body_flow"
    traits: ClassVar[Traits] = Traits(
        order=math.inf, energy_exact=True, dissipative=True, symmetric=True, implicit=False
    )
    leaf_code: ClassVar[int] = layout.LEAF_RIGID_BODY_FLOW
    applies_to: ClassVar[str] = "quadratic H = (a x^2 + b y^2 + c z^2)/2 with J = m"


@dataclass(frozen=True)
class RotorSplitting(_HamiltonianFlow):
    """Explicit Poisson splitting of the rigid body into free rotors, ``R_1(h/2) R_2(h/2) R_3(h) R_2(h/2) R_1(h/2)``.

    For ``H = sum_i H_i(m_i)`` the flow of ``H_i`` turns ``m`` about axis ``i`` by
    ``t dH_i/dm_i``.  Symmetric, order 2, Poisson; keeps ``|m|`` (so S) to
    round-off but not H.  Reference: McLachlan, Phys. Rev. Lett. 71 (1993) 3043,
    doi:10.1103/PhysRevLett.71.3043.  Declared as ``exact_flows={"rotor_splitting": ()}``
    (both catalogue rigid bodies).
    """

    name: ClassVar[str] = "rotor_splitting"
    traits: ClassVar[Traits] = Traits(order=2, energy_exact=False, dissipative=True, symmetric=True, implicit=False)
    leaf_code: ClassVar[int] = layout.LEAF_ROTOR_SPLITTING
    applies_to: ClassVar[str] = "separable H = sum_i H_i(m_i) with J = m"


@dataclass(frozen=True)
class OscillatorRotation(_HamiltonianFlow):
    """The exact Hamiltonian flow ``x' = x x J`` for ``H = |x|^2/2`` and constant ``J``: a rotation
    about ``J`` by ``-|J| t``.

    Keeps H and every function of ``x . J`` exactly.  Declared as
    ``exact_flows={"oscillator_rotation": ()}`` (``dissipative_oscillator``).
    """

    name: ClassVar[str] = "oscillator_rotation"
    traits: ClassVar[Traits] = Traits(
        order=math.inf, energy_exact=True, dissipative=True, symmetric=True, implicit=False
    )
    leaf_code: ClassVar[int] = layout.LEAF_ROTATION
    applies_to: ClassVar[str] = "H = |x|^2/2 with a constant J"


EXACT_FLOWS = (RigidBodyFlow, RotorSplitting, OscillatorRotation)

__all__ = ["EXACT_FLOWS", "OscillatorRotation", "RigidBodyFlow", "RotorSplitting"]
