"""geomint.diagnostics on real solutions: energy error, drift law, S rises, measured order, work-precision."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import geomint
from geomint import diagnostics, studies

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
X0 = [np.cos(1.1), 0.0, np.sin(1.1)]


def test_energy_error_is_relative_and_zero_at_the_start():
    sol = geomint.solve(BODY, X0, (0.0, 10.0), 0.1, method="rk4")
    error = diagnostics.energy_error(sol)
    assert error[0] == 0.0 and error.shape == sol.t.shape
    np.testing.assert_array_equal(error, np.abs(sol.H - sol.H[0]) / abs(sol.H[0]))
    assert error.max() == pytest.approx(sol.energy_error)


def test_windowed_drift_separates_rk4_drift_from_gonzalez():
    laws = {}
    for method in ("rk4", "gonzalez"):
        sol = geomint.solve(geomint.systems.relaxing_rigid_body(eps=0.0), X0, (0.0, 2000.0), 0.2, method=method)
        centers, maxima = diagnostics.windowed_drift(sol, count=12)
        assert centers.shape == maxima.shape == (12,)
        laws[method] = diagnostics.growth_law(centers, maxima, t_min=10.0)
    assert laws["rk4"][1] == "t" and 0.75 < laws["rk4"][0] < 1.25
    assert laws["gonzalez"][1] == "round-off"  # within 16 ulp: no law is fitted to round-off


def test_growth_law_is_not_fitted_to_round_off():
    """Issue 26: maxima of a few quantised ulp were fitted as "sqrt t (p = 0.44)"; within 16 ulp there is no law."""
    t = np.geomspace(1.0, 1e5, 30)
    ulps = [1, 1, 2, 1, 2, 2, 1, 2, 3, 2, 2, 3, 2, 3, 3, 2, 3, 4, 3, 3, 4, 3, 4, 4, 3, 4, 5, 4, 5, 4]
    p, law = diagnostics.growth_law(t, diagnostics.EPS * np.array(ulps, dtype=float), t_min=1.0)
    assert law == "round-off" and np.isnan(p)
    assert diagnostics.growth_law(t, 1e-15 * (1 + 0.1 * np.sin(t)), t_min=10.0)[1] == "round-off"
    assert diagnostics.growth_law(t, 20 * diagnostics.EPS * t**0.5, t_min=1.0)[1] == "sqrt t"  # past 16 ulp: a law


def test_windowed_drift_refuses_a_single_state():
    sol = geomint.solve(BODY, X0, (0.0, 1.0), 0.1, save_every=None)
    with pytest.raises(ValueError, match=r"`t_first` must lie in"):
        diagnostics.windowed_drift(sol, t_first=5.0)


def _with_S(S):
    n = len(S)
    return geomint.Solution(
        t=np.arange(n, dtype=float),
        x=np.zeros((n, 3)),
        H=np.ones(n),
        S=np.array(S),
        success=True,
        status=0,
        message="",
        failed_step=None,
        n_steps=n - 1,
        n_newton=0,
        nfev=0,
        method="test",
    )


def test_S_rises_locate_rises_beyond_round_off_only():
    sol = _with_S([3.0, 2.0, 2.5, 1.0, 1.0 + 4 * diagnostics.EPS, 0.5])
    np.testing.assert_array_equal(diagnostics.S_rises(sol), [1])
    assert len(diagnostics.S_rises(sol)) == sol.count_S_rises()
    assert len(diagnostics.S_rises(geomint.solve(BODY, X0, (0.0, 20.0), 0.2))) == 0


def test_measured_order_of_rk4_and_gonzalez():
    steps = [0.2, 0.1, 0.05, 0.025]
    rk4, _ = studies.measured_order(BODY, "rk4", X0, 2.0, steps)
    gonzalez, _ = studies.measured_order(BODY, "gonzalez", X0, 2.0, steps)
    assert abs(rk4 - 4) < 0.2 and abs(gonzalez - 2) < 0.1


def test_observed_order_excludes_the_round_off_plateau():
    h = np.array([0.1, 0.05, 0.025, 0.0125, 0.00625])
    errors = np.maximum(h**4, 3e-15)
    assert diagnostics.observed_order(h, errors) == pytest.approx(4.0, abs=1e-9)


def test_work_precision_errors_fall_with_the_cost_and_cost_to_reach_reads_them():
    reference = studies.reference_solution(BODY, X0, 2.0)
    curve = studies.work_precision(BODY, X0, 2.0, "gonzalez", [10, 20, 40, 80], reference, repeats=1)
    assert curve.label == "gonzalez" and curve.structure_preserving
    assert np.all(np.diff(curve.error) < 0) and np.all(np.diff(curve.nfev) > 0)
    cost = diagnostics.cost_to_reach(curve.nfev, curve.error, curve.error[1])
    assert cost == pytest.approx(curve.nfev[1])


def test_work_precision_over_tolerances_measures_the_error_along_the_trajectory():
    """Adaptive runs over rtol = atol; with a callable reference the error is the largest over the returned
    states, so it is at least the error at T; fixed steps save about ``samples`` states."""
    dense = solve_ivp(
        lambda t, y: BODY.xi(y), (0.0, 2.0), X0, method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True
    ).sol
    along = studies.work_precision(
        BODY,
        X0,
        2.0,
        geomint.Projected(geomint.DormandPrince54()),
        None,
        lambda t: dense(t).T,
        repeats=1,
        tolerances=[1e-4, 1e-6, 1e-8],
    )
    at_T = studies.work_precision(
        BODY,
        X0,
        2.0,
        geomint.Projected(geomint.DormandPrince54()),
        None,
        dense(2.0),
        repeats=1,
        tolerances=[1e-4, 1e-6, 1e-8],
    )
    assert along.setting == [1e-4, 1e-6, 1e-8] and np.all(np.diff(along.error) < 0)
    assert np.all(np.array(along.error) >= np.array(at_T.error)) and np.any(np.array(along.error) > at_T.error)
    fixed = studies.work_precision(BODY, X0, 2.0, "rk4", [2000], lambda t: dense(t).T, repeats=1, samples=100)
    assert fixed.error[0] < 1e-11
    with pytest.raises(ValueError, match="give exactly one of `step_counts`"):
        studies.work_precision(BODY, X0, 2.0, "rk4", [10], dense(2.0), tolerances=[1e-6])


def test_the_work_precision_helpers_refuse_what_they_cannot_fit_and_take_an_exact_result():
    """An exact result (error 0) is reached at its own cost, not at the cost before it (log 0 made the weight
    -0); NaN errors, mismatched lengths and no repeats are refused by name."""
    assert diagnostics.cost_to_reach([1, 10, 100], [1e-2, 0.0, 0.0], 1e-5) == 10.0
    assert round(diagnostics.cost_to_reach([1, 10, 100], [1e-2, 1e-4, 1e-6], 1e-5), 1) == 31.6
    with pytest.raises(ValueError, match=r"`errors` must be >= 0 and not NaN; got \[0.01, nan"):
        diagnostics.observed_order([0.1, 0.05, 0.025, 0.0125], [1e-2, np.nan, 1e-4, 1e-5])
    with pytest.raises(
        ValueError, match=r"`step_sizes` and `errors` must be 1-D of one length >= 1; got shapes \(3,\) and \(2,\)"
    ):
        diagnostics.observed_order([0.1, 0.05, 0.025], [1e-2, 1e-3])
    with pytest.raises(ValueError, match=r"`cost` must be finite and > 0 \(or NaN\)"):
        diagnostics.cost_to_reach([0, 10], [1e-2, 1e-4], 1e-3)
    with pytest.raises(ValueError, match=r"`repeats` must be an integer >= 1; got 0"):
        diagnostics.median_time(lambda: None, 0)
