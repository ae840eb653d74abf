"""A damped harmonic oscillator with its heat bath: a GENERIC system in R^3 whose (q, p) part has a closed form."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from .._cache import CACHE
from .._validate import real
from ..model.system_n import GenericSystem

if TYPE_CHECKING:
    import numpy.typing as npt

#: params: mass, stiffness, friction, the bath's temperature at s = 0 and its heat capacity
_MASS, _STIFFNESS, _GAMMA, _T0, _C = range(5)


@njit(cache=CACHE)
def _temperature(x, p):
    return p[_T0] * np.exp(x[2] / p[_C])


@njit(cache=CACHE)
def _E(x, p):
    return 0.5 * x[1] * x[1] / p[_MASS] + 0.5 * p[_STIFFNESS] * x[0] * x[0] + p[_C] * _temperature(x, p)


@njit(cache=CACHE)
def _grad_E(x, p):
    return np.array([p[_STIFFNESS] * x[0], x[1] / p[_MASS], _temperature(x, p)])


@njit(cache=CACHE)
def _S(x, p):
    return x[2]


@njit(cache=CACHE)
def _grad_S(x, p):
    return np.array([0.0, 0.0, 1.0])


@njit(cache=CACHE)
def _L(x, p):
    return np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


@njit(cache=CACHE)
def _M(x, p):
    """``gamma T w w^T``, ``w = (0, 1, -p / (m T))``."""
    T = _temperature(x, p)
    w2 = -x[1] / (p[_MASS] * T)
    scale = p[_GAMMA] * T
    return np.array([[0.0, 0.0, 0.0], [0.0, scale, scale * w2], [0.0, scale * w2, scale * w2 * w2]])


def _positive(name, value):
    value = real(name, value)
    if not 0.0 < value < float("inf"):
        raise ValueError(f"`{name}` must be finite and > 0; got {value!r}.")
    return value


def _nonnegative(name, value):
    value = real(name, value)
    if not 0.0 <= value < float("inf"):
        raise ValueError(f"`{name}` must be finite and >= 0; got {value!r}.")
    return value


def heat_bath_oscillator(
    m: float = 1.0, k: float = 1.0, gamma: float = 0.5, T0: float = 1.0, c: float = 1.0
) -> GenericSystem:
    """A harmonic oscillator with friction gamma, its heat going into a bath of entropy s (GENERIC, n = 3).

        x = (q, p, s),   E = p^2 / (2 m) + k q^2 / 2 + U(s),   U(s) = c T0 e^{s / c},   S = s,
        T = U'(s) = T0 e^{s / c} > 0   (a bath of constant heat capacity c),
        L canonical on (q, p),   M = gamma T w w^T,   w = (0, 1, -p / (m T)).

    ``w . grad E = p/m - p/(m T) T = 0``, so ``M grad E = 0``; ``L grad S = 0``.  The field is

        dq/dt = p / m,   dp/dt = -k q - (gamma / m) p,   ds/dt = gamma p^2 / (m^2 T) >= 0,

    so q obeys ``m q'' + gamma q' + k q = 0``: ``q'' = -(k/m) q - (gamma/m) q' = -(k/m) q - (gamma/m^2) p``,
    the linear damped oscillator with rate ``beta = gamma / (2 m)`` and ``omega_0^2 = k / m``
    (``heat_bath_closed_form``), whatever the bath.  ``T ds/dt`` is the power the friction dissipates.

    Reference: H. C. Oettinger, Beyond Equilibrium Thermodynamics (Wiley, 2005), the damped oscillator with a
    heat bath; docs/engine_rn.md, "Reference problems".
    """
    params = [
        _positive("m", m),
        _positive("k", k),
        _nonnegative("gamma", gamma),
        _positive("T0", T0),
        _positive("c", c),
    ]
    return GenericSystem(
        E=_E,
        grad_E=_grad_E,
        S=_S,
        grad_S=_grad_S,
        L=_L,
        M=_M,
        params=params,
        dim=3,
        name="heat_bath_oscillator",
        variables=("q", "p", "s"),
    )


def heat_bath_closed_form(
    t: npt.ArrayLike,
    q0: float,
    p0: float,
    m: float = 1.0,
    k: float = 1.0,
    gamma: float = 0.5,
    s0: float | None = None,
    T0: float = 1.0,
    c: float = 1.0,
) -> npt.NDArray[np.float64]:
    """The exact solution of ``heat_bath_oscillator(m, k, gamma, T0, c)`` from ``(q0, p0[, s0])`` at the times t.

    ``m q'' + gamma q' + k q = 0``, ``beta = gamma / (2 m)``, ``omega^2 = k / m - beta^2``, ``v0 = p0 / m``::

        q(t) = e^{-beta t} (q0 C(t) + (v0 + beta q0) Sn(t)),
        p(t) = m e^{-beta t} (v0 C(t) - (beta v0 + (k/m) q0) Sn(t)),

    with ``C = cos(omega t)``, ``Sn = sin(omega t) / omega`` (underdamped), ``cosh`` and ``sinh(mu t) / mu``,
    ``mu^2 = -omega^2`` (overdamped), ``1`` and ``t`` (critical).  With ``s0`` the entropy follows from the
    conserved energy, ``s = c ln(U / (c T0))``, ``U = E0 - p^2 / (2 m) - k q^2 / 2``.

    Returns an array (len(t), 2) of (q, p), or (len(t), 3) of (q, p, s) when ``s0`` is given; a scalar t gives
    one row, shape (2,) or (3,).
    """
    m, k, gamma = _positive("m", m), _positive("k", k), _nonnegative("gamma", gamma)
    q0, p0 = real("q0", q0), real("p0", p0)
    times = np.asarray(t, dtype=np.float64)
    if times.ndim > 1 or not np.all(np.isfinite(times)):
        raise ValueError(f"`t` must be a finite number or 1-D array of them; got shape {times.shape}.")
    tt = np.atleast_1d(times)
    beta, v0 = gamma / (2.0 * m), p0 / m
    omega2 = k / m - beta * beta
    decay = np.exp(-beta * tt)
    if omega2 > 0.0:
        omega = np.sqrt(omega2)
        C, Sn = decay * np.cos(omega * tt), decay * np.sin(omega * tt) / omega
    elif omega2 < 0.0:  # e^{-beta t} cosh(mu t) and sinh, as exponentials that do not overflow (mu < beta)
        mu = np.sqrt(-omega2)
        slow, fast = np.exp((mu - beta) * tt), np.exp(-(mu + beta) * tt)
        C, Sn = 0.5 * (slow + fast), 0.5 * (slow - fast) / mu
    else:
        C, Sn = decay, decay * tt
    q = q0 * C + (v0 + beta * q0) * Sn  # C and Sn carry the factor e^{-beta t}
    p = m * (v0 * C - (beta * v0 + (k / m) * q0) * Sn)
    columns = [q, p]
    if s0 is not None:
        s0, T0, c = real("s0", s0), _positive("T0", T0), _positive("c", c)
        E0 = 0.5 * p0 * p0 / m + 0.5 * k * q0 * q0 + c * T0 * np.exp(s0 / c)
        U = E0 - 0.5 * p * p / m - 0.5 * k * q * q
        columns.append(c * np.log(U / (c * T0)))
    out = np.stack(columns, axis=1)
    return out[0] if times.ndim == 0 else out
