"""Two gas containers with a moving, heat-conducting wall: a GENERIC system in R^4.

A reference problem of docs/engine_rn.md.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._cache import CACHE
from .._validate import real
from ..model.system_n import GenericSystem

#: the checks' samples: q in [0.3, 1.7] (the domain is 0 < q < 2), p, S_1, S_2 in [-1, 1]
SAMPLES = np.random.default_rng(20261123).uniform([0.3, -1.0, -1.0, -1.0], [1.7, 1.0, 1.0, 1.0], size=(6, 4))


@njit(cache=CACHE)
def _energies(x):
    """The internal energies ``U_1 = (e^{S_1} / q)^{2/3}``, ``U_2 = (e^{S_2} / (2 - q))^{2/3}``; NaN outside
    0 < q < 2."""
    q = x[0]
    return np.exp((2.0 / 3.0) * (x[2] - np.log(q))), np.exp((2.0 / 3.0) * (x[3] - np.log(2.0 - q)))


@njit(cache=CACHE)
def _E(x, p):
    U1, U2 = _energies(x)
    return 0.5 * x[1] * x[1] + U1 + U2


@njit(cache=CACHE)
def _grad_E(x, p):
    """``(-T_1 / q + T_2 / (2 - q), p, T_1, T_2)``, ``T_i = dE / dS_i = (2/3) U_i``; ``T_i / V_i`` the pressures."""
    U1, U2 = _energies(x)
    T1, T2 = (2.0 / 3.0) * U1, (2.0 / 3.0) * U2
    q = x[0]
    return np.array([-T1 / q + T2 / (2.0 - q), x[1], T1, T2])


@njit(cache=CACHE)
def _S(x, p):
    return x[2] + x[3]


@njit(cache=CACHE)
def _grad_S(x, p):
    return np.array([0.0, 0.0, 1.0, 1.0])


@njit(cache=CACHE)
def _L(x, p):
    out = np.zeros((4, 4))
    out[0, 1] = 1.0
    out[1, 0] = -1.0
    return out


@njit(cache=CACHE)
def _M(x, p):
    """``gamma w w^T`` on (S_1, S_2), ``w = (1 / T_1, -1 / T_2)``."""
    U1, U2 = _energies(x)
    w1, w2 = 1.5 / U1, -1.5 / U2
    gamma = p[0]
    out = np.zeros((4, 4))
    out[2, 2] = gamma * w1 * w1
    out[2, 3] = gamma * w1 * w2
    out[3, 2] = gamma * w1 * w2
    out[3, 3] = gamma * w2 * w2
    return out


def gas_containers(gamma: float = 1.0) -> GenericSystem:
    """Two ideal gases in a box of length 2, parted by a wall at q of momentum p that moves and conducts heat.

        x = (q, p, S_1, S_2),   E = p^2 / 2 + (e^{S_1} / q)^{2/3} + (e^{S_2} / (2 - q))^{2/3},   S = S_1 + S_2,
        T_i = dE / dS_i,   L canonical on (q, p),
        M = gamma [[T_1^-2, -(T_1 T_2)^-1], [-(T_1 T_2)^-1, T_2^-2]] on (S_1, S_2) = gamma w w^T,  w = (1/T_1, -1/T_2).

    ``M grad E = gamma w (w . (T_1, T_2)) = 0`` exactly, as the reference problem states M, and
    ``dS/dt = gamma (1/T_1 - 1/T_2)^2 >= 0``: heat flows from the hotter gas to
    the colder.  The wall obeys ``dp/dt = T_1 / q - T_2 / (2 - q)`` (the pressure
    difference, ``U_i = (3/2) T_i`` for a monatomic gas).  Defined for 0 < q < 2:
    the structure checks use samples with q in [0.3, 1.7].

    The limit: entropy production vanishes only where ``T_1 = T_2``, and the wall
    at rest needs equal pressures ``T_1 / q = T_2 / (2 - q)``, so ``q = 1``, ``p = 0``
    and ``S_1 = S_2 = sigma`` with ``E_0 = 2 e^{2 sigma / 3}``:
    ``S_inf = 2 sigma = 3 ln(E_0 / 2)`` (``gas_containers_limit``).  Motion of the wall
    compresses the gases adiabatically and unequally, so it produces entropy until it stops.

    Reference: H. C. Oettinger, Beyond Equilibrium Thermodynamics (Wiley, 2005); X. Shang and
    H. C. Oettinger, Proc. R. Soc. A 476 (2020) 20190446; docs/engine_rn.md, "Reference problems".
    """
    gamma = real("gamma", gamma)
    if not 0.0 <= gamma < float("inf"):
        raise ValueError(f"`gamma` must be finite and >= 0; got {gamma!r}.")
    return GenericSystem(
        E=_E,
        grad_E=_grad_E,
        S=_S,
        grad_S=_grad_S,
        L=_L,
        M=_M,
        params=[gamma],
        dim=4,
        name="gas_containers",
        samples=SAMPLES,
        variables=("q", "p", "S1", "S2"),
    )


def gas_containers_limit(E0: float) -> np.ndarray:
    """The state the gas containers relax to from energy ``E0 > 0``: ``(1, 0, S_inf / 2, S_inf / 2)`` with
    ``S_inf = 3 ln(E0 / 2)`` (equal temperatures and pressures, the wall at rest in the middle)."""
    E0 = real("E0", E0)
    if not 0.0 < E0 < float("inf"):
        raise ValueError(f"`E0` must be finite and > 0; got {E0!r}.")
    half = 1.5 * np.log(E0 / 2.0)
    return np.array([1.0, 0.0, half, half])
