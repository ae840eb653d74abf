"""Compiled helpers built from a system's public functions (``system.functions``, ``system.params``).

- ``scipy_rhs``: the field ``xi = grad H x J + eps grad H x (grad H x grad S)`` as a
  jitted ``f(t, x) -> array`` for ``scipy.integrate.solve_ivp``.  A fair baseline
  needs a fast right-hand side: ``system.xi`` is a vectorised analysis function
  (~0.3 ms per call on one state), this one costs ~1 us per call from Python.
- ``lsoda_rhs``: the same field as a C callback for numbalsoda's compiled LSODA
  (``numbalsoda.lsoda_sig``; benchmark extra ``pip install geomint[bench]``).
- ``bare_field_loop``: n field evaluations in a compiled loop (the cost floor of
  every method, for the benchmark's profile).
- ``field_loop_through_pointers``: the same through first-class function
  pointers, as the library's kernels call user functions (explains step costs).
- ``fixed_point_gonzalez``: the Gonzalez step solved by fixed-point iteration
  to a *given* tolerance.  geomint solves to round-off and exposes no tolerance;
  this emulation exists only to show what a loose tolerance costs in energy
  (figure "Newton tolerance vs energy error").  It mirrors the discrete gradient
  of ``geomint.Gonzalez`` (including its midpoint switch below ``eps^(1/3)|x|``)
  and is checked against ``geomint.solve`` in ``tests/test_experiments.py``.

Closures specialise on the system's functions and parameters; they compile in
about a second per system and are not cached on disk.
"""

import numba
import numpy as np

#: the midpoint switch of geomint's Gonzalez discrete gradient (geomint/_kernels/discrete_gradient.py)
SWITCH = np.finfo(np.float64).eps ** (1.0 / 3.0)


@numba.njit
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit
def _combine(eps, grad_h, axial, grad_s, hamiltonian):
    base = _cross(grad_h, axial) if hamiltonian else (0.0, 0.0, 0.0)
    g = _cross(grad_h, _cross(grad_h, grad_s))
    return (base[0] + eps * g[0], base[1] + eps * g[1], base[2] + eps * g[2])


def _functions(system):
    f = system.functions
    if f.poisson_form != "axial":
        raise ValueError(f"experiments.compiled needs a system given by its axial vector J; {system.name} gives P.")
    return f.H, f.grad_H, f.S, f.grad_S, f.poisson, system.params, float(system.eps), bool(system.hamiltonian)


def scipy_rhs(system):
    """``f(t, x) -> (3,) array``, the system's field, compiled for this system."""
    _, grad_H, _, grad_S, J, params, eps, hamiltonian = _functions(system)

    @numba.njit
    def rhs(t, x):
        v = _combine(eps, grad_H(x, params), J(x, params), grad_S(x, params), hamiltonian)
        out = np.empty(3)
        out[0], out[1], out[2] = v
        return out

    return rhs


def lsoda_rhs(system):
    """The system's field as a ``numbalsoda.lsoda_sig`` C callback (``rhs.address`` goes to ``numbalsoda.lsoda``)."""
    from numbalsoda import lsoda_sig

    _, grad_H, _, grad_S, J, params, eps, hamiltonian = _functions(system)

    @numba.cfunc(lsoda_sig)
    def rhs(t, u, du, p):
        x = numba.carray(u, 3)
        du[0], du[1], du[2] = _combine(eps, grad_H(x, params), J(x, params), grad_S(x, params), hamiltonian)

    return rhs


def _field_sum(grad_H, grad_S, J, params, eps, hamiltonian, x0, n):
    """Sum of the field's components at n states near x0 (the work of n field evaluations)."""
    x = x0.copy()
    total = 0.0
    for i in range(n):
        x[0] = x0[0] + 1e-9 * (i & 7)
        v = _combine(eps, grad_H(x, params), J(x, params), grad_S(x, params), hamiltonian)
        total += v[0] + v[1] + v[2]
    return total


_VECTOR = numba.types.float64[::1]
_TUPLE_FN = numba.types.FunctionType(numba.types.UniTuple(numba.types.float64, 3)(_VECTOR, _VECTOR))
_field_sum_specialised = numba.njit(_field_sum)
#: ``_field_sum`` reaching the functions as typed first-class functions (no inlining), the way the
#: library's precompiled kernels reach user functions; tuple-returning systems only.
field_loop_through_pointers = numba.njit(
    numba.float64(_TUPLE_FN, _TUPLE_FN, _TUPLE_FN, _VECTOR, numba.float64, numba.boolean, _VECTOR, numba.int64)
)(_field_sum)


def bare_field_loop(system):
    """``loop(x0, n) -> checksum``: n field evaluations compiled for this system (functions inlined)."""
    _, grad_H, _, grad_S, J, params, eps, hamiltonian = _functions(system)

    @numba.njit
    def loop(x0, n):
        return _field_sum_specialised(grad_H, grad_S, J, params, eps, hamiltonian, x0, n)

    return loop


def fixed_point_gonzalez(system):
    """``run(x0, h, n, tol, max_iter) -> (max |H - H0|, S rises, mean iterations, x_final)``.

    Each step iterates ``x' <- x + h F(x, x')`` (F the discrete field of
    ``geomint.Gonzalez``) from ``x' = x + h xi(x)`` until the update is below
    ``tol`` in the max norm or ``max_iter`` iterations; S rises counts steps with
    ``S' - S > 16 eps |S|`` (the rule of ``Solution.count_S_rises``).
    """
    H, grad_H, S, grad_S, J, params, eps, hamiltonian = _functions(system)
    switch = SWITCH
    ulp = np.finfo(np.float64).eps

    @numba.njit
    def discrete_gradient(grad_mid, f_old, f_new, dx, size):
        dx2 = _dot(dx, dx)
        if dx2 <= (switch * size) ** 2:
            return grad_mid
        q = (f_new - f_old - _dot(grad_mid, dx)) / dx2
        return (grad_mid[0] + q * dx[0], grad_mid[1] + q * dx[1], grad_mid[2] + q * dx[2])

    @numba.njit
    def run(x0, h, n, tol, max_iter):
        x = x0.copy()
        x_new = np.empty(3)
        mid = np.empty(3)
        H0 = H(x, params)
        worst = 0.0
        rises = 0
        iterations = 0
        for _ in range(n):
            H_old, S_old = H(x, params), S(x, params)
            v = _combine(eps, grad_H(x, params), J(x, params), grad_S(x, params), hamiltonian)
            for k in range(3):
                x_new[k] = x[k] + h * v[k]
            for _ in range(max_iter):
                iterations += 1
                dx = (x_new[0] - x[0], x_new[1] - x[1], x_new[2] - x[2])
                for k in range(3):
                    mid[k] = x[k] + 0.5 * dx[k]
                size = max(np.max(np.abs(x)), np.max(np.abs(x_new)))
                dg_h = discrete_gradient(grad_H(mid, params), H_old, H(x_new, params), dx, size)
                dg_s = discrete_gradient(grad_S(mid, params), S_old, S(x_new, params), dx, size)
                axial = J(mid, params)
                ns = _dot(dg_s, dg_s)
                if ns > 0.0:
                    c = _dot(axial, dg_s) / ns
                    axial = (c * dg_s[0], c * dg_s[1], c * dg_s[2])
                F = _combine(eps, dg_h, axial, dg_s, hamiltonian)
                change = 0.0
                for k in range(3):
                    value = x[k] + h * F[k]
                    change = max(change, abs(value - x_new[k]))
                    x_new[k] = value
                if change <= tol:
                    break
            S_new = S(x_new, params)
            if S_new - S_old > 16.0 * ulp * max(abs(S_old), abs(S_new)):
                rises += 1
            x[:] = x_new
            worst = max(worst, abs(H(x, params) - H0))
        return worst, rises, iterations / n, x

    return run
