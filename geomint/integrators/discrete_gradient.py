"""Discrete-gradient integrators: exact energy, monotone Casimir."""

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .._kernels import discrete_gradient as _dg
from .._kernels import steps as _steps
from .base import Integrator


@dataclass(frozen=True)
class Gonzalez(Integrator):
    """The metriplectic discrete-gradient step with Gonzalez's discrete gradient.

        x' = x + h [ dgH x Jbar + eps dgH x (dgH x dgS) ],
        dgF(x, x') = grad F(xbar) + [F(x') - F(x) - grad F(xbar) . dx] / |dx|^2 dx,
        Jbar = (J(xbar) . n) n,  n = dgS / |dgS|,  xbar = (x + x') / 2,

    so that ``H(x') = H(x)`` and ``S(x') - S(x) = -h eps |dgH x dgS|^2 <= 0``.
    Symmetric, order 2.  The implicit equation is solved by Newton's method to
    round-off (see ``geomint._kernels.steps.discrete_gradient_step``).

    Reference: O. Gonzalez, Time integration and discrete Hamiltonian systems,
    J. Nonlinear Sci. 6 (1996) 449-467, doi:10.1007/BF02440162; for the
    metriplectic form, DESIGN.md section 2.

    Parameters
    ----------
    max_newton_iter : int, default 50
        Newton iterations allowed per step before the run stops with
        ``status = -1``.
    """

    max_newton_iter: int = 50

    name: ClassVar[str] = "gonzalez"
    order: ClassVar[int] = 2
    energy_exact: ClassVar[bool] = True
    dissipative: ClassVar[bool] = True
    symmetric: ClassVar[bool] = True
    implicit: ClassVar[bool] = True

    def __post_init__(self):
        if not isinstance(self.max_newton_iter, int) or self.max_newton_iter < 1:
            raise ValueError(f"`max_newton_iter` must be an integer >= 1; got {self.max_newton_iter!r}.")

    kind: ClassVar[int] = _dg.GONZALEZ

    def lower(self):
        return self._data(_steps.DISCRETE_GRADIENT, iopts=(self.kind, self.max_newton_iter))

    def discrete_gradients(self, system, x, x_new):
        """``(dgH, dgS, Jbar)`` at the pair of states ``(x, x_new)``, as the step uses them.

        ``dgH . (x_new - x) = H(x_new) - H(x)`` to round-off (likewise for S),
        and ``Jbar`` is parallel to ``dgS``.
        """
        out = np.empty((3, 3))
        pair = [np.ascontiguousarray(v, dtype=np.float64) for v in (x, x_new)]
        _dg.evaluate[system.form](*system.model, self.kind, *pair, out)
        return out[0], out[1], out[2]
