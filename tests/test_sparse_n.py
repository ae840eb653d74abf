"""The step's Newton matrix from the Jacobian's zero pattern (``geomint._kernels.sparse_n``): what the probe finds,
that its block solve is the dense solve, that a dense Jacobian keeps the dense path, and that the runs which use
it keep H and S exactly at every step and solve the same scheme."""

import numba
import numpy as np
import pytest
from test_solver_n import _random_fish_actions

from geomint import systems
from geomint._kernels import sparse_n, step_n
from geomint._kernels.field_n import field_into, jacobian_into


@numba.njit
def _probe(model, eps, hamiltonian, x, work):
    return step_n.probe_pattern(model, eps, hamiltonian, False, x, work)


@numba.njit
def _block_solve(model, eps, hamiltonian, x, h, work, rhs):
    """Refresh and factor at x by the pattern, then ``rhs = A^-1 rhs``."""
    ok = step_n.refresh(model, eps, hamiltonian, False, x, h, work)
    step_n.solve(model, eps, hamiltonian, work, x.shape[0], rhs)
    return ok


@numba.njit
def _dense_jacobian(model, eps, hamiltonian, x):
    n = x.shape[0]
    jac, f0 = np.empty((n, n)), np.empty(n)
    field_into(f0, model, eps, hamiltonian, x)
    return jacobian_into(jac, model, eps, hamiltonian, x, f0, np.empty(n), np.empty(n))


def _struct(work, n):
    start = step_n.WN_HEADER + step_n.N_VECTORS * n + n * n
    return work[start : start + n * n]


def _pendula(N, seed=0):
    system = systems.damped_pendula(N, gamma=0.7)
    rng = np.random.default_rng(seed)
    x = np.concatenate([rng.uniform(-2.0, 2.0, N), rng.uniform(-1.0, 1.0, N), [0.3]])
    return system, x


def test_the_probe_finds_the_pendulas_blocks_colours_and_bordered_row():
    N = 40
    system, x = _pendula(N)
    n = 2 * N + 1
    work = np.zeros(step_n.work_size(n))
    assert _probe(system.inlined_model, system.eps, system.hamiltonian, x, work) == n + 1
    assert work[step_n.WN_SPARSE] == 1.0
    struct = _struct(work, n)
    # a 2 x 2 block (q_i, p_i) per pendulum and s alone; the columns q and p in two colours; the entropy's row
    # ds/dt = gamma |p|^2 dense (dropped) and bordered: no other row reads s and it does not read s
    assert struct[sparse_n.S_BLOCKS] == N + 1
    assert struct[sparse_n.S_LARGEST] == 2
    assert struct[sparse_n.S_COLOURS] == 2
    assert struct[sparse_n.S_DROPPED] == 1
    assert struct[sparse_n.S_BORDERED] == 1 and struct[sparse_n.S_ROWS] == n - 1


@pytest.mark.parametrize("h", [0.01, 0.1, 0.5])
def test_the_block_solve_is_the_dense_solve(h):
    """The pattern's A = I - h/2 D xi, factored block by block with the bordered row by a directional
    difference, solves as the dense A from the dense Jacobian (both by differences: agreement to their
    truncation, ~sqrt(eps))."""
    system, x = _pendula(40, seed=3)
    n = len(x)
    model, eps, ham = system.inlined_model, system.eps, system.hamiltonian
    work = np.zeros(step_n.work_size(n))
    _probe(model, eps, ham, x, work)
    rhs = np.random.default_rng(1).normal(size=n)
    dense = np.linalg.solve(np.eye(n) - 0.5 * h * _dense_jacobian(model, eps, ham, x), rhs)
    assert _block_solve(model, eps, ham, x, h, work, rhs)
    assert np.max(np.abs(rhs - dense)) <= 1e-6 * np.max(np.abs(dense))


def test_without_the_bordered_row_the_solve_is_not_the_dense_one():
    """The bordered row is what the directional difference adds: with it dropped (the identity's row in A) the
    entropy's correction is off by (h/2) D xi_s . delta (this test fails if the solve ignores it)."""
    system, x = _pendula(40, seed=3)
    n, h = len(x), 0.1
    model, eps, ham = system.inlined_model, system.eps, system.hamiltonian
    work = np.zeros(step_n.work_size(n))
    _probe(model, eps, ham, x, work)
    _struct(work, n)[sparse_n.S_BORDERED] = 0.0
    rhs = np.random.default_rng(1).normal(size=n)
    dense = np.linalg.solve(np.eye(n) - 0.5 * h * _dense_jacobian(model, eps, ham, x), rhs)
    _block_solve(model, eps, ham, x, h, work, rhs)
    assert np.max(np.abs(rhs[:-1] - dense[:-1])) <= 1e-6 * np.max(np.abs(dense))
    assert abs(rhs[-1] - dense[-1]) > 1e-3 * np.max(np.abs(dense))


@pytest.mark.parametrize(
    "make, probed",
    [
        (lambda: _random_fish_actions(80, 2, 0.2), True),
        (lambda: systems.random_fish(80, seed=2, eps=0.2), False),
        (lambda: systems.damped_pendula(40, form="matrix"), False),
        (lambda: systems.damped_pendula(8), False),
    ],
)
def test_a_dense_jacobian_matrices_or_a_small_system_keep_the_dense_path(make, probed):
    """random Fish at n = 80 with P as an action: probed, every row reads every coordinate, no pattern pays;
    with P as a matrix, and the pendula as matrices: not probed (n + 1 evaluations of an O(n^2) field cost as
    much as a dense refresh); pendula at n = 17: below ``SPARSE_MIN_N``, not probed."""
    system = make()
    n = system.dim
    x = np.random.default_rng(5).uniform(-1.0, 1.0, n)
    work = np.zeros(step_n.work_size(n))
    evaluations = _probe(system.inlined_model, system.eps, system.hamiltonian, x, work)
    assert work[step_n.WN_SPARSE] == -1.0
    assert evaluations == (n + 1 if probed else 0)
