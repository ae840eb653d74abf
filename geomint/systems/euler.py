"""Selective decay of 2-D Euler in the Fish form: Zeitlin's sine-bracket and the Fourier-Galerkin truncations.

The vorticity on the torus [0, 2 pi)^2, ``omega(theta) = sum_k omega_k e^{i k . theta}`` (``omega_{-k}`` the
conjugate of ``omega_k``), truncated to ``k`` in ``Z_N^2 \\ {0}`` (N odd), components in ``[-(N-1)/2, (N-1)/2]``.
The state ``x`` holds the real and imaginary parts of ``omega_k`` over the half modes (``k_1 > 0``, or
``k_1 = 0 < k_2``), ordered by ``k_1`` then ``k_2``, interleaved ``(Re, Im)``: ``n = N^2 - 1`` coordinates,
named ``re_k1_k2`` and ``im_k1_k2`` (``euler_variables``).

References: V. Zeitlin, Physica D 49 (1991) 353 (the sine bracket); the selective decay of a metriplectic
bracket, Morrison, Physica D 18 (1986) 410; docs/engine_rn.md, "Reference problems".
"""

from __future__ import annotations

import numbers
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from .._cache import CACHE
from ..model.system_n import MetriplecticSystemN

if TYPE_CHECKING:
    import numpy.typing as npt

#: params[0]: which bracket; then the tables of P (``_tables``), ``_PAIR`` numbers per ordered pair of half modes
ZEITLIN, GALERKIN = 0.0, 1.0
_TABLES, _PAIR = 1, 6


@njit(cache=CACHE)
def _size(x):
    """N from ``n = N^2 - 1``, and the largest component M = (N - 1) / 2."""
    N = int(np.round(np.sqrt(x.shape[0] + 1.0)))
    return N, (N - 1) // 2


@njit(cache=CACHE)
def _index(k1, k2, M):
    """The position of the half mode (k1, k2) among the half modes, or -1 if (k1, k2) is not one."""
    if k1 == 0:
        return k2 - 1 if 0 < k2 <= M else -1
    if 0 < k1 <= M and -M <= k2 <= M:
        return M + (k1 - 1) * (2 * M + 1) + (k2 + M)
    return -1


@njit(cache=CACHE)
def _wrap(m, N, M):
    """``m`` modulo N in [-M, M] (N = 2 M + 1): the residue of -m is minus that of m."""
    r = m % N
    return r - N if r > M else r


@njit(cache=CACHE)
def _half(m1, m2, N, M, galerkin):
    """Where ``omega_m`` is held, for any m: ``(i, sign)`` with ``omega_m = x[2 i] + sign * 1j * x[2 i + 1]``, or
    ``(-1, 0.0)`` for no coefficient (m = 0, or outside the box for Galerkin); m wrapped modulo N for Zeitlin."""
    if galerkin:
        if abs(m1) > M or abs(m2) > M:
            return -1, 0.0
    else:
        m1, m2 = _wrap(m1, N, M), _wrap(m2, N, M)
    i = _index(m1, m2, M)
    if i >= 0:
        return i, 1.0
    i = _index(-m1, -m2, M)
    if i >= 0:
        return i, -1.0
    return -1, 0.0  # m = 0


@njit(cache=CACHE)
def _H(x, p):
    N, M = _size(x)
    value = 0.0
    i = 0
    for k1 in range(0, M + 1):
        for k2 in range(-M, M + 1):
            if k1 == 0 and k2 <= 0:
                continue
            value += (x[2 * i] * x[2 * i] + x[2 * i + 1] * x[2 * i + 1]) / (k1 * k1 + k2 * k2)
            i += 1
    return value


@njit(cache=CACHE)
def _grad_H(x, p):
    N, M = _size(x)
    out = np.empty(x.shape[0])
    i = 0
    for k1 in range(0, M + 1):
        for k2 in range(-M, M + 1):
            if k1 == 0 and k2 <= 0:
                continue
            inverse = 2.0 / (k1 * k1 + k2 * k2)
            out[2 * i] = inverse * x[2 * i]
            out[2 * i + 1] = inverse * x[2 * i + 1]
            i += 1
    return out


@njit(cache=CACHE)
def _S(x, p):
    return np.sum(x * x)


@njit(cache=CACHE)
def _grad_S(x, p):
    return 2.0 * x


@njit(cache=CACHE)
def _modes(M):
    """The half modes in their order, as an (h, 2) integer array."""
    h = M + M * (2 * M + 1)
    out = np.empty((h, 2), dtype=np.int64)
    i = 0
    for k1 in range(0, M + 1):
        for k2 in range(-M, M + 1):
            if k1 == 0 and k2 <= 0:
                continue
            out[i, 0], out[i, 1] = k1, k2
            i += 1
    return out


@njit(cache=CACHE)
def _tables(N, galerkin):
    """The structure of P, once per system: for each ordered pair (k, p) of half modes, ``_PAIR`` numbers (row-major
    over (k, p), the diagonal pairs unused): where ``omega_{k-p}`` is held and the sign of its imaginary part
    (``_half``), ``c_1 = c(p, k - p)``; the same for ``omega_{k+p}``, ``c_2 = c(-p, k + p)``."""
    M = (N - 1) // 2
    modes = _modes(M)
    h = modes.shape[0]
    sines = np.empty(N)  # (N / 2 pi) sin(2 pi r / N) at r + M, odd in r exactly
    for r in range(0, M + 1):
        s = N / (2.0 * np.pi) * np.sin(2.0 * np.pi * r / N)
        sines[M + r], sines[M - r] = s, -s
    out = np.zeros((h, h, _PAIR))
    for i in range(h):
        k1, k2 = modes[i, 0], modes[i, 1]
        for j in range(h):
            if i == j:
                continue
            p1, p2 = modes[j, 0], modes[j, 1]
            cross1 = p1 * (k2 - p2) - p2 * (k1 - p1)  # p x (k - p) = p x k
            cross2 = -p1 * (k2 + p2) + p2 * (k1 + p1)  # (-p) x (k + p) = -(p x k)
            if galerkin:
                c1, c2 = float(cross1), float(cross2)
            else:
                c1, c2 = sines[M + _wrap(cross1, N, M)], sines[M + _wrap(cross2, N, M)]
            at1, sign1 = _half(k1 - p1, k2 - p2, N, M, galerkin)
            at2, sign2 = _half(k1 + p1, k2 + p2, N, M, galerkin)
            out[i, j, 0], out[i, j, 1], out[i, j, 2] = at1, sign1, c1
            out[i, j, 3], out[i, j, 4], out[i, j, 5] = at2, sign2, c2
    return out.reshape(h * h * _PAIR)


@njit(cache=CACHE)
def _held(x, at, sign):
    """``(Re, Im)`` of the coefficient a table entry points to (``_half``)."""
    if at < 0:
        return 0.0, 0.0
    i = int(at)
    return x[2 * i], sign * x[2 * i + 1]


@njit(cache=CACHE)
def _P(x, p):
    """The Lie-Poisson matrix: ``P(x) grad F = (1/2) B(grad F, omega)`` in these coordinates, where
    ``B(v, omega)_k = sum_{p + q = k} c(p, q) psi_p omega_q`` with ``psi_p`` the half-mode coordinates of v.
    Block (k, p) from ``omega_{k-p}`` (``c_1 = c(p, k - p)``) and ``omega_{k+p}`` (``c_2 = c(-p, k + p)``), read
    through the tables ``params[_TABLES:]`` (``_tables``): O(n^2)."""
    n = x.shape[0]
    h = n // 2
    out = np.zeros((n, n))
    for i in range(h):
        for j in range(h):
            if i == j:
                continue
            t = _TABLES + (i * h + j) * _PAIR
            a1, b1 = _held(x, p[t], p[t + 1])
            a2, b2 = _held(x, p[t + 3], p[t + 4])
            c1, c2 = p[t + 2], p[t + 5]
            out[2 * i, 2 * j] = 0.5 * (c1 * a1 + c2 * a2)
            out[2 * i, 2 * j + 1] = 0.5 * (c2 * b2 - c1 * b1)
            out[2 * i + 1, 2 * j] = 0.5 * (c1 * b1 + c2 * b2)
            out[2 * i + 1, 2 * j + 1] = 0.5 * (c1 * a1 - c2 * a2)
    return out


def _check_N(N):
    if isinstance(N, bool) or not isinstance(N, numbers.Integral) or N < 3 or N % 2 == 0:
        raise ValueError(f"`N` must be an odd integer >= 3 (the modes Z_N^2 without 0); got {N!r}.")
    return int(N)


def _euler(N, eps, kind, label):
    N = _check_N(N)
    return MetriplecticSystemN(
        H=_H,
        grad_H=_grad_H,
        S=_S,
        grad_S=_grad_S,
        P=_P,
        eps=eps,
        params=np.concatenate([[kind], _tables(N, kind == GALERKIN)]),
        dim=N * N - 1,
        name=f"euler_{label}_N{N}",
        variables=euler_variables(N),
    )


_FORMULAS = """
        d omega_k / dt = sum_{p + q = k} c(p, q) psi_p omega_q,   psi_p = omega_p / |p|^2,
        H = sum_half |omega_k|^2 / |k|^2,   S = sum_half |omega_k|^2   (the enstrophy, a Casimir),

    written ``dx/dt = P(x) grad H + eps g grad S`` with the paper's metric g.  P is the
    (n, n) matrix with ``P(x) grad F = (1/2) B(grad F, omega)`` (``grad H / 2`` holds psi
    over the half modes): linear in x, skew, ``P grad S = 0``.  Zeitlin's c are the
    structure constants of a Lie algebra (su(N)), so his P satisfies Jacobi; the
    Galerkin truncation's does not.

    The dissipative part lowers S at fixed H: the flow relaxes to the lowest shell
    |k|^2 = 1, where ``S = H``, so ``S_inf = H_0``.  With ``grad H . grad S = 4 H`` and
    ``|grad H|^2 = 4 K``, ``K = sum_half |omega_k|^2 / |k|^4``, the dissipative part alone is
    ``d omega_k / dt = 8 eps (H / |k|^2 - K) omega_k``: near the end (K close to H), ``S - S_inf``
    decays at the rate ``8 eps H_0`` of the shell |k|^2 = 2.  ``n = N^2 - 1`` (24, 48, 80,
    288, 1088 for N = 5, 7, 9, 17, 33); ``euler_initial_state`` gives the reference data.
"""


def euler_zeitlin(N: int = 5, eps: float = 1.0) -> MetriplecticSystemN:
    """2-D Euler selective decay, Zeitlin's sine-bracket truncation on ``Z_N^2 \\ {0}`` (N odd), in the Fish form.

    c(p, q) = (N / 2 pi) sin(2 pi (p x q) / N),   p x q = p_1 q_2 - p_2 q_1,   indices modulo N,
    """
    return _euler(N, eps, ZEITLIN, "zeitlin")


def euler_galerkin(N: int = 5, eps: float = 1.0) -> MetriplecticSystemN:
    """2-D Euler selective decay, the Fourier-Galerkin truncation ``|k|_inf <= (N - 1) / 2`` (N odd), in the Fish form.

    c(p, q) = p x q = p_1 q_2 - p_2 q_1,   modes outside the box dropped,
    """
    return _euler(N, eps, GALERKIN, "galerkin")


# the formulas both share, at the docstrings' indentation (4 spaces, the first formula line 8)
euler_zeitlin.__doc__ = (euler_zeitlin.__doc__ or "").rstrip() + _FORMULAS
euler_galerkin.__doc__ = (euler_galerkin.__doc__ or "").rstrip() + _FORMULAS


def euler_modes(N: int) -> npt.NDArray[np.int64]:
    """The half modes ``(k_1, k_2)`` of the N x N truncation in the order of the coordinates, shape (n / 2, 2):
    ``x[2 i]`` and ``x[2 i + 1]`` are the real and imaginary parts of ``omega_k``, ``k = euler_modes(N)[i]``."""
    return _modes((_check_N(N) - 1) // 2)


def euler_variables(N: int) -> tuple[str, ...]:
    """The names of the coordinates of the N x N truncation (``system.variables``): ``re_k1_k2`` and ``im_k1_k2``,
    the real and imaginary parts of ``omega_k``, ``k = (k1, k2)`` in the order of ``euler_modes``, a negative
    component written ``m`` and its size (``re_1_m2`` for ``k = (1, -2)``)."""

    def part(k):
        return f"m{-k}" if k < 0 else str(k)

    return tuple(f"{which}_{part(int(k1))}_{part(int(k2))}" for k1, k2 in euler_modes(N) for which in ("re", "im"))


def euler_initial_state(N: int = 5) -> npt.NDArray[np.float64]:
    """The reference data of docs/engine_rn.md: ``omega(1, 0) = 1``, ``omega(1, 1) = 0.5``, ``omega(2, 1) = 0.25 i``
    (and conjugates), the other modes 0; then ``H = 1 + 0.25 / 2 + 0.0625 / 5 = 1.1375`` and
    ``S = 1 + 0.25 + 0.0625 = 1.3125``.  Needs N >= 5 (the mode (2, 1))."""
    N = _check_N(N)
    if N < 5:
        raise ValueError(f"`N` must be at least 5 for the mode (2, 1) of the data; got {N}.")
    M = (N - 1) // 2
    x = np.zeros(N * N - 1)
    for (k1, k2), value in (((1, 0), 1.0), ((1, 1), 0.5), ((2, 1), 0.25j)):
        i = _index(k1, k2, M)
        x[2 * i], x[2 * i + 1] = value.real, value.imag
    return x


def euler_coefficients(x: npt.ArrayLike, N: int) -> npt.NDArray[np.complex128]:
    """The Fourier coefficients of a state, an (N, N) complex array ``F[k_1 mod N, k_2 mod N] = omega_k`` (numpy's
    FFT layout, Hermitian: ``F[-k] = conj F[k]``, ``F[0, 0] = 0``)."""
    N = _check_N(N)
    x = np.asarray(x, dtype=np.float64)
    if x.shape != (N * N - 1,):
        raise ValueError(f"`x` must have shape ({N * N - 1},) (n = N^2 - 1 for N = {N}); got shape {x.shape}.")
    F = np.zeros((N, N), dtype=np.complex128)
    for i, (k1, k2) in enumerate(euler_modes(N)):
        F[k1 % N, k2 % N] = x[2 * i] + 1j * x[2 * i + 1]
        F[-k1 % N, -k2 % N] = x[2 * i] - 1j * x[2 * i + 1]
    return F


def euler_vorticity(x: npt.ArrayLike, N: int, size: int | None = None) -> npt.NDArray[np.float64]:
    """The vorticity ``omega(theta) = sum_k omega_k e^{i k . theta}`` of a state on the grid ``theta = 2 pi (j_1,
    j_2) / size`` (default size N; a larger one interpolates trigonometrically), shape (size, size), axis 0 along
    ``theta_1``."""
    N = _check_N(N)
    size = N if size is None else size
    if isinstance(size, bool) or not isinstance(size, numbers.Integral) or size < N:
        raise ValueError(f"`size` must be an integer >= N = {N}; got {size!r}.")
    F = euler_coefficients(x, N)
    grid = np.zeros((size, size), dtype=np.complex128)
    M = (N - 1) // 2
    for k1 in range(-M, M + 1):
        for k2 in range(-M, M + 1):
            grid[k1 % size, k2 % size] = F[k1 % N, k2 % N]
    return np.real(np.fft.ifft2(grid)) * size * size
