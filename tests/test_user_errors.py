"""A user function that raises is never swallowed: at construction, on direct calls, inside a run."""

import numba
import numpy as np
import pytest
from test_system import _H, _J, _S, _grad_H, _grad_S, _grad_S_array, _J_array

import geomint

pytestmark = pytest.mark.inlined  # the step loop as users run it (conftest.py)


@numba.njit
def _grad_S_raising_below_half(x, p):
    if x[2] < 0.5:
        raise ValueError("grad S undefined below z = 1/2")
    return (0.0, 0.0, x[2])


@numba.njit
def _H_raising_beyond_one(x, p):
    if x[0] > 1.0:
        raise ZeroDivisionError("H undefined beyond x = 1")
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


def _oscillator(check=False, **replace):
    """The dissipative oscillator (rotation about z, z^2 / 2 decaying) with some functions replaced."""
    functions = dict(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, J=_J)
    functions.update(replace)
    return geomint.MetriplecticSystem(**functions, eps=1.0, check=check)


def test_a_function_that_raises_at_the_sample_points_is_named_at_construction():
    with pytest.raises(
        geomint.UserFunctionError,
        match=r"`grad_S` raised ValueError\('grad S undefined below "
        r"z = 1/2'\) at x = \[.*pass check=False",
    ):
        _oscillator(check=True, grad_S=_grad_S_raising_below_half)


def test_direct_and_vectorised_calls_name_the_function_and_the_state():
    system = _oscillator(grad_S=_grad_S_raising_below_half)
    with pytest.raises(geomint.UserFunctionError, match=r"`grad_S` raised .* at x = \[0.0, 0.0, 0.25\]") as one:
        system.grad_S([0.0, 0.0, 0.25])
    assert isinstance(one.value.__cause__, ValueError) and one.value.function == "grad_S"
    with pytest.raises(geomint.UserFunctionError, match=r"`grad_S` raised .* at x = \[0.0, 0.0, 0.25\]"):
        system.xi(np.array([[0.0, 0.0, 0.75], [0.0, 0.0, 0.25]]))
    np.testing.assert_array_equal(system.grad_S([0.0, 0.0, 0.75]), [0.0, 0.0, 0.75])


@pytest.mark.parametrize("method", ["gonzalez", "itoh_abe", "avf", "rk4", "yoshida4", "projected", "strang"])
def test_a_function_that_raises_inside_a_run_fails_that_step(method, capfd):
    """S = z^2/2 decays through z = 1/2, where grad S raises: the step that reaches it fails, naming grad_S,
    and every state before it is kept (numba's "Exception ignored" lines are not printed)."""
    system = _oscillator(grad_S=_grad_S_raising_below_half)
    sol = geomint.solve(system, [0.1, 0.2, 0.9], (0.0, 10.0), 0.01, method=method)
    assert not sol.success and sol.status == -4
    assert f"Step {sol.failed_step} " in sol.message and "`grad_S` raised ValueError" in sol.message
    assert sol.n_steps == sol.failed_step - 1 and sol.t_final == pytest.approx(sol.n_steps * 0.01)
    assert np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.H))
    # the run without the raise follows the same states up to there
    clean = geomint.solve(_oscillator(), [0.1, 0.2, 0.9], (0.0, sol.t_final), 0.01, method=method)
    np.testing.assert_allclose(sol.x_final, clean.x_final, rtol=1e-12, atol=1e-15)
    assert "Exception ignored" not in capfd.readouterr().err


def test_a_raise_in_H_is_named_too():
    """The rotation about z carries x beyond 1 (|x| up to 1.2): H raises there."""
    system = _oscillator(H=_H_raising_beyond_one)
    sol = geomint.solve(system, [0.0, 1.2, 0.3], (0.0, 10.0), 0.05, method="gonzalez")
    assert sol.status == -4 and "`H` raised ZeroDivisionError" in sol.message
    assert np.all(sol.x[:, 0] <= 1.0 + 0.05 * 1.2)


def test_other_unraisable_exceptions_still_reach_the_previous_hook(monkeypatch):
    """The hook takes only numba's exceptions; others go where they went before."""
    import sys

    seen = []
    monkeypatch.setattr(sys, "unraisablehook", seen.append)
    sol = geomint.solve(_oscillator(), [0.1, 0.2, 0.9], (0.0, 1.0), 0.1)

    class Noisy:
        def __del__(self):
            raise RuntimeError("from a finaliser")

    Noisy()
    assert sol.success and len(seen) == 1 and isinstance(seen[0].exc_value, RuntimeError)


@numba.njit
def _grad_H_short_beyond(x, p):
    if x[0] > 0.9:
        return np.zeros(2)
    return np.array([x[0], x[1], x[2]])


@pytest.mark.parametrize("method", ["gonzalez", "rk4"])
def test_an_array_of_the_wrong_shape_mid_run_fails_the_step_naming_the_function(method):
    """The array type cannot say how long it is; the kernels read it as NaNs, never past its end."""
    system = _oscillator(grad_H=_grad_H_short_beyond, grad_S=_grad_S_array, J=_J_array)
    sol = geomint.solve(system, [0.1, 0.95, 0.3], (0.0, 10.0), 0.01, method=method)
    assert sol.status == -2 and "`grad_H` returned a non-finite value or an array of the wrong shape" in sol.message
    assert np.all(sol.x[:-1, 0] <= 0.9) and np.all(np.isfinite(sol.x))


@numba.njit
def _H_nan_beyond_one(x, p):
    if x[0] > 1.0:
        return np.nan
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


_RUNS = {
    "fixed": dict(h=0.01),
    "adaptive": dict(rtol=1e-8),
    "t_eval": dict(h=0.01, t_eval=[0.5, 1.0]),
    "events": dict(rtol=1e-8, events=lambda t, x: x[2] - 0.5),
}


@pytest.mark.parametrize("run", sorted(_RUNS))
def test_a_start_where_H_is_not_finite_or_raises_is_refused_before_any_result(run):
    """``solve`` reads H(x0) and S(x0) from its run's first row (the loop evaluates them there): a start where
    either is not finite, or where one raises, is refused with the error a check before the run gives, on every
    path of the run, in R^3 and in R^n (the gas containers outside 0 < q < 2); a start next to it runs."""
    kwargs = _RUNS[run]
    with pytest.raises(ValueError, match=r"H and S must be finite at `x0`; at x0 = \[1.5, 0.0, 0.3\] H = nan"):
        geomint.solve(_oscillator(H=_H_nan_beyond_one), [1.5, 0.0, 0.3], (0.0, 1.0), **kwargs)
    with pytest.raises(geomint.UserFunctionError, match=r"`H` raised ZeroDivisionError.* at x = \[1.5, 0.0, 0.3\]"):
        geomint.solve(_oscillator(H=_H_raising_beyond_one), [1.5, 0.0, 0.3], (0.0, 1.0), **kwargs)
    gas = geomint.systems.gas_containers()
    with pytest.raises(ValueError, match=r"H and S must be finite at `x0`; at x0 = \[2.5, 0.0, 2.0, 2.0\]"):
        geomint.solve(gas, [2.5, 0.0, 2.0, 2.0], (0.0, 1.0), **kwargs)
    assert geomint.solve(_oscillator(H=_H_raising_beyond_one), [0.5, 0.0, 0.3], (0.0, 1.0), **kwargs).success
    assert geomint.solve(gas, [1.5, 0.0, 2.0, 2.0], (0.0, 1.0), **kwargs).success
