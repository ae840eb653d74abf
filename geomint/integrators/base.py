"""The integrator protocol and the short-name lookup."""

from dataclasses import dataclass
from typing import ClassVar

import numpy as np


@dataclass(frozen=True)
class Integrator:
    """A one-step method as data.

    Class attributes declare what the method guarantees; the tests check every
    declaration (orders by measurement, invariants per step).

    Attributes
    ----------
    name : str
        Short name accepted by ``geomint.solve(method=...)``.
    order : int
        Classical order of accuracy.
    energy_exact : bool
        H(x_{n+1}) = H(x_n) to round-off at every step.
    dissipative : bool
        S(x_{n+1}) <= S(x_n) (to round-off) at every step.
    symmetric : bool
        The method is its own adjoint (time-reversible).
    implicit : bool
        Each step solves a nonlinear equation (Newton iterations are counted).
    """

    name: ClassVar[str]
    order: ClassVar[int]
    energy_exact: ClassVar[bool]
    dissipative: ClassVar[bool]
    symmetric: ClassVar[bool]
    implicit: ClassVar[bool]

    def lower(self):
        """``(code, coeffs, iopts)`` for the compiled engine."""
        raise NotImplementedError

    def bind(self, system, x0):
        """``lower()`` for a run of ``system`` from ``x0``: methods that apply only to some
        systems raise ``ValueError`` here, and methods that need a run constant
        (a projection's target ``H(x0)``) add it.  Caller: ``geomint.solve``."""
        return self.lower()

    @staticmethod
    def _data(code, coeffs=(), iopts=()):
        return code, np.asarray(coeffs, dtype=np.float64).reshape(-1), np.asarray(iopts, dtype=np.int64).reshape(-1)


def resolve(method):
    """An ``Integrator`` from an instance or a short name such as ``"gonzalez"``."""
    if isinstance(method, Integrator):
        return method
    names = _short_names()
    if isinstance(method, str) and method.lower() in names:
        return names[method.lower()]()
    raise ValueError(
        f"`method` must be an Integrator instance or one of {sorted(names)}; got {method!r}."
    )


def _short_names():
    from . import composition, discrete_gradient, exact_flows, projection, runge_kutta, splitting

    classes = (
        discrete_gradient.Gonzalez,
        discrete_gradient.ItohAbe,
        discrete_gradient.SymmetrizedItohAbe,
        discrete_gradient.AVF,
        discrete_gradient.DampedGonzalez,
        runge_kutta.RK4,
    )
    classes += (splitting.Lie, splitting.Strang, projection.Projected, *composition.WRAPPERS)
    classes += (exact_flows.RigidBodyFlow, exact_flows.RotorSplitting, exact_flows.OscillatorRotation)
    return {cls.name: cls for cls in classes}
