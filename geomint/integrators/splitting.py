r"""Lie and Strang splittings of the Hamiltonian flow and the gradient flow.

    x' = xi_P(x)  +  eps xi_g(x)
         \_ A _/     \__ B __/

``A`` keeps H and S, ``B`` keeps H and lowers S (docs/design.md section 3).  Each
flow gets its own sub-integrator: an exact flow (``RigidBodyFlow``,
``OscillatorRotation``), the explicit ``RotorSplitting``, or any one-step
method restricted to that flow (``Gonzalez()`` on ``system.with_effects(eps=0)``
resp. ``with_effects(hamiltonian=False)``, done inside the kernel).
"""

from dataclasses import dataclass, field
from typing import ClassVar

from .base import Integrator, Traits
from .discrete_gradient import Gonzalez
from .program import Program, Programmed, check_flow


@dataclass(frozen=True)
class _Splitting(Programmed, Integrator):
    hamiltonian_part: Integrator = field(default_factory=Gonzalez)
    gradient_part: Integrator = field(default_factory=Gonzalez)

    def __post_init__(self) -> None:
        for argument, method in (("hamiltonian_part", self.hamiltonian_part), ("gradient_part", self.gradient_part)):
            if not isinstance(method, Integrator):
                raise TypeError(f"`{argument}` must be a geomint Integrator; got {method!r}.")
        check_flow("hamiltonian_part", self.hamiltonian_part, "hamiltonian")
        check_flow("gradient_part", self.gradient_part, "gradient")
        for argument, method in (("hamiltonian_part", self.hamiltonian_part), ("gradient_part", self.gradient_part)):
            if isinstance(method, Programmed):
                raise TypeError(
                    f"`{argument}` must be a one-step method (Gonzalez(), AVF(), RK4(), an exact flow); got {method!r}."
                )

    def _traits(self, order, symmetric):
        a, b = self.hamiltonian_part, self.gradient_part
        return Traits(
            order=order,
            energy_exact=a.energy_exact and b.energy_exact,
            dissipative=a.dissipative and b.dissipative,
            symmetric=symmetric,
            implicit=a.implicit or b.implicit,
        )

    def sub_methods(self) -> tuple[Integrator, ...]:
        return (self.hamiltonian_part, self.gradient_part)


@dataclass(frozen=True)
class Lie(_Splitting):
    """Lie-Trotter splitting ``Phi_h = B_h o A_h``: first order.

    ``A_h`` advances the Hamiltonian flow ``xi_P`` with ``hamiltonian_part``,
    ``B_h`` the gradient flow ``eps xi_g`` with ``gradient_part``.  Keeps H
    when both parts do; never raises S when both parts do not.  Reference:
    McLachlan and Quispel, Acta Numerica 11 (2002) 341, doi:10.1017/S0962492902000053.
    """

    name: ClassVar[str] = "lie"

    @property
    def traits(self) -> Traits:
        return self._traits(1, False)

    def program(self) -> Program:
        return Program(((self.hamiltonian_part, "hamiltonian", 1.0), (self.gradient_part, "gradient", 1.0)))


@dataclass(frozen=True)
class Strang(_Splitting):
    """Strang splitting ``Phi_h = A_{h/2} o B_h o A_{h/2}``: second order, symmetric when both parts are.

    The order is ``min(2, order of each part)``.  Reference: G. Strang, SIAM J.
    Numer. Anal. 5 (1968) 506, doi:10.1137/0705041.
    """

    name: ClassVar[str] = "strang"

    @property
    def traits(self) -> Traits:
        a, b = self.hamiltonian_part, self.gradient_part
        return self._traits(min(2, a.order, b.order), a.symmetric and b.symmetric)

    def program(self) -> Program:
        a, b = self.hamiltonian_part, self.gradient_part
        return Program(((a, "hamiltonian", 0.5), (b, "gradient", 1.0), (a, "hamiltonian", 0.5)))
