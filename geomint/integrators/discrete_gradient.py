"""Discrete-gradient integrators: exact energy, monotone Casimir.

Every method here is the one metriplectic step

    x' = x + h [ dgH x Jbar + eps dgH x (dgH x dgS) ],   Jbar = (J(xbar) . n) n,  n = dgS / |dgS|,

(``H(x') = H(x)``, ``S(x') - S(x) = -h eps |dgH x dgS|^2 <= 0``) with a
different discrete gradient ``dg``; one compiled Newton loop
(``geomint._kernels.dg_step.discrete_gradient_step``) serves all of them, and a
run compiles only the discrete gradient it uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .._kernels import discrete_field as _discrete_field
from .._kernels import layout
from .base import Integrator, Traits

if TYPE_CHECKING:
    import numpy.typing as npt

    from .base import StageData


@dataclass(frozen=True)
class DiscreteGradient(Integrator):
    """The metriplectic discrete-gradient step; subclasses choose the discrete gradient (``kind``).

    Parameters
    ----------
    max_newton_iter : int, default 50
        Newton iterations allowed per step before the run stops with
        ``status = -1``.
    compensated : bool, default True
        Add the increments with compensated (Kahan) summation, so the energy
        error stays at a few ulp instead of growing like a random walk with
        the number of steps.  ``False`` only to measure what it buys.
    """

    max_newton_iter: int = 50
    compensated: bool = True

    kind: ClassVar[int]
    damped: ClassVar[bool] = False

    def __post_init__(self) -> None:
        if (
            isinstance(self.max_newton_iter, bool)
            or not isinstance(self.max_newton_iter, int)
            or not 1 <= self.max_newton_iter <= 10**6
        ):
            raise ValueError(f"`max_newton_iter` must be an integer in [1, 10**6]; got {self.max_newton_iter!r}.")
        if not isinstance(self.compensated, bool):
            raise TypeError(f"`compensated` must be True or False; got {self.compensated!r}.")

    def _coeffs(self):
        return np.empty(0)

    def stage(self, system: Any) -> StageData:
        return (
            layout.LEAF_DISCRETE_GRADIENT,
            self.kind,
            self.max_newton_iter,
            self.damped,
            self.compensated,
            self._coeffs(),
        )

    def error_estimate(self) -> tuple[int, float]:
        """Against the explicit RK4 step from the same state (``layout.RK4_REFERENCE``); damped methods,
        made for stiff relaxation where an explicit reference is unstable, by step doubling."""
        return (layout.DOUBLING if self.damped else layout.RK4_REFERENCE), self.order

    def lower(self, system: Any) -> layout.DiscreteGradientStep:
        return layout.DiscreteGradientStep(
            layout.KIND_MARKERS[self.kind](self.kind),
            self.max_newton_iter,
            layout.Damped(True) if self.damped else layout.Undamped(False),
            self.compensated,
            self._coeffs(),
        )

    def discrete_gradients(
        self,
        system: Any,
        x: npt.ArrayLike,
        x_new: npt.ArrayLike,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """``(dgH, dgS, Jbar)`` at the pair of states ``(x, x_new)``, as the step uses them.

        ``dgH . (x_new - x) = H(x_new) - H(x)`` to round-off (likewise for S),
        and ``Jbar`` is parallel to ``dgS``.
        """
        out = np.empty((3, 3))
        pair = [np.ascontiguousarray(v, dtype=np.float64) for v in (x, x_new)]
        _discrete_field.evaluate(system.model, layout.KIND_MARKERS[self.kind](self.kind), self._coeffs(), *pair, out)  # pyright: ignore[reportCallIssue]
        return out[0], out[1], out[2]


@dataclass(frozen=True)
class Gonzalez(DiscreteGradient):
    """The metriplectic step with Gonzalez's discrete gradient.

        dgF(x, x') = grad F(xbar) + [F(x') - F(x) - grad F(xbar) . dx] / |dx|^2 dx,  xbar = (x + x') / 2.

    Symmetric, order 2.  Reference: O. Gonzalez, Time integration and discrete
    Hamiltonian systems, J. Nonlinear Sci. 6 (1996) 449-467,
    doi:10.1007/BF02440162; for the metriplectic form, docs/design.md section 2.
    Not L-stable: with ``h eps`` large it reflects the fast dissipative modes
    (docs/hard_cases.md); use ``DampedGonzalez`` there.
    """

    name: ClassVar[str] = "gonzalez"
    traits: ClassVar[Traits] = Traits(order=2, energy_exact=True, dissipative=True, symmetric=True, implicit=True)
    kind: ClassVar[int] = layout.GONZALEZ


@dataclass(frozen=True)
class DampedGonzalez(DiscreteGradient):
    """Gonzalez's step with the dissipation scaled for stiff problems.

        x' = x + h [ dgH x Jbar + eps phi dgH x (dgH x dgS) ],
        phi = 1 / sqrt(1 + (h kappa / 2)^2),   kappa = eps |D xi_g(x)|_inf.

    Still exact in H and monotone in S (any ``phi > 0``), and ``phi = 1 + O(h^2)``
    keeps order 2; ``phi`` is evaluated at ``x``, so the method is not symmetric.
    Why it is needed: for every step of the discrete-gradient form,
    ``dgH . dx = 0`` forces ``|dgH x dgS| >= |dgH| |dS| / |dx|``, hence
    ``|dS| <= |dx|^2 / (h eps |dgH|^2)``: near the attractor a step can remove
    only a fraction ~ 1/(h eps) of ``S - S_inf`` and the midpoint-type methods
    stall when ``h eps >> 1`` (docs/hard_cases.md).  With ``phi`` the stiff
    modes are damped by ``(1 - w) / (1 + w)``, ``w -> 1``, as in an L-stable method;
    slow modes are slowed by ``phi`` (an O(h^2) error while ``h kappa`` is small).
    Costs 4 more gradient evaluations per step.
    """

    name: ClassVar[str] = "damped_gonzalez"
    traits: ClassVar[Traits] = Traits(order=2, energy_exact=True, dissipative=True, symmetric=False, implicit=True)
    kind: ClassVar[int] = layout.GONZALEZ
    damped: ClassVar[bool] = True


@dataclass(frozen=True)
class ItohAbe(DiscreteGradient):
    """The metriplectic step with Itoh and Abe's coordinate-increment discrete gradient.

        dgF_i = [F(x'_1..x'_i, x_{i+1}..x_3) - F(x'_1..x'_{i-1}, x_i..x_3)] / (x'_i - x_i).

    Order 1, not symmetric (for H and S that are sums of functions of one
    coordinate each it is symmetric, hence order 2).  A coordinate that does not move (0/0) or moves
    less than ``SWITCH |x|`` takes the partial derivative at the midpoint of its
    edge (``geomint._kernels.discrete_gradient``).  Reference: T. Itoh, K. Abe,
    Hamiltonian-conserving discrete canonical equations based on variational
    difference quotients, J. Comput. Phys. 76 (1988) 85-102,
    doi:10.1016/0021-9991(88)90132-5.
    """

    name: ClassVar[str] = "itoh_abe"
    traits: ClassVar[Traits] = Traits(order=1, energy_exact=True, dissipative=True, symmetric=False, implicit=True)
    kind: ClassVar[int] = layout.ITOH_ABE


@dataclass(frozen=True)
class SymmetrizedItohAbe(DiscreteGradient):
    """Itoh-Abe's discrete gradient averaged over the 6 orderings of the coordinates.

    Symmetric (``dg(x, x') = dg(x', x)``), order 2; F at the 8 corners of the
    box spanned by x and x'.  Reference: R. I. McLachlan, G. R. W. Quispel,
    N. Robidoux, Geometric integration using discrete gradients, Phil. Trans.
    R. Soc. A 357 (1999) 1021-1045, doi:10.1098/rsta.1999.0363.
    """

    name: ClassVar[str] = "symmetrized_itoh_abe"
    traits: ClassVar[Traits] = Traits(order=2, energy_exact=True, dissipative=True, symmetric=True, implicit=True)
    kind: ClassVar[int] = layout.SYMMETRIZED_ITOH_ABE


@dataclass(frozen=True)
class AVF(DiscreteGradient):
    """The metriplectic step with the average-vector-field discrete gradient.

        dgF = int_0^1 grad F(x + s dx) ds  ~  sum_k w_k grad F(x + s_k dx)   (Gauss-Legendre on [0, 1]),

    projected onto the discrete-gradient condition as in Gonzalez's formula, so
    H and S are exact for every F; the projection changes nothing (to
    round-off) when the rule is exact, i.e. for polynomial H and S of degree
    ``<= 2 nodes``.  Symmetric, order 2.  Reference: G. R. W. Quispel,
    D. I. McLaren, A new class of integral preserving methods, J. Phys. A 41
    (2008) 045206, doi:10.1088/1751-8113/41/4/045206.

    Parameters
    ----------
    nodes : int or None
        Gauss-Legendre nodes, 1 to 16.  ``None``: chosen from ``degree``.
    degree : int or None
        Largest polynomial degree of H and S; ``nodes = ceil(degree / 2)``
        integrates their gradients exactly.  With both ``None``, 3 nodes
        (exact up to degree 6).
    """

    nodes: int | None = None
    degree: int | None = None

    name: ClassVar[str] = "avf"
    traits: ClassVar[Traits] = Traits(order=2, energy_exact=True, dissipative=True, symmetric=True, implicit=True)
    kind: ClassVar[int] = layout.AVF

    def __post_init__(self) -> None:
        super().__post_init__()
        for arg, value, low, high in (("nodes", self.nodes, 1, 16), ("degree", self.degree, 1, 32)):
            if value is not None and (
                isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high
            ):
                raise ValueError(f"`{arg}` must be None or an integer in [{low}, {high}]; got {value!r}.")
        if self.nodes is not None and self.degree is not None and 2 * self.nodes < self.degree:
            raise ValueError(
                f"`nodes` = {self.nodes} is not exact for `degree` = {self.degree}; "
                f"give one of them, or nodes >= {math.ceil(self.degree / 2)}."
            )

    @property
    def n_nodes(self) -> int:
        """The number of Gauss-Legendre nodes used."""
        if self.nodes is not None:
            return self.nodes
        return 3 if self.degree is None else max(1, math.ceil(self.degree / 2))

    def _coeffs(self):
        t, w = np.polynomial.legendre.leggauss(self.n_nodes)
        return np.concatenate([0.5 * (1.0 + t), 0.5 * w])
