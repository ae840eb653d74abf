"""Projection onto ``H = H0`` that never raises S: any method made energy-exact."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from .._kernels import layout
from .base import Integrator, Traits
from .program import Program, Programmed, program_of
from .runge_kutta import RK4, EmbeddedRungeKutta


@dataclass(frozen=True)
class Projected(Programmed, Integrator):
    """``method`` followed by a projection onto ``{H = H0, S <= S_n}``, ``H0 = H(x0)``.

    Standard (``symmetric=False``), after ``x~ = Phi_h(x_n)``:

        y = x~ + lambda grad H(x~),        H(y) = H0        (Newton on the scalar lambda);

    if then ``S(y) > S_n`` beyond round-off (moving along ``grad H`` changes S by
    ``lambda grad S . grad H``), the constraint ``S <= S_n`` is active and

        y = x~ + lambda grad H(x~) + mu grad S(x~),   H(y) = H0,  S(y) = S_n

    (2x2 Newton, Gram-matrix Jacobian).  So ``H(x_{n+1}) = H0`` to round-off at
    every step, with ``H0`` the energy anchor the loop passes (no random walk of the target), and
    ``S(x_{n+1}) <= S(x_n)`` up to round-off whatever ``method`` does.  The order
    of ``method`` is kept (the projection moves by the size of its local error).

    Symmetric (``symmetric=True``, Hairer, BIT 40 (2000) 726, doi:10.1023/A:1022344502818):

        x^ = x_n + mu grad H(x_n),   y~ = Phi_h(x^),   x_{n+1} = y~ + mu grad H(x_{n+1}),   H(x_{n+1}) = H0,

    one ``mu`` at both ends, so a symmetric ``method`` stays symmetric (each
    iteration costs one step of ``method``).  The S safeguard above applies to
    its result too (breaking symmetry only in a step where it fires).
    Reference for both: Hairer, Lubich, Wanner, *Geometric Numerical
    Integration*, sections IV.4 and V.4.1.

    Parameters
    ----------
    method : Integrator, default RK4()
        Any method: a one-step method, a splitting or a composition.
    symmetric : bool, default False
        Hairer's symmetric projection; needs a symmetric ``method``.
    max_iter : int, default 50
        Newton (and symmetric-projection) iterations per step before ``status = -1``.
    """

    method: Integrator = field(default_factory=RK4)
    symmetric: bool = field(default=False, kw_only=True)
    max_iter: int = field(default=50, kw_only=True)

    name: ClassVar[str] = "projected"

    def __post_init__(self) -> None:
        if not isinstance(self.method, Integrator) or isinstance(self.method, Projected):
            raise TypeError(
                f"`method` must be a geomint Integrator that is not already projected; got {self.method!r}."
            )
        if not self.method.whole_field:
            raise ValueError(
                f"`method` must integrate the whole field; {self.method!r} integrates only the "
                f"{self.method.flows[0]} flow."
            )
        if not isinstance(self.symmetric, bool):
            raise TypeError(f"`symmetric` must be True or False; got {self.symmetric!r}.")
        if self.symmetric and not self.method.symmetric:
            raise ValueError(
                f"`symmetric=True` keeps a symmetric method symmetric; {self.method!r} is not symmetric. "
                "Use symmetric=False."
            )
        if not isinstance(self.max_iter, int) or isinstance(self.max_iter, bool) or not 1 <= self.max_iter <= 10**6:
            raise ValueError(f"`max_iter` must be an integer in [1, 10**6]; got {self.max_iter!r}.")

    @property
    def traits(self) -> Traits:
        return Traits(
            order=self.method.order,
            energy_exact=True,
            dissipative=True,
            symmetric=self.symmetric,
            implicit=self.method.implicit,
        )

    def program(self) -> Program:
        inner = program_of(self.method)
        mode = layout.SYMMETRIC if self.symmetric else layout.STANDARD
        return Program(inner.stages, inner.gammas, inner.monotone, mode, self.max_iter)

    def sub_methods(self) -> tuple[Integrator, ...]:
        return (self.method,)

    def error_estimate(self) -> tuple[int, float]:
        """An embedded pair's own estimate (the error of the explicit step the projection then moves by
        about as much); step doubling for any other method."""
        if isinstance(self.method, EmbeddedRungeKutta):
            return self.method.error_estimate()
        return super().error_estimate()

    def lower(self, system: Any) -> tuple:
        if isinstance(self.method, EmbeddedRungeKutta):
            return self.method.lower(system, projection=layout.STANDARD, max_iter=self.max_iter)
        return super().lower(system)
