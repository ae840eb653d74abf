"""Solving the step in R^n: operators as actions, the fixed point against Newton, LAPACK's factors, the damped
step (docs/engine_rn.md, "Solving the step")."""

import numba
import numpy as np
import pytest
from test_engine_n import assert_exact_steps

import geomint
from geomint import systems
from geomint._kernels import layout, loop, step_n
from geomint._kernels.vecn import LAPACK_INT, lapack_factor, lapack_solve, lu_factor, lu_solve
from geomint.model import MetriplecticSystemN
from geomint.run.chunks import new_output, new_run_state
from geomint.run.controller import constant_grid
from geomint.systems.random_fish import _P as _random_fish_P

EPS = np.finfo(float).eps


def _pendula_start(N, seed=0):
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(-2.0, 2.0, N), rng.uniform(-1.0, 1.0, N), [0.0]])


def _run(system, x0, t_end, h, solver=step_n.AUTO, method=None, pattern=True):
    """Fixed steps on the grid with the solver the workspace asks for (``step_n.WN_SOLVER``), the Jacobian's zero
    pattern allowed or not (``step_n.WN_SPARSE``): the states, H and S saved at every step, the counters and the
    workspace."""
    data = (method or geomint.Gonzalez()).lower(system)
    grid, n_steps = constant_grid(0.0, t_end, h, 1)
    out = new_output(n_steps + 2, len(x0))
    work, state = new_run_state(data, np.asarray(x0, dtype=float), True)
    work[step_n.WN_SOLVER] = solver
    work[step_n.WN_SPARSE] = 0.0 if pattern else -1.0
    clock = layout.new_clock(0.0)
    loop.run(
        system.model, system.eps, system.hamiltonian, data, grid, state, work, clock, np.array([t_end]), n_steps, out
    )
    rows = out.counters[layout.ROWS]
    return out.x[:rows], out.H[:rows], out.S[:rows], out.counters, work


@numba.njit
def _random_fish_P_apply(x, v, p):
    """The random Fish system's P as an action (formed, then applied: the same operator)."""
    return _random_fish_P(x, p) @ v


def _random_fish_actions(n, seed, eps):
    matrices = systems.random_fish(n, seed=seed, eps=eps)
    f = matrices.functions
    return MetriplecticSystemN(
        H=f.H,
        grad_H=f.grad_H,
        S=f.S,
        grad_S=f.grad_S,
        P_apply=_random_fish_P_apply,
        eps=eps,
        params=matrices.params,
        dim=n,
    )


@pytest.mark.parametrize("N", [8, 40])  # n = 17: both forms by Newton; n = 81: the actions by the zero pattern
def test_action_and_matrix_forms_give_the_same_trajectories(N):
    x0 = _pendula_start(N)
    runs = {
        form: geomint.solve(systems.damped_pendula(N, form=form), x0, (0.0, 20.0), h=0.1)
        for form in ("action", "matrix")
    }
    a, m = runs["action"], runs["matrix"]
    assert a.success and m.success
    assert np.abs(a.x - m.x).max() <= 1e-12 * (1.0 + np.abs(m.x).max())
    assert np.abs(a.S - m.S).max() <= 1e-12 * np.abs(m.S).max()
    assert_exact_steps(systems.damped_pendula(N), a)


def test_a_random_fish_system_given_by_its_action_runs_as_its_matrix():
    matrices, actions = systems.random_fish(12, seed=3, eps=0.3), _random_fish_actions(12, 3, 0.3)
    x0 = np.random.default_rng(3).normal(size=12) * 0.5
    m, a = (geomint.solve(s, x0, (0.0, 4.0), h=0.05) for s in (matrices, actions))
    assert np.abs(a.x - m.x).max() <= 1e-12
    assert_exact_steps(actions, a)


@pytest.mark.parametrize("solver", [step_n.NEWTON_ONLY, step_n.FIXED_POINT_ONLY])
@pytest.mark.parametrize("name", ["random_fish", "euler_zeitlin", "damped_pendula"])
def test_both_solvers_make_every_step_exact(name, solver):
    """The level corrections and the acceptance rule make H exact and S monotone whichever solver stopped."""
    system = {
        "random_fish": lambda: systems.random_fish(16, seed=1, eps=0.3),
        "euler_zeitlin": lambda: systems.euler_zeitlin(5, eps=0.05),
        "damped_pendula": lambda: systems.damped_pendula(12),
    }[name]()
    x0 = systems.euler_initial_state(5) if name == "euler_zeitlin" else _pendula_start(12)[: system.dim]
    if name == "random_fish":
        x0 = np.random.default_rng(1).normal(size=16) * 0.5
    x, H, S, counters, _ = _run(system, x0, 4.0, 0.05, solver)
    assert counters[layout.STATUS] == 0 and counters[layout.STEPS] == 80
    sol = type("Rows", (), {"success": True, "message": "", "t": np.arange(len(H)), "x": x, "H": H, "S": S})
    assert_exact_steps(system, sol)
    reference = _run(system, x0, 4.0, 0.05, step_n.NEWTON_ONLY)[0]
    assert np.abs(x - reference).max() <= 1e-11 * (1.0 + np.abs(reference).max())


def test_the_solver_is_chosen_by_contraction():
    """Pendula as actions at n = 257 with a dense Jacobian (the zero pattern refused): the fixed point contracts
    (~h/2 |D xi| = 0.05) and is kept; with the pattern (a refresh: 3 evaluations, 129 blocks), Newton.  As
    matrices at n = 17, Newton, cheaper per step there.  A stiff relaxation (h eps |D xi_g| ~ 1e2): the fixed
    point does not contract and Newton takes over."""
    N = 128
    *_, counters, work = _run(systems.damped_pendula(N), _pendula_start(N), 5.0, 0.1, pattern=False)
    assert counters[layout.STATUS] == 0 and work[step_n.WN_MODE] == 1.0
    assert 0.0 < work[step_n.WN_RATE] < 0.2 and counters[layout.NEWTON_ITERATIONS] / counters[layout.STEPS] < 12
    *_, counters, work = _run(systems.damped_pendula(N), _pendula_start(N), 5.0, 0.1)
    assert counters[layout.STATUS] == 0 and work[step_n.WN_MODE] == 0.0 and work[step_n.WN_SPARSE] == 1.0
    assert counters[layout.NEWTON_ITERATIONS] / counters[layout.STEPS] < 5
    *_, counters, work = _run(systems.damped_pendula(8, form="matrix"), _pendula_start(8), 5.0, 0.1)
    assert work[step_n.WN_MODE] == 0.0 and work[step_n.WN_FIXED_POINT_ITERATIONS] > 0  # probed, not kept
    stiff = _random_fish_actions(80, 2, 1e3)
    x0 = np.random.default_rng(2).normal(size=80) * 0.3
    x, H, S, counters, work = _run(stiff, x0, 1.0, 0.1, method=geomint.DampedGonzalez())
    assert counters[layout.STATUS] == 0 and work[step_n.WN_MODE] == 0.0 and work[step_n.WN_NEWTON_ITERATIONS] > 0.0


@numba.njit
def _factor_and_solve(a, b, lapack):
    n = a.shape[0]
    if lapack:
        pivots = np.zeros(n, dtype=LAPACK_INT)
        ok = lapack_factor(a, pivots)
        if ok:
            lapack_solve(a, pivots, b)
    else:
        pivots = np.zeros(n)
        ok = lu_factor(a.ravel(), 0, n, pivots, 0)
        if ok:
            lu_solve(a.ravel(), 0, n, pivots, 0, b)
    return ok


@pytest.mark.parametrize("n", [1, 5, 30, 100])
def test_lapack_and_hand_written_factors_solve_alike(n):
    rng = np.random.default_rng(n)
    A = rng.normal(size=(n, n)) + 0.5 * np.eye(n)
    b = rng.normal(size=n)
    exact = np.linalg.solve(A, b)
    for lapack in (True, False):
        x = b.copy()
        assert _factor_and_solve(A.copy(), x, lapack)
        np.testing.assert_allclose(x, exact, rtol=1e-10, atol=1e-12 * np.abs(exact).max())
    singular = A.copy()
    singular[:, 0] = 0.0
    nan = A.copy()
    nan[0, 0] = np.nan
    for lapack in (True, False):
        assert not _factor_and_solve(singular.copy(), b.copy(), lapack)
        assert not _factor_and_solve(nan.copy(), b.copy(), lapack)


def test_the_workspace_holds_no_dense_matrix_beyond_DENSE_MAX_N():
    n = step_n.DENSE_MAX_N
    assert step_n.work_size(n) == step_n.WN_HEADER + step_n.N_VECTORS * n + 2 * n * n
    assert step_n.work_size(n + 1) == step_n.WN_HEADER + step_n.N_VECTORS * (n + 1)


def _misalignment(system, X):
    """``|Pi_H grad S| / |grad S|`` at each state: the distance from the relaxed states (grad S parallel to grad
    H), which the stiff dissipative mode carries."""
    out = []
    for x in X:
        gh, gs = system.grad_H(x), system.grad_S(x)
        out.append(np.linalg.norm(gs - (gh @ gs) / (gh @ gh) * gh) / np.linalg.norm(gs))
    return np.array(out)


def test_damped_gonzalez_runs_in_rn_and_damps_the_stiff_mode():
    """A random Fish system with eps = 1e3 at h = 0.1 from |x| = 0.7 (h eps |grad H|^2 ~ 50): DampedGonzalez keeps
    H exact and S monotone, and the stiff mode decays at every step (the misalignment falls, no increment reverses
    the last), as fast whatever h (phi eps h -> 2 eps / kappa); Gonzalez, which reflects that mode, does not get
    through the first step."""
    system = systems.random_fish(6, seed=7, eps=1e3)
    x0 = np.random.default_rng(7).normal(size=6)
    x0 *= 0.7 / np.linalg.norm(x0)
    damped = geomint.solve(system, x0, (0.0, 3.0), h=0.1, method=geomint.DampedGonzalez())
    assert_exact_steps(system, damped)
    assert np.all(np.diff(damped.S) <= 0.0)
    misalignment = _misalignment(system, damped.x[:10])
    assert np.all(np.diff(misalignment) < 0.0) and misalignment[-1] < 0.05 * misalignment[0], misalignment
    dx = np.diff(damped.x[:12], axis=0)
    assert np.all(np.einsum("ij,ij->i", dx[:-1], dx[1:]) >= 0.0)
    finer = geomint.solve(system, x0, (0.0, 0.5), h=0.05, method=geomint.DampedGonzalez())
    np.testing.assert_allclose(_misalignment(system, finer.x[:10]), misalignment, rtol=0.1)
    plain = geomint.solve(system, x0, (0.0, 3.0), h=0.1, method=geomint.Gonzalez())
    assert not plain.success and plain.status == layout.NEWTON_FAILED
