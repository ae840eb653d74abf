"""How splittings, compositions and projections lower to the one engine.

A ``Program`` is the flat description that ``geomint._kernels.composition``
runs: stages (a leaf method on a flow, with a fraction of the step), the
composition's gammas, the monotone safeguard and the projection.  Any method
that is not itself a program (``RK4()``, ``Gonzalez()``, the exact flows) is a
one-stage program on the full field.
"""

from dataclasses import dataclass

import numpy as np

from .._kernels import composition as _comp
from .._kernels import steps as _steps
from ..system import MetriplecticSystem

FLOWS = {"full": _comp.FULL, "hamiltonian": _comp.HAMILTONIAN, "gradient": _comp.GRADIENT}
_ALL_FLOWS = tuple(FLOWS)


@dataclass(frozen=True)
class Program:
    """``projection(safeguard(base(gamma_G h) ... base(gamma_1 h)))``, ``base = stage_N ... stage_1``.

    ``stages``: tuples ``(method, flow name, fraction of h)``.
    """

    stages: tuple
    gammas: tuple = (1.0,)
    monotone: bool = False
    projection: int = _comp.NO_PROJECTION
    max_iter: int = 50

    def lower(self):
        """``(code, coeffs, iopts)`` for ``steps.step`` (layout in ``_kernels/composition.py``)."""
        from .discrete_gradient import Gonzalez

        leaves = [(method, flow) for method, flow, _ in self.stages] + [(Gonzalez(), "full")]
        header = [len(self.gammas), len(self.stages), int(self.monotone), self.projection, self.max_iter]
        rows, leaf_iopts = [], []
        first = _comp.HEADER + _comp.ROW * len(leaves)
        for method, flow in leaves:
            code, iopts = leaf_data(method)
            rows += [code, FLOWS[flow], first + len(leaf_iopts)]
            leaf_iopts += list(iopts)
        coeffs = [*self.gammas, *(fraction for _, _, fraction in self.stages)]
        return _steps.COMPOSED, np.array(coeffs, dtype=np.float64), np.array(header + rows + leaf_iopts, dtype=np.int64)


class Programmed:
    """Mixin for methods built on sub-integrators and lowered through ``program()``."""

    def sub_methods(self):
        raise NotImplementedError

    def check_system(self, system):
        """Raise ``ValueError`` if a sub-integrator does not apply to ``system`` (exact flows)."""
        for method in self.sub_methods():
            check_applies(method, system)

    def bind(self, system, x0):
        self.check_system(system)
        return self.lower()

    def lower(self):
        return self.program().lower()


def leaf_data(method):
    """``(leaf code, iopts)`` of a method used as one stage of a program."""
    if hasattr(method, "leaf_code"):
        return method.leaf_code, ()
    code, coeffs, iopts = method.lower()
    if code not in (_steps.RK4, _steps.DISCRETE_GRADIENT) or coeffs.size:
        raise TypeError(
            f"a sub-integrator must be a one-step method (RK4(), Gonzalez(), an exact flow); got {method!r}."
        )
    return code, iopts


def program_of(method):
    """The program of ``method``: its own, or one stage of it on the full field."""
    return method.program() if hasattr(method, "program") else Program(((method, "full", 1.0),))


def check_applies(method, system):
    """Raise ``ValueError`` if ``method`` (or one of its sub-integrators) does not apply to ``system``."""
    if hasattr(method, "check_system"):
        method.check_system(system)


def check_flow(argument, method, flow):
    """Raise ``ValueError`` if ``method`` cannot integrate the sub-flow ``flow``."""
    flows = getattr(method, "flows", _ALL_FLOWS)
    if flow not in flows:
        raise ValueError(f"`{argument}` must integrate the {flow} flow; {method!r} integrates only the {flows[0]} flow.")


def S_rise_statistics(system, method, x0, h, n_steps, ulps=16):
    """Count the sub-steps and full steps of ``method`` that raise S, on ``n_steps`` steps from ``x0``.

    A rise is ``S_new - S_old > ulps * eps * max(|S_old|, |S_new|)``.  Returns a
    dict: ``steps``, ``sub_steps``, ``sub_step_rises``, ``full_step_rises``
    (after the safeguard), ``safeguard_fired`` (full steps redone by the
    monotone safeguard) and ``status``.  Runs compiled, without saving states.
    """
    if not isinstance(system, MetriplecticSystem):
        raise TypeError(f"`system` must be a geomint.MetriplecticSystem; got {type(system).__name__}.")
    check_applies(method, system)
    state = np.array(x0, dtype=np.float64)
    if state.shape != (3,) or not np.all(np.isfinite(state)):
        raise ValueError(f"`x0` must be 3 finite numbers; got {x0!r}.")
    code, coeffs, iopts = program_of(method).lower()
    out = np.zeros(6, dtype=np.int64)
    _comp.rise_statistics[system.form](
        *system.model, system.eps, system.hamiltonian, coeffs, iopts, state, float(h), int(n_steps), float(ulps), out
    )
    keys = ("steps", "sub_steps", "sub_step_rises", "full_step_rises", "safeguard_fired", "status")
    return dict(zip(keys, (int(v) for v in out)))
