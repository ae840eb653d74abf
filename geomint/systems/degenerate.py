"""A Poisson tensor that vanishes on a plane (paper section 2.3)."""

import numbers

from numba import njit

from .._cache import CACHE
from ..model.system import MetriplecticSystem


@njit(cache=CACHE)
def _H(x, p):
    y = x[1] - p[0]
    return 0.5 * (x[0] * x[0] + y * y + x[2] * x[2])


@njit(cache=CACHE)
def _grad_H(x, p):
    return (x[0], x[1] - p[0], x[2])


@njit(cache=CACHE)
def _S(x, p):
    return 0.5 * x[2] * x[2]


@njit(cache=CACHE)
def _grad_S(x, p):
    return (0.0, 0.0, x[2])


@njit(cache=CACHE)
def _J(x, p):
    return (0.0, 0.0, x[1])


_SHIFTS = {1: 0.0, 2: 1.0}


def degenerate_example(number: int = 1, eps: float = 1.0) -> MetriplecticSystem:
    """The paper's Examples 1 and 2: ``J = (0, 0, y)``, so ``P = 0`` on the plane y = 0.

    Example 1: ``H = (x^2 + y^2 + z^2) / 2``; Example 2: ``H = (x^2 + (y-1)^2 + z^2) / 2``;
    both with ``S = z^2 / 2``.  On y = 0 the field reduces to ``g grad S``.  In
    Example 1 the great circle ``{y = 0} n {H = H0}`` is invariant and flows to
    ``(+-r0, 0, 0)``; in Example 2 it is invariant only at z = 0.
    """
    if isinstance(number, bool) or not isinstance(number, numbers.Integral) or number not in _SHIFTS:
        raise ValueError(f"`number` must be 1 or 2 (the paper's Examples 1 and 2); got {number!r}.")
    return MetriplecticSystem(
        H=_H,
        grad_H=_grad_H,
        S=_S,
        grad_S=_grad_S,
        J=_J,
        eps=eps,
        params=[_SHIFTS[number]],
        name=f"degenerate_example_{number}",
    )
