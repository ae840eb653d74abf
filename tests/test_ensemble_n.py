"""Ensembles in R^n: each trajectory is its own ``solve`` bit for bit (a random Fish system in R^6 and damped pendula,
GENERIC), on threads and on Dask; sweeps over eps and params; failures per trajectory; what R^n does not offer yet
refused as ``solve`` refuses it; the ensemble labelled with the system's coordinates."""

import numpy as np
import pytest

import geomint
from geomint import systems

FISH = systems.random_fish(6, seed=3, eps=0.5)
PENDULA = systems.damped_pendula(3, gamma=0.5)
FISH_STARTS = np.random.default_rng(11).normal(size=(7, 6)) * 0.6
PENDULA_STARTS = np.random.default_rng(12).uniform(-1.5, 1.5, size=(7, 7))


def _same(ensemble, i, sol):
    n = ensemble.rows[i]
    for name in ("t", "x", "H", "S"):
        np.testing.assert_array_equal(getattr(ensemble, name)[i, :n], getattr(sol, name))
    assert (
        ensemble.status[i],
        ensemble.failed_step[i] or None,
        ensemble.n_steps[i],
        ensemble.n_newton[i],
        ensemble.nfev[i],
    ) == (sol.status, sol.failed_step, sol.n_steps, sol.n_newton, sol.nfev)
    assert ensemble.messages[i] == sol.message
    assert ensemble.solution(i).S_direction == sol.S_direction


CASES = [
    (FISH, FISH_STARTS, "gonzalez"),
    (FISH, FISH_STARTS, "avf"),
    (FISH, FISH_STARTS, "rk4"),
    (PENDULA, PENDULA_STARTS, "gonzalez"),
    (PENDULA, PENDULA_STARTS, "itoh_abe"),
]


@pytest.mark.parametrize("system, starts, method", CASES, ids=[f"{s.name}-{m}" for s, _, m in CASES])
def test_each_trajectory_is_its_own_solve_bit_for_bit(system, starts, method):
    """Threads on interleaved trajectories (2 threads, chunks of 3): every trajectory equals its solve."""
    ensemble = geomint.solve_ensemble(system, starts, (0.0, 2.0), 0.05, method=method, save_every=3, threads=2, chunk=3)
    assert ensemble.x.shape == (len(starts), 15, system.dim) and np.all(ensemble.success)
    for i in range(len(starts)):
        _same(ensemble, i, geomint.solve(system, starts[i], (0.0, 2.0), 0.05, method=method, save_every=3))


def test_threads_and_chunks_do_not_change_a_bit():
    one = geomint.solve_ensemble(PENDULA, PENDULA_STARTS, (0.0, 2.0), 0.1, threads=1, chunk=len(PENDULA_STARTS))
    many = geomint.solve_ensemble(PENDULA, PENDULA_STARTS, (0.0, 2.0), 0.1, threads=3, chunk=2)
    for name in ("t", "x", "H", "S", "n_newton", "nfev"):
        np.testing.assert_array_equal(getattr(one, name), getattr(many, name))


def test_a_sweep_over_params_and_eps_runs_each_as_its_own_system():
    """GENERIC's friction gamma (a parameter) and a Fish system's eps: each trajectory is the solve of the system
    built with its own value (the constant terms of H and S measured with its own params)."""
    gammas = [0.2, 0.9]
    result = geomint.sweep(PENDULA, PENDULA_STARTS[:2], (0.0, 2.0), 0.1, params=[[g] for g in gammas])
    assert len(result) == 4 and result.params[:, 0].tolist() == [0.2, 0.2, 0.9, 0.9]
    for k, (g, x0) in enumerate((g, x0) for g in gammas for x0 in PENDULA_STARTS[:2]):
        _same(result, k, geomint.solve(systems.damped_pendula(3, gamma=g), x0, (0.0, 2.0), 0.1))
    assert not np.array_equal(result.x[0], result.x[2])  # gamma did reach the kernel
    eps_values = [0.0, 1.5]
    result = geomint.sweep(FISH, FISH_STARTS[:2], (0.0, 2.0), 0.1, eps=eps_values, save_every=None)
    for k, (e, x0) in enumerate((e, x0) for e in eps_values for x0 in FISH_STARTS[:2]):
        _same(result, k, geomint.solve(systems.random_fish(6, seed=3, eps=e), x0, (0.0, 2.0), 0.1, save_every=None))
    assert np.all(np.abs(result.S[:2, -1] - result.S[:2, 0]) < 1e-13)  # eps = 0: S is a Casimir
    assert np.all(result.S[2:, -1] < result.S[2:, 0] - 1e-3)


@pytest.mark.filterwarnings("ignore::geomint.AccuracyWarning")  # the blown-up trajectory's step ratio
def test_failures_stay_with_their_trajectory():
    """A start that is not finite, one where H is not finite (the gas containers outside 0 < q < 2) and RK4
    blowing up on a far start: each fails alone, as its solve does; the others run."""
    far = FISH_STARTS[0] * 3.0 / np.linalg.norm(FISH_STARTS[0])
    X0 = np.array([FISH_STARTS[1], far, [np.nan] * 6, FISH_STARTS[2]])
    ensemble = geomint.solve_ensemble(FISH, X0, (0.0, 4.0), 0.5, method="rk4", threads=2, chunk=2)
    assert ensemble.status.tolist() == [0, -2, -5, 0]
    assert "not finite" in ensemble.messages[2] and ensemble.rows[2] == 1 and np.all(np.isnan(ensemble.x[2]))
    for i in (0, 1, 3):
        _same(ensemble, i, geomint.solve(FISH, X0[i], (0.0, 4.0), 0.5, method="rk4"))
    gas = systems.gas_containers()
    ensemble = geomint.solve_ensemble(gas, [[1.5, 0.0, 2.0, 2.0], [2.5, 0.0, 2.0, 2.0]], (0.0, 1.0), 0.1)
    assert ensemble.status.tolist() == [0, -5] and "H and S must be finite at x0" in ensemble.messages[1]


def test_to_xarray_labels_the_coordinates_with_the_systems_variables_and_says_what_S_is():
    pytest.importorskip("xarray")
    ensemble = geomint.solve_ensemble(PENDULA, PENDULA_STARTS[:3], (0.0, 1.0), 0.1)
    assert ensemble.variables == ("q1", "q2", "q3", "p1", "p2", "p3", "s") and ensemble.S_direction == 1.0
    data = ensemble.to_xarray(param_names=["gamma"])
    assert dict(data["x"].sizes) == {"trajectory": 3, "time": 11, "component": 7}
    assert list(data["component"].values) == list(PENDULA.variables)
    np.testing.assert_array_equal(data["x"].sel(component="s").values, ensemble.x[:, :, 6])
    assert data.attrs["S_direction"] == 1.0 and "entropy" in data.attrs["S_meaning"]
    assert data["S"].attrs["long_name"] == "entropy" and data["gamma"].values.tolist() == [0.5] * 3
    sol = ensemble.solution(0)
    assert sol.S_direction == 1.0 and sol.S_rises > 0 and sol.S_falls == 0 and sol.S_against_direction == 0
    fish = geomint.solve_ensemble(FISH, FISH_STARTS[:2], (0.0, 1.0), 0.1)
    assert fish.to_xarray().attrs["S_direction"] == -1.0 and fish.solution(1).S_against_direction == 0
    assert list(fish.to_xarray()["component"].values) == [f"x{i}" for i in range(6)]


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(X0=np.zeros((2, 3))), ValueError, r"`X0` must have shape \(m, 6\): m >= 1 starts, a row of the 6 "),
        (dict(X0=np.zeros(6)), ValueError, r"`X0` must have shape \(m, 6\).*; got shape \(6,\)"),
        (dict(X0="abc"), TypeError, r"`X0` must be an array"),
        (
            dict(method=geomint.Projected(geomint.Gonzalez(), symmetric=True)),
            ValueError,
            r"does not run on this system in R\^6: Hairer's symmetric projection",
        ),
        (dict(params=np.ones((2, 3))), ValueError, r"`params` must have shape \(n, p\) = \(2, 260\)"),
        (dict(eps=[0.1, -1.0]), ValueError, r"`eps` must be >= 0"),
    ],
)
def test_bad_input_is_refused_with_the_rule(kwargs, error, match):
    arguments = dict(system=FISH, X0=FISH_STARTS[:2], t_span=(0.0, 1.0), h=0.1)
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        geomint.solve_ensemble(**arguments)
    if "X0" in kwargs and error is ValueError and np.ndim(kwargs["X0"]) == 2:  # sweep takes one start as (n,)
        with pytest.raises(error, match=match):
            geomint.sweep(FISH, kwargs["X0"], (0.0, 1.0), 0.1)


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


@pytest.mark.parametrize("system, starts", [(FISH, FISH_STARTS), (PENDULA, PENDULA_STARTS)], ids=["fish", "pendula"])
def test_dask_gives_each_trajectorys_solve_bit_for_bit(dask_client, system, starts):
    """The system is shipped to worker processes (pickled without its compiled model) and run there by the same
    batch kernel: the arrays equal the local ones and every trajectory its solve."""
    local = geomint.solve_ensemble(system, starts, (0.0, 2.0), 0.1, save_every=2)
    remote = geomint.solve_ensemble(
        system, starts, (0.0, 2.0), 0.1, save_every=2, backend="dask", client=dask_client, chunk=3
    )
    for name in ("t", "x", "H", "S", "rows", "status", "n_newton", "nfev"):
        np.testing.assert_array_equal(getattr(remote, name), getattr(local, name))
    assert remote.messages == local.messages
    assert remote.variables == system.variables and remote.S_direction == system.direction
    for i in (0, 4, 6):
        _same(remote, i, geomint.solve(system, starts[i], (0.0, 2.0), 0.1, save_every=2))


@pytest.mark.parametrize(
    "kwargs",
    [dict(h=None, rtol=1e-6), dict(h=0.1, method="yoshida4"), dict(h=0.1, t_eval=[0.25, 0.5, 1.0])],
    ids=["adaptive", "yoshida4", "t_eval"],
)
def test_adaptive_composed_and_t_eval_ensembles_are_their_solves_bit_for_bit(kwargs):
    ensemble = geomint.solve_ensemble(FISH, FISH_STARTS[:3], (0.0, 1.0), **kwargs)
    for i in range(3):
        sol = geomint.solve(FISH, FISH_STARTS[i], (0.0, 1.0), **kwargs)
        mine = ensemble.solution(i)
        assert mine.n_steps == sol.n_steps and mine.success
        np.testing.assert_array_equal(mine.x_final, sol.x_final)
        np.testing.assert_array_equal(mine.S[-1], sol.S[-1])
