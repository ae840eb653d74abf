"""The R^n level corrections (``step_n.to_level``) where H is a long sum whose evaluation rounds more than the
step's acceptance allows: a state a few dozen ulps off a level is brought onto it within ``ACCEPT_ULPS`` of H's
terms, and the steps on such a system keep every step.

The system: a chain of N quartic oscillators with an entropy coordinate, ``E = s + sum_i p_i^2 / 2 + q_i^4 / 4``
summed as a user writes it, from s on: each of the 2 N small terms is rounded into a partial sum of the size of
s, so the evaluated E moves in steps of ulps of s that follow a move along grad E only on average.  Its states
near equilibrium (small q and p) make the move for an ulp of E long.  Before the level search (scalar Newton
stopped at its first move that did not improve), runs of it failed steps whose Newton iteration had converged:
the level missed by 4.1 and 6.4 ulps of the terms (h = 0.05, steps 73 and 219).
"""

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import geomint
from geomint._kernels import layout, step_n

EPS = np.finfo(float).eps
N = 50
DIM = 2 * N + 1
FRICTION = 0.3


@numba.njit
def energy(x, p):
    v = x[DIM - 1]
    for i in range(N):
        v += 0.5 * x[N + i] ** 2 + 0.25 * x[i] ** 4
    return v


@numba.njit
def grad_energy(x, p):
    g = np.empty(DIM)
    for i in range(N):
        g[i] = x[i] ** 3
        g[N + i] = x[N + i]
    g[DIM - 1] = 1.0
    return g


@numba.njit
def entropy(x, p):
    return x[DIM - 1]


@numba.njit
def grad_entropy(x, p):
    g = np.zeros(DIM)
    g[DIM - 1] = 1.0
    return g


@numba.njit
def poisson(x, v, p):
    out = np.zeros(DIM)
    for i in range(N):
        out[i] = v[N + i]
        out[N + i] = -v[i]
    return out


@numba.njit
def friction(x, v, p):
    """``M = FRICTION sum_i w_i w_i^T``, ``w_i = e_{p_i} - p_i e_s``: positive semidefinite, ``M grad E = 0``."""
    out = np.zeros(DIM)
    last = 0.0
    for i in range(N):
        c = v[N + i] - x[N + i] * v[DIM - 1]
        out[N + i] = FRICTION * c
        last -= FRICTION * x[N + i] * c
    out[DIM - 1] = last
    return out


def chain(E=energy, **options):
    return geomint.GenericSystem(
        E=E,
        grad_E=grad_energy,
        S=entropy,
        grad_S=grad_entropy,
        L_apply=poisson,
        M_apply=friction,
        dim=DIM,
        name="quartic_chain",
        **options,
    )


def start():
    return np.concatenate([np.linspace(-1.0, 1.0, N), np.linspace(0.5, -0.5, N), [0.0]])


def terms(x):
    """``step_n.term_scale_n`` at x: max(|E|, sum_i |dE/dx_i x_i|) (E(0) = 0)."""
    return max(abs(energy(x, None)), float(np.abs(grad_energy(x, None) * x).sum()))


@numba.njit
def _to_level(model, y, value, target, tolerance):
    n = y.shape[0]
    return step_n.to_level(model, y, value, target, True, np.empty(n), np.empty(n), tolerance)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.sampled_from([0.01, 0.03, 0.1, 0.3]), off=st.integers(-40, 40))
def test_a_state_off_the_level_of_a_long_sum_is_brought_onto_it(seed, scale, off):
    """``off`` ulps of the terms from the level at a random state of the chain: to_level lands within
    ``ACCEPT_ULPS`` of them, moves by round-off, and leaves S (``Pi_S grad E`` has no s component) as it was."""
    system = chain()
    rng = np.random.default_rng(seed)
    x = np.concatenate([rng.uniform(-scale, scale, 2 * N), [rng.uniform(0.0, 10.0)]])
    value, unit = energy(x, None), EPS * terms(x)
    target = value + off * unit
    y = x.copy()
    landed, _ = _to_level(system.inlined_model, y, value, target, unit)
    assert landed == energy(y, None)
    assert abs(landed - target) <= layout.ACCEPT_ULPS * unit, (landed - target) / unit
    assert y[-1] == x[-1]
    assert np.max(np.abs(y - x)) <= 1e-10


@pytest.mark.parametrize("method", [geomint.Gonzalez(), geomint.AVF()], ids=repr)
def test_the_chain_keeps_every_step_to_its_acceptance(method):
    """600 steps through the chain's relaxation (the two failures above were in them): every step kept, E
    within ``ACCEPT_ULPS`` of its terms of E(x0), S never falling."""
    system, x0 = chain(), start()
    sol = geomint.solve(system, x0, (0.0, 30.0), h=0.05, method=method)
    assert sol.success, sol.message
    allowed = layout.ACCEPT_ULPS * EPS * max(terms(x) for x in sol.x)
    assert np.max(np.abs(sol.H - sol.H[0])) <= allowed
    assert np.all(np.diff(sol.S) >= -layout.ACCEPT_S_ULPS * EPS * np.abs(sol.S[1:]))


#: a jitter far beyond the acceptance (hundreds of ulps of E's terms), flipping sign from one ulp of q_0 to the next
JITTER = 1e-12


@numba.njit
def jittered_energy(x, p):
    return energy(x, p) + (JITTER if int(x[0] * 2.0**52) & 1 else -JITTER)


def test_a_step_whose_solve_converged_but_misses_the_level_is_reported_as_such():
    """E evaluated with a jitter of hundreds of ulps, as a sum that cancels might: the solve converges (its
    discrete gradients see the jitter divided by |x' - x|^2), no state near the level is within ``ACCEPT_ULPS`` of
    it, and the step fails as ``NOT_ACCEPTED`` with its cause, not as a Newton iteration that did not converge;
    the states before it are kept."""
    system = chain(E=jittered_energy, check=False)
    sol = geomint.solve(system, start(), (0.0, 30.0), h=0.05)
    assert sol.status == geomint.Status.NOT_ACCEPTED, sol.message
    assert "failed the acceptance" in sol.message and "did not converge" not in sol.message
    assert sol.failed_step is not None and len(sol.t) == sol.failed_step
    assert np.all(np.isfinite(sol.x))
