"""The front door: argument validation, saving, results."""

import numpy as np
import pytest

import geomint
from geomint.run import chunks

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
X0 = [np.cos(1.1), 0.0, np.sin(1.1)]


@pytest.mark.nojit
@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(x0=[1.0, np.nan, 0.0]), ValueError, r"`x0` must be finite; got \[1.0, nan, 0.0\]"),
        (dict(x0=[1.0, 2.0]), ValueError, r"`x0` must have shape \(3,\); got shape \(2,\)"),
        (dict(x0=[[1.0, 2.0, 3.0]]), ValueError, r"`x0` must have shape \(3,\); got shape \(1, 3\)"),
        (dict(x0="abc"), TypeError, r"`x0` must be a sequence of 3 real numbers"),
        (dict(h=0.0), ValueError, r"`h` must be finite and > 0; got 0.0"),
        (dict(h=-0.1), ValueError, r"`h` must be finite and > 0; got -0.1"),
        (dict(h=np.inf), ValueError, r"`h` must be finite and > 0; got inf"),
        (
            dict(t_span=(1.0, 1.0)),
            ValueError,
            r"`t_span` must satisfy t_end != t0.*got \(1.0, 1.0\)",
        ),  # backward runs are allowed (issue 11)
        (dict(t_span=(0.0, np.inf)), ValueError, r"`t_span` must be finite"),
        (dict(t_span=(0.0,)), ValueError, r"`t_span` must be a pair \(t0, t_end\)"),
        (
            dict(method="euler"),
            ValueError,
            r"`method` must be an Integrator instance or one of \[.*'gonzalez', .*'rk4'.*\]; got 'euler'",
        ),
        (dict(save_every=0), ValueError, r"`save_every` must be an integer >= 1 or None; got 0"),
        (dict(save_every=2.5), ValueError, r"`save_every` must be an integer >= 1 or None; got 2.5"),
        (dict(system="body"), TypeError, r"`system` must be a geomint.MetriplecticSystem; got str"),
    ],
)
def test_bad_input_is_refused_with_the_rule(kwargs, error, match):
    arguments = dict(system=BODY, x0=X0, t_span=(0.0, 1.0), h=0.1)
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        geomint.solve(**arguments)


@pytest.mark.nojit
def test_bad_integrator_options_are_refused():
    with pytest.raises(ValueError, match=r"`max_newton_iter` must be an integer in \[1, 10\*\*6\]; got 0"):
        geomint.Gonzalez(max_newton_iter=0)


@pytest.mark.nojit
def test_short_names_and_objects_agree():
    by_name = geomint.solve(BODY, X0, (0.0, 0.3), 0.1, method="GONZALEZ")
    by_object = geomint.solve(BODY, X0, (0.0, 0.3), 0.1, method=geomint.Gonzalez())
    np.testing.assert_array_equal(by_name.x, by_object.x)
    assert by_name.method == geomint.Gonzalez()


@pytest.mark.nojit
def test_time_grid_lands_on_t_end_and_keeps_the_final_state():
    sol = geomint.solve(BODY, X0, (1.0, 1.35), 0.1, save_every=2)
    assert sol.n_steps == 4  # 0.1, 0.1, 0.1 and a last step of 0.05
    np.testing.assert_allclose(sol.t, [1.0, 1.2, 1.35], rtol=0, atol=1e-15)
    every = geomint.solve(BODY, X0, (1.0, 1.35), 0.1)
    np.testing.assert_array_equal(sol.x_final, every.x_final)
    np.testing.assert_array_equal(sol.x, every.x[[0, 2, 4]])
    assert sol.t_final == 1.35 and sol.success and sol.status == 0


def test_final_state_only_keeps_two_rows():
    sol = geomint.solve(BODY, X0, (0.0, 100.0), 0.05, save_every=None)
    full = geomint.solve(BODY, X0, (0.0, 100.0), 0.05)
    assert sol.x.shape == (2, 3)
    np.testing.assert_array_equal(sol.x[-1], full.x[-1])
    assert (sol.n_steps, sol.n_newton, sol.nfev) == (full.n_steps, full.n_newton, full.nfev)


def test_counts_and_invariant_columns():
    sol = geomint.solve(BODY, X0, (0.0, 1.0), 0.1)
    assert sol.n_steps == 10 and sol.nfev >= 5 * 10 and sol.n_newton >= 10
    np.testing.assert_array_equal(sol.H, BODY.H(sol.x))
    np.testing.assert_array_equal(sol.S, BODY.S(sol.x))
    rk4 = geomint.solve(BODY, X0, (0.0, 1.0), 0.1, method="rk4")
    assert rk4.n_newton == 0 and rk4.nfev == 40


def test_progress_is_reported_between_chunks_without_changing_the_result():
    seen = []
    sol = geomint.solve(BODY, X0, (0.0, 12_500.0), 0.05, save_every=None, progress=seen.append)
    plain = geomint.solve(BODY, X0, (0.0, 12_500.0), 0.05, save_every=None)
    assert len(seen) > 1 and seen == sorted(set(seen)) and seen[-1] == 250_000
    np.testing.assert_array_equal(sol.x, plain.x)


@pytest.mark.parametrize("method", ["gonzalez", "rk4", "yoshida4"])
def test_chunk_boundaries_do_not_change_a_single_bit(monkeypatch, method):
    """The compiled loop carries state, compensation and Newton history across chunks."""
    whole = geomint.solve(BODY, X0, (0.0, 50.0), 0.05, method=method, save_every=7)
    monkeypatch.setattr(chunks.time, "perf_counter", lambda: 0.0)  # no timing: fixed chunks
    monkeypatch.setitem(geomint.solve.__globals__, "FIRST_CHUNK", 13)
    monkeypatch.setattr(chunks, "MAX_CHUNK", 13)
    chunked = geomint.solve(BODY, X0, (0.0, 50.0), 0.05, method=method, save_every=7)
    for name in ("t", "x", "H", "S"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))
    assert (chunked.n_newton, chunked.nfev) == (whole.n_newton, whole.nfev)


def test_ctrl_c_returns_the_states_computed_so_far(sigint_raises):
    """SIGINT in the middle of a long solve: answered between chunks, every state up to there kept."""
    import os
    import signal
    import threading
    import time

    sent = []
    timer = threading.Timer(1.0, lambda: (sent.append(time.perf_counter()), os.kill(os.getpid(), signal.SIGINT)))
    geomint.solve(BODY, X0, (0.0, 1.0), 0.05)  # compiled before the clock starts
    timer.start()
    sol = geomint.solve(BODY, X0, (0.0, 5e6), 0.05, save_every=1000)
    answered = time.perf_counter()
    timer.join()
    assert sol.status == 2 and not sol.success and sol.failed_step is None
    assert "Interrupted (SIGINT)" in sol.message
    assert 0 < sol.n_steps < 10**8
    assert sol.t_final == pytest.approx(sol.n_steps * 0.05, rel=1e-12)
    assert np.all(np.diff(sol.t) > 0) and np.all(np.isfinite(sol.x))
    reference = geomint.solve(BODY, X0, (0.0, sol.t_final), 0.05, save_every=None)
    np.testing.assert_allclose(sol.x_final, reference.x_final, rtol=1e-12, atol=1e-12)
    assert answered - sent[0] < 1.0  # answered at the end of the chunk running (~0.1 s of work)


def test_non_finite_state_is_a_status_not_a_nan():
    """RK4 with a step far beyond the time scale overflows: reported, never stored."""
    stiff = geomint.systems.quartic_rigid_body(k=2.0, eps=50.0)
    sol = geomint.solve(stiff, [1.5, -1.2, 0.9], (0.0, 100.0), 1.0, method="rk4")
    assert not sol.success and sol.status == -2
    assert "non-finite" in sol.message and f"Step {sol.failed_step} " in sol.message
    assert np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.H))
    assert sol.n_steps == sol.failed_step - 1


def test_a_progress_that_is_not_callable_is_refused_before_any_step():
    with pytest.raises(TypeError, match=r"`progress` must be None or a callable taking the steps done; got 5"):
        geomint.solve(BODY, X0, (0.0, 1.0), 0.1, progress=5)
