"""Ensembles and sweeps: each trajectory is its own ``solve``, bit for bit; failures stay per trajectory; Dask
gives the same arrays and survives a worker killed mid-run."""

import os
import signal
import sys

import numpy as np
import pytest
from test_user_errors import _grad_S_raising_below_half, _oscillator

import geomint

pytestmark = pytest.mark.inlined  # the step loop as users run it (conftest.py)

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
STARTS = np.random.default_rng(5).normal(size=(23, 3))
STARTS /= np.linalg.norm(STARTS, axis=1)[:, None]


def _same(ensemble, i, sol):
    n = ensemble.rows[i]
    for name in ("t", "x", "H", "S"):
        np.testing.assert_array_equal(getattr(ensemble, name)[i, :n], getattr(sol, name))
    assert (
        ensemble.status[i],
        ensemble.n_steps[i],
        ensemble.n_newton[i],
        ensemble.nfev[i],
        ensemble.n_rejected[i],
    ) == (sol.status, sol.n_steps, sol.n_newton, sol.nfev, sol.n_rejected)
    assert ensemble.messages[i] == sol.message


@pytest.mark.parametrize("method", ["gonzalez", "rk4", "yoshida4", "projected", "itoh_abe"])
def test_each_trajectory_is_its_own_solve_bit_for_bit(method):
    ensemble = geomint.solve_ensemble(BODY, STARTS, (0.0, 3.0), 0.05, method=method, save_every=7, chunk=5)
    assert len(ensemble) == len(STARTS) and np.all(ensemble.success)
    for i in (0, 4, 5, 22):
        _same(ensemble, i, geomint.solve(BODY, STARTS[i], (0.0, 3.0), 0.05, method=method, save_every=7))


ADAPTIVE_METHODS = ["gonzalez", geomint.Projected(geomint.DormandPrince54()), "rk4"]


@pytest.mark.parametrize("method", ADAPTIVE_METHODS, ids=["gonzalez", "projected_dp54", "rk4_doubling"])
def test_each_adaptive_trajectory_is_its_own_adaptive_solve_bit_for_bit(method):
    """Adaptive steps (one estimator each: RK4 reference, embedded pair, step doubling), the first step chosen per
    trajectory; rows at t_eval, or at the start and the end."""
    t_eval = [0.5, 1.0, 2.5, 4.0]
    ensemble = geomint.solve_ensemble(
        BODY, STARTS, (0.0, 4.0), method=method, rtol=1e-7, atol=1e-9, t_eval=t_eval, chunk=6
    )
    assert np.all(ensemble.success) and ensemble.t.shape == (len(STARTS), 4)
    assert np.all(ensemble.n_steps > 4) and len(set(ensemble.n_steps.tolist())) > 1  # own steps each
    for i in (0, 7, 22):
        _same(
            ensemble, i, geomint.solve(BODY, STARTS[i], (0.0, 4.0), method=method, rtol=1e-7, atol=1e-9, t_eval=t_eval)
        )
    ends = geomint.solve_ensemble(BODY, STARTS[:3], (0.0, 4.0), method=method, rtol=1e-5, first_step=0.01)
    for i in range(3):
        _same(
            ends,
            i,
            geomint.solve(BODY, STARTS[i], (0.0, 4.0), method=method, rtol=1e-5, first_step=0.01, save_every=None),
        )


def test_fixed_steps_landing_on_t_eval_and_backward_spans_are_solve_too():
    t_eval = [0.0, 0.33, 1.0, 1.7]
    ensemble = geomint.solve_ensemble(BODY, STARTS, (0.0, 2.0), 0.1, t_eval=t_eval)
    for i in (0, 11):
        _same(ensemble, i, geomint.solve(BODY, STARTS[i], (0.0, 2.0), 0.1, t_eval=t_eval))
    back = geomint.solve_ensemble(BODY, STARTS[:4], (2.0, 0.0), 0.1, save_every=5)
    adaptive_back = geomint.solve_ensemble(BODY, STARTS[:4], (2.0, 0.0), rtol=1e-6)
    for i in range(4):
        _same(back, i, geomint.solve(BODY, STARTS[i], (2.0, 0.0), 0.1, save_every=5))
        _same(adaptive_back, i, geomint.solve(BODY, STARTS[i], (2.0, 0.0), rtol=1e-6, save_every=None))
    assert back.t[0, -1] == 0.0 and adaptive_back.t[0, -1] == 0.0


def test_failures_landing_on_t_eval_stay_with_their_trajectory_and_keep_the_last_state_reached():
    """Fixed steps landing on t_eval (RK4 blowing up on stiff starts) and adaptive steps (a grad_S that raises):
    the failed trajectories keep their t_eval rows so far and the state reached, as solve returns them."""
    stiff = geomint.systems.quartic_rigid_body(k=2.0, eps=50.0)
    X0 = np.array([[0.3, 0.2, 0.1], [1.5, -1.2, 0.9], [0.2, 0.1, 0.3]])
    t_eval = [0.05, 0.1, 5.0, 20.0]
    ensemble = geomint.solve_ensemble(stiff, X0, (0.0, 20.0), 0.2, method="rk4", t_eval=t_eval)
    assert ensemble.status.tolist() == [0, -2, -2]
    for i in range(3):
        _same(ensemble, i, geomint.solve(stiff, X0[i], (0.0, 20.0), 0.2, method="rk4", t_eval=t_eval))
    system = _oscillator(grad_S=_grad_S_raising_below_half)
    X0 = np.array([[0.1, 0.2, 0.9], [0.0, 0.1, 0.99], [0.0, 0.0, 3.0]])
    ensemble = geomint.solve_ensemble(system, X0, (0.0, 3.0), rtol=1e-6, t_eval=[0.5, 1.0, 3.0], threads=2)
    assert ensemble.status.tolist() == [-4, -4, 0]
    assert all("`grad_S` raised ValueError" in m for m in ensemble.messages[:2])
    for i in range(3):
        _same(ensemble, i, geomint.solve(system, X0[i], (0.0, 3.0), rtol=1e-6, t_eval=[0.5, 1.0, 3.0]))


def test_a_user_function_raising_where_the_first_step_is_chosen_fails_that_step_and_is_named():
    """grad_S raises at the start itself (z < 1/2), where the adaptive first step evaluates the field: the
    trajectory fails at step 1 with the function named, in solve and in the ensemble alike (no "Exception
    ignored" and no garbage step)."""
    system = _oscillator(grad_S=_grad_S_raising_below_half)
    X0 = np.array([[0.3, 0.2, 0.1], [0.0, 0.0, 3.0]])
    sol = geomint.solve(system, X0[0], (0.0, 1.0), rtol=1e-6)
    assert sol.status == -4 and sol.failed_step == 1 and "`grad_S` raised ValueError" in sol.message
    ensemble = geomint.solve_ensemble(system, X0, (0.0, 1.0), rtol=1e-6, threads=2)
    assert ensemble.status.tolist() == [-4, 0]
    _same(ensemble, 0, sol)


def test_threads_and_chunks_do_not_change_a_bit():
    one = geomint.solve_ensemble(BODY, STARTS, (0.0, 2.0), 0.05, threads=1, chunk=len(STARTS))
    many = geomint.solve_ensemble(BODY, STARTS, (0.0, 2.0), 0.05, threads=3, chunk=4)
    for name in ("t", "x", "H", "S", "n_newton"):
        np.testing.assert_array_equal(getattr(one, name), getattr(many, name))


def test_a_sweep_runs_each_eps_and_parameter_set_as_its_own_system():
    sets = [[0.5, 1.0, 1.5], [0.3, 1.0, 2.0]]
    result = geomint.sweep(BODY, STARTS[:3], (0.0, 2.0), 0.05, eps=[0.0, 0.5], params=sets, save_every=None)
    assert len(result) == 2 * 2 * 3
    k = 0
    for eps in (0.0, 0.5):
        for a, b, c in sets:
            system = geomint.systems.relaxing_rigid_body(a, b, c, eps=eps)
            for x0 in STARTS[:3]:
                assert result.eps[k] == eps and result.params[k].tolist() == [a, b, c]
                _same(result, k, geomint.solve(system, x0, (0.0, 2.0), 0.05, save_every=None))
                k += 1


def test_failures_stay_with_their_trajectory_and_keep_their_rows():
    """A non-finite start is refused alone; RK4 blowing up on a stiff start fails alone, its rows kept."""
    stiff = geomint.systems.quartic_rigid_body(k=2.0, eps=50.0)
    X0 = np.array([[1.5, -1.2, 0.9], [np.nan, 0.0, 0.0], [0.3, 0.2, 0.1], [1e200, 0.0, 0.0]])
    ensemble = geomint.solve_ensemble(stiff, X0, (0.0, 20.0), 0.2, method="rk4", save_every=2)
    assert ensemble.status.tolist()[1:] == [-5, 0, -5] and ensemble.status[0] == -2
    assert "not finite" in ensemble.messages[1] and "H and S must be finite at x0" in ensemble.messages[3]
    alone = geomint.solve(stiff, X0[0], (0.0, 20.0), 0.2, method="rk4", save_every=2)
    _same(ensemble, 0, alone)
    assert np.all(np.isnan(ensemble.x[0, ensemble.rows[0] :])) and ensemble.failed_step[0] == alone.failed_step
    _same(ensemble, 2, geomint.solve(stiff, X0[2], (0.0, 20.0), 0.2, method="rk4", save_every=2))
    assert ensemble.solution(0).message == alone.message


def test_a_user_function_that_raises_fails_only_its_trajectories():
    system = _oscillator(grad_S=_grad_S_raising_below_half)
    X0 = np.array([[0.1, 0.2, 0.9], [0.0, 0.1, 0.99], [0.0, 0.0, 3.0]])  # the third is at rest at z = 3
    ensemble = geomint.solve_ensemble(system, X0, (0.0, 3.0), 0.01, threads=2)
    assert ensemble.status.tolist() == [-4, -4, 0]
    assert all("`grad_S` raised ValueError" in m for m in ensemble.messages[:2])
    _same(ensemble, 0, geomint.solve(system, X0[0], (0.0, 3.0), 0.01))


def test_to_xarray_labels_trajectories_times_components_and_parameters():
    ensemble = geomint.sweep(BODY, STARTS[:2], (0.0, 1.0), 0.1, eps=[0.1, 0.2])
    data = ensemble.to_xarray(param_names=["a", "b", "c"])
    assert dict(data["x"].sizes) == {"trajectory": 4, "time": 11, "component": 3}
    assert data["eps"].values.tolist() == [0.1, 0.1, 0.2, 0.2] and data["c"].values.tolist() == [1.5] * 4
    np.testing.assert_array_equal(data["x"].values, ensemble.x)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(X0=[0.1, 0.2, 0.3]), ValueError, r"`X0` must have shape \(n, 3\) with n >= 1; got shape \(3,\)"),
        (dict(X0=np.zeros((2, 2))), ValueError, r"`X0` must have shape \(n, 3\)"),
        (dict(X0="abc"), TypeError, r"`X0` must be an array"),
        (dict(params=np.ones((3, 3))), ValueError, r"`params` must have shape \(n, p\) = \(2, 3\), a row per start"),
        (dict(params=[[1, 2, np.nan]] * 2), ValueError, r"`params` must be finite; row 0"),
        (dict(eps=[0.1]), ValueError, r"`eps` must have shape \(n,\) = \(2,\)"),
        (dict(eps=[0.1, -1.0]), ValueError, r"`eps` must be >= 0"),
        (dict(eps=-1.0), ValueError, r"`eps` must be >= 0"),
        (dict(eps="0.1"), TypeError, r"`eps` must be a real number"),
        (dict(backend="spark"), ValueError, r"`backend` must be 'local' or 'dask'; got 'spark'"),
        (dict(chunk=0), ValueError, r"`chunk` must be an integer >= 1; got 0"),
        (dict(threads=True), ValueError, r"`threads` must be an integer >= 1; got True"),
        (dict(h="0.1"), TypeError, r"`h` must be a real number"),
        (dict(progress=3), TypeError, r"`progress` must be None or a callable"),
        (dict(rtol=1e-6), ValueError, r"`h` = 0.1 fixes the step, so `rtol` cannot be given too"),
        (dict(h=None, rtol=0.0), ValueError, r"`rtol` must be finite and >= 100 eps"),
        (dict(h=None, save_every=5), ValueError, r"`save_every` must be 1 or None with adaptive steps"),
        (dict(t_eval=[0.5, 2.0]), ValueError, r"`t_eval` must lie within t_span"),
        (dict(t_span=(1.0, 0.0), method="projected"), ValueError, r"runs backward, which"),
    ],
)
def test_bad_input_is_refused_with_the_rule(kwargs, error, match):
    arguments = dict(system=BODY, X0=STARTS[:2], t_span=(0.0, 1.0), h=0.1)
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        geomint.solve_ensemble(**arguments)


def test_one_eps_serves_every_start_and_numbers_may_be_0_d_arrays():
    """``eps=0.2`` is ``eps=[0.2, 0.2]``, and a 0-d array is the number it holds (as numpy takes it), for solve's
    tolerances too."""
    one = geomint.solve_ensemble(BODY, STARTS[:2], (0.0, 1.0), 0.1, eps=0.2)
    each = geomint.solve_ensemble(BODY, STARTS[:2], (0.0, 1.0), 0.1, eps=[0.2, 0.2])
    np.testing.assert_array_equal(one.x, each.x)
    assert one.eps.tolist() == [0.2, 0.2]
    sol = geomint.solve(BODY, STARTS[0], (0.0, 1.0), rtol=np.array(1e-6), atol=np.array(1e-9))
    same = geomint.solve(BODY, STARTS[0], (0.0, 1.0), rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(sol.x, same.x)


def test_the_dask_backend_without_dask_says_which_extra_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError, match=r"pip install geomint\[dask\]"):
        geomint.solve_ensemble(BODY, STARTS[:2], (0.0, 1.0), 0.1, backend="dask")


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


def test_dask_gives_the_local_arrays_bit_for_bit(dask_client):
    local = geomint.solve_ensemble(BODY, STARTS, (0.0, 3.0), 0.05, save_every=3)
    remote = geomint.solve_ensemble(
        BODY, STARTS, (0.0, 3.0), 0.05, save_every=3, backend="dask", client=dask_client, chunk=4
    )
    for name in ("t", "x", "H", "S", "rows", "status", "n_newton", "nfev"):
        np.testing.assert_array_equal(getattr(remote, name), getattr(local, name))
    assert remote.messages == local.messages
    assert remote.caveats == local.caveats and np.array_equal(remote.step_ratio, local.step_ratio)
    local = geomint.solve_ensemble(BODY, STARTS, (0.0, 3.0), rtol=1e-6, t_eval=[1.0, 2.0, 3.0])
    remote = geomint.solve_ensemble(
        BODY, STARTS, (0.0, 3.0), rtol=1e-6, t_eval=[1.0, 2.0, 3.0], backend="dask", client=dask_client, chunk=4
    )
    for name in ("t", "x", "H", "S", "rows", "status", "n_steps", "n_rejected"):
        np.testing.assert_array_equal(getattr(remote, name), getattr(local, name))


def test_a_dask_worker_killed_mid_run_loses_nothing(dask_client):
    """At the first finished chunk a worker that is still computing is killed (SIGKILL); Dask runs its chunks
    again elsewhere and the arrays equal the local ones."""
    killed = []

    def kill_a_busy_worker(done):
        if killed:
            return
        busy = [address for address, keys in dask_client.processing().items() if keys]
        pids = dask_client.run(os.getpid)
        if busy:
            killed.append(pids[busy[0]])
            os.kill(pids[busy[0]], signal.SIGKILL)

    X0 = np.concatenate([STARTS] * 4)
    local = geomint.solve_ensemble(BODY, X0, (0.0, 60.0), 0.01, save_every=None)
    remote = geomint.solve_ensemble(
        BODY,
        X0,
        (0.0, 60.0),
        0.01,
        save_every=None,
        backend="dask",
        client=dask_client,
        chunk=4,
        progress=kill_a_busy_worker,
    )
    assert killed, "no worker was busy when the first chunk finished"
    assert killed[0] not in dask_client.run(os.getpid).values()
    np.testing.assert_array_equal(remote.x, local.x)
    assert np.all(remote.success)
