"""How splittings, compositions and projections lower to the one engine.

A ``Program`` is the flat description that ``geomint._kernels.composition``
runs: stages (a method on a flow, with a fraction of the step), the
composition's gammas, the monotone safeguard and the projection.  Every stage
carries its own step data (``Integrator.stage``), so any method composes,
splits and projects.  A method that is not itself a program is a one-stage
program on the full field.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._kernels import layout

if TYPE_CHECKING:
    from .base import Integrator

FLOWS = {"full": layout.FULL, "hamiltonian": layout.HAMILTONIAN, "gradient": layout.GRADIENT}


@dataclass(frozen=True)
class Program:
    """``projection(safeguard(base(gamma_G h) ... base(gamma_1 h)))``, ``base = stage_N ... stage_1``.

    ``stages``: tuples ``(method, flow name, fraction of h)``.
    """

    stages: tuple
    gammas: tuple = (1.0,)
    monotone: bool = False
    projection: int = layout.NO_PROJECTION
    max_iter: int = 50

    def energy_exact(self) -> bool:
        return all(method.energy_exact for method, _, _ in self.stages)

    def lower(self, system: Any) -> layout.ComposedStep:  # system: a MetriplecticSystem (integrators import no model)
        """A ``layout.ComposedStep`` (layout in ``_kernels/composition.py``)."""
        from .discrete_gradient import Gonzalez

        anchor = self.projection == layout.NO_PROJECTION and self.energy_exact()
        header = [len(self.gammas), len(self.stages), int(self.monotone), self.projection, self.max_iter, int(anchor)]
        coeffs = [*self.gammas, *(fraction for _, _, fraction in self.stages)]
        rows = []
        leaves, damped_any = set(), False
        stages = [(method, flow) for method, flow, _ in self.stages] + [(Gonzalez(), "full")]
        for k, (method, flow) in enumerate(stages):
            leaf, kind, max_iter, damped, compensated, data = method.stage(system)
            rows += [leaf, FLOWS[flow], kind, max_iter, int(damped), int(compensated), len(coeffs), len(data)]
            coeffs += [float(c) for c in data]
            if k < len(self.stages) or self.monotone:  # the safeguard's fallback runs only in monotone programs
                leaves.add((leaf, kind if leaf == layout.LEAF_DISCRETE_GRADIENT else 0))
                # damping scales eps, which a stage on the Hamiltonian flow does not have
                damped_any = damped_any or (bool(damped) and flow != "hamiltonian")
        iopts = np.array(header + rows, dtype=np.int64)
        slots = len(self.gammas) * len(self.stages) + 1
        return layout.ComposedStep(np.array(coeffs, dtype=np.float64), iopts, slots, _markers(leaves, damped_any))


def _markers(leaves, damped):
    """``ComposedStep.uses`` from the ``(leaf code, kind code)`` pairs a program can run, in a fixed order (one
    compiled type per set), and ``Damped(True)`` last where a stage is ``damped``."""
    markers = tuple(
        layout.KIND_MARKERS[kind](kind) if leaf == layout.LEAF_DISCRETE_GRADIENT else layout.LEAF_MARKERS[leaf](leaf)
        for leaf, kind in sorted(leaves)
    )
    return markers + ((layout.Damped(True),) if damped else ())


class Programmed:
    """Mixin for methods built on sub-integrators and lowered through ``program()``."""

    if TYPE_CHECKING:  # for pyright only: each method using the mixin defines it (``program_of`` asks hasattr)

        def program(self) -> Program: ...

    def sub_methods(self) -> tuple[Integrator, ...]:
        raise NotImplementedError

    def check_system(self, system: Any) -> None:
        for method in self.sub_methods():
            method.check_system(system)

    def lower(self, system: Any) -> layout.ComposedStep:
        return self.program().lower(system)


def program_of(method: Integrator) -> Program:
    """The program of ``method``: its own, or one stage of it on the full field."""
    # (pyright does not narrow an Integrator by hasattr: the methods with a program are the Programmed ones)
    return (
        method.program()  # pyright: ignore[reportAttributeAccessIssue]
        if hasattr(method, "program")
        else Program(((method, "full", 1.0),))
    )


def check_flow(argument: str, method: Integrator, flow: str) -> None:
    """Raise ``ValueError`` if ``method`` cannot integrate the sub-flow ``flow``."""
    if flow not in method.flows:
        raise ValueError(
            f"`{argument}` must integrate the {flow} flow; {method!r} integrates only the {method.flows[0]} flow."
        )
