"""The dissipative oscillator (paper section 2.2)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from numba import njit

from .._cache import CACHE
from .._validate import reals
from ..model.system import MetriplecticSystem

if TYPE_CHECKING:
    import numpy.typing as npt


@njit(cache=CACHE)
def _H(x, p):
    return 0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2])


@njit(cache=CACHE)
def _grad_H(x, p):
    return (x[0], x[1], x[2])


@njit(cache=CACHE)
def _S(x, p):
    """``S(z) = sum_k p[k] z^k`` by Horner's rule."""
    z = x[2]
    value = 0.0
    for k in range(p.shape[0] - 1, -1, -1):
        value = value * z + p[k]
    return value


@njit(cache=CACHE)
def _grad_S(x, p):
    z = x[2]
    slope = 0.0
    for k in range(p.shape[0] - 1, 0, -1):
        slope = slope * z + k * p[k]
    return (0.0, 0.0, slope)


@njit(cache=CACHE)
def _J(x, p):
    return (0.0, 0.0, 1.0)


def dissipative_oscillator(
    coefficients: npt.ArrayLike = (0.0, 0.0, 1.0),
    eps: float = 1.0,
) -> MetriplecticSystem:
    """The harmonic oscillator in (x, y), lifted to R^3 and perturbed (paper section 2.2).

        H = |x|^2 / 2,   J = (0, 0, 1),   S = S(z) = sum_k coefficients[k] z^k,

        dx/dt = y + eps x z S'(z),  dy/dt = -x + eps y z S'(z),  dz/dt = -eps (x^2 + y^2) S'(z).

    The default ``S = z^2`` is the paper's example: the equators of the spheres
    H = const are attracting cycles and the poles unstable equilibria.
    ``coefficients = (0, 0, 0.5)`` gives S = z^2/2 and ``(0, 1)`` gives S = z
    (problem R5 of docs/references.md); ``(0,)`` gives S = 0, the unperturbed oscillator.
    """
    coefficients = reals("coefficients", coefficients)
    if coefficients.size == 0:
        raise ValueError(f"`coefficients` must be a non-empty 1-D sequence; got {coefficients.tolist()!r}.")
    return MetriplecticSystem(
        H=_H,
        grad_H=_grad_H,
        S=_S,
        grad_S=_grad_S,
        J=_J,
        eps=eps,
        params=coefficients,
        name="dissipative_oscillator",
        exact_flows={"oscillator_rotation": ()},
    )
