"""Exact and explicit Hamiltonian sub-flows for specific catalogue systems.

Each applies to the Hamiltonian part ``xi_P`` only: inside ``Lie``/``Strang``
as the Hamiltonian sub-integrator, or alone on a system with ``eps = 0``.
``solve`` checks the system (``bind``) and raises ``ValueError`` otherwise.
"""

import math
from dataclasses import dataclass
from typing import ClassVar


from .._kernels import composition as _comp
from ..systems import oscillator as _oscillator
from ..systems import rigid_body as _rigid_body
from .base import Integrator
from .program import Program


@dataclass(frozen=True)
class _HamiltonianFlow(Integrator):
    """A leaf method of the Hamiltonian flow alone, for the systems in ``applies_to``."""

    flows: ClassVar[tuple] = ("hamiltonian",)
    leaf_code: ClassVar[int]
    applies_to: ClassVar[str]
    dissipative: ClassVar[bool] = True
    implicit: ClassVar[bool] = False

    def _matches(self, system):
        raise NotImplementedError

    def check_system(self, system):
        if not self._matches(system):
            raise ValueError(
                f"`method` {self!r} applies only to {self.applies_to}; got {system!r}. Use Gonzalez() for this flow."
            )

    def program(self):
        return Program(((self, "hamiltonian", 1.0),))

    def lower(self):
        return self.program().lower()

    def bind(self, system, x0):
        self.check_system(system)
        if system.eps != 0.0:
            raise ValueError(
                f"`method` {self!r} integrates the Hamiltonian part only, so alone it needs eps = 0; got eps = "
                f"{system.eps!r}. Use it inside Strang(...) or on system.with_effects(eps=0)."
            )
        return self.lower()


def _is_rigid_body(system, grad_H_functions):
    f = system.functions
    return f.poisson is _rigid_body._identity_J and any(f.grad_H is g for g in grad_H_functions)


@dataclass(frozen=True)
class RigidBodyFlow(_HamiltonianFlow):
    """The exact flow of the free rigid body ``m' = grad H x m``, ``H = (a x^2 + b y^2 + c z^2)/2``,
    by Jacobi elliptic functions (formulas in ``geomint._kernels.exact_flows.rigid_body_flow``).

    Keeps H and ``|m|`` to round-off; exact, so it has no finite order.
    Reference: Celledoni, Fasso, Safstrom, Zanna, SIAM J. Sci. Comput. 30 (2008)
    2084, doi:10.1137/070704393.  Applies to ``relaxing_rigid_body``.
    """

    name: ClassVar[str] = "rigid_body_flow"
    order: ClassVar[float] = math.inf
    energy_exact: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    leaf_code: ClassVar[int] = _comp.RIGID_BODY_FLOW
    applies_to: ClassVar[str] = "the relaxing rigid body (quadratic H, J = m)"

    def _matches(self, system):
        return _is_rigid_body(system, (_rigid_body._quadratic_grad_H,))


@dataclass(frozen=True)
class RotorSplitting(_HamiltonianFlow):
    """Explicit Poisson splitting of the rigid body into free rotors, ``R_1(h/2) R_2(h/2) R_3(h) R_2(h/2) R_1(h/2)``.

    For ``H = sum_i H_i(m_i)`` the flow of ``H_i`` turns ``m`` about axis ``i`` by
    ``t dH_i/dm_i``.  Symmetric, order 2, Poisson; keeps ``|m|`` (so S) to
    round-off but not H.  Reference: McLachlan, Phys. Rev. Lett. 71 (1993) 3043,
    doi:10.1103/PhysRevLett.71.3043.  Applies to both catalogue rigid bodies.
    """

    name: ClassVar[str] = "rotor_splitting"
    order: ClassVar[int] = 2
    energy_exact: ClassVar[bool] = False
    symmetric: ClassVar[bool] = True
    leaf_code: ClassVar[int] = _comp.ROTOR_SPLITTING
    applies_to: ClassVar[str] = "the catalogue rigid bodies (separable H, J = m)"

    def _matches(self, system):
        return _is_rigid_body(system, (_rigid_body._quadratic_grad_H, _rigid_body._quartic_grad_H))


@dataclass(frozen=True)
class OscillatorRotation(_HamiltonianFlow):
    """The exact Hamiltonian flow of the dissipative oscillator: ``(x, y)`` turn clockwise at unit rate.

    ``x' = x x J`` with ``J = (0, 0, 1)`` is the rotation about ``J`` by ``-t``;
    keeps H and S (a function of z) exactly.  Applies to ``dissipative_oscillator``.
    """

    name: ClassVar[str] = "oscillator_rotation"
    order: ClassVar[float] = math.inf
    energy_exact: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    leaf_code: ClassVar[int] = _comp.ROTATION
    applies_to: ClassVar[str] = "the dissipative oscillator (H = |x|^2/2, J = (0, 0, 1))"

    def _matches(self, system):
        f = system.functions
        return f.grad_H is _oscillator._grad_H and f.poisson is _oscillator._J


__all__ = ["OscillatorRotation", "RigidBodyFlow", "RotorSplitting"]
