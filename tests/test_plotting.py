"""geomint.plotting on plain Solutions: every function draws a key per line and counts failures and rises."""

import numpy as np
import pytest

import geomint
from geomint import diagnostics, plotting

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
X0 = [np.cos(1.1), 0.0, np.sin(1.1)]


@pytest.fixture(scope="module")
def runs():
    return [geomint.solve(BODY, X0, (0.0, 20.0), 0.1, method=m) for m in ("gonzalez", "rk4", "yoshida4")]


def _labels(ax):
    return ax.get_legend_handles_labels()[1]


def test_twenty_methods_get_twenty_distinct_styles():
    styles = [plotting.style(i, 20) for i in range(20)]
    assert len({(s["color"], s["linestyle"]) for s in styles}) == 20
    assert len({(s["color"], s["marker"]) for s in styles}) == 20  # also when a caller sets the line styles


def test_energy_error_keys_every_method_and_reports_the_worst(runs):
    ax = plotting.energy_error(runs)
    assert _labels(ax) == ["gonzalez", "rk4", "yoshida4", "machine epsilon"]
    assert f"{max(s.energy_error for s in runs):.2g}" in ax.get_title()


def test_casimir_marks_and_counts_S_rises():
    n = 5
    sol = geomint.Solution(t=np.arange(n, dtype=float), x=np.zeros((n, 3)), H=np.ones(n),
                           S=np.array([3.0, 2.0, 2.5, 1.0, 0.5]), success=True, status=0, message="", failed_step=None,
                           n_steps=n - 1, n_newton=0, nfev=0, method=geomint.RK4())
    ax = plotting.casimir(sol)
    assert ax.get_title() == "Casimir S: 1 rise beyond round-off"
    assert "S rose (beyond 16 ulps)" in _labels(ax)


def test_drift_labels_the_growth_law():
    free = geomint.systems.relaxing_rigid_body(eps=0.0)
    sols = [geomint.solve(free, X0, (0.0, 1000.0), 0.2, method=m, save_every=5) for m in ("gonzalez", "rk4")]
    labels = _labels(plotting.drift(sols))
    assert labels[1].startswith("rk4: t (p = ") and labels[0].split(":")[0] == "gonzalez"


def test_level_surface_counts_failures_in_the_title_and_marks_them():
    starts = geomint.level_set.sample(BODY, 0.6, 3)
    sols = [geomint.solve(BODY, x, (0.0, 2.0), 0.3, method=geomint.Gonzalez(max_newton_iter=1)) for x in starts]
    ok = geomint.solve(BODY, starts[0], (0.0, 2.0), 0.1)
    ax = plotting.level_surface(BODY, sols + [ok])
    assert ax.get_title() == "trajectories on H = 0.6; 3 of 4 failed"
    assert "failed: last state reached (3)" in _labels(ax)
    assert sum(label.startswith("x0 = (") for label in _labels(ax)) == 4


def test_level_surface_on_an_unbounded_level_set_fits_the_trajectories():
    cylinder = geomint.MetriplecticSystem.from_expressions(
        H="(y**2 + z**2)/2 - r*z", S="x**2/2 - sigma*z", J=("-x", "0", "sigma"), params={"sigma": 10.0, "r": 28.0},
        eps=0.002)
    sol = geomint.solve(cylinder, [-2.0, 3.0, 20.0], (0.0, 2.0), 0.002)
    ax = plotting.level_surface(cylinder, sol)
    span = max(np.ptp(sol.x, axis=0))
    for low, high in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim()):
        assert high - low <= 1.5 * span


def test_level_surface_draws_a_circle_of_equilibria_as_a_curve():
    equal = geomint.systems.relaxing_rigid_body(1.0, 1.0, 0.5, eps=0.5)
    sol = geomint.solve(equal, [0.3, 0.2, 0.6], (0.0, 5.0), 0.05)
    ax = plotting.level_surface(equal, sol)
    # The circle x² + y² = 2 H0 attracts at rate -1.5 eps across it (geomint.analysis), so it is drawn as stable.
    assert "curve of stable equilibria" in _labels(ax)


def test_work_precision_draws_one_keyed_line_per_curve():
    reference = diagnostics.reference_solution(BODY, X0, 1.0)
    curves = [diagnostics.work_precision(BODY, X0, 1.0, m, [5, 10, 20], reference, repeats=1) for m in ("gonzalez", "rk4")]
    ax = plotting.work_precision(curves, cost="nfev")
    assert _labels(ax) == ["gonzalez", "rk4"]
    assert [line.get_linestyle() for line in ax.get_lines()] == ["-", "--"]
    with pytest.raises(ValueError, match=r"`cost` must be \"wall\" or \"nfev\"; got 'time'"):
        plotting.work_precision(curves, cost="time")
