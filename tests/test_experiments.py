"""The experiments' own building blocks, on tiny sizes (the experiments themselves run in docs/)."""

import types

import numpy as np
import pytest

import geomint
from experiments import drift, floors, problems
from experiments.compiled import fixed_point_gonzalez
from experiments.floors_rn import floor_for
from experiments.methods import geomint_methods
from experiments.runs import Windows, growth_law, not_applicable, scipy_solution
from experiments.work_precision import cost_to_reach
from geomint._kernels.layout import ACCEPT_S_ULPS, ACCEPT_ULPS


@pytest.mark.parametrize(("coefficient", "eps"), [(1.0, 0.3), (0.5, 1.0), (2.0, 0.05)])
def test_oscillator_closed_form_matches_a_tight_solve(coefficient, eps):
    problem = problems.oscillator(eps=eps, coefficient=coefficient)
    solution = scipy_solution(problem.system, problem.x0, (0.0, 7.0), "DOP853", 1e-12)
    exact = problem.exact(solution.t)
    assert np.max(np.abs(exact - solution.x)) < 1e-9
    assert np.max(np.abs(exact[-1] - problem.exact(7.0))) == 0.0


@pytest.mark.parametrize("build", [problems.relaxing_rigid_body, problems.quartic_rigid_body])
def test_rigid_body_attractor_is_on_the_level_set_and_is_reached(build):
    problem = build(eps=1.0)
    H0 = problem.system.H(problem.x0)
    assert abs(problem.system.H(problem.attractor) - H0) < 1e-14
    assert np.count_nonzero(problem.attractor) == 1 and problem.attractor[2] > 0
    if problem.system.params.size == 3:
        assert abs(problem.system.S(problem.attractor) - H0 / problem.system.params[2]) < 1e-14
    solution = geomint.solve(problem.system, problem.x0, (0.0, 100.0), 0.05, save_every=None)
    assert np.linalg.norm(solution.x_final - problem.attractor) < 1e-6


def test_geomint_methods_lists_what_the_module_has():
    labels = [m.label for m in geomint_methods()]
    assert {"Gonzalez", "RK4"} <= set(labels) and len(labels) == len(set(labels))
    sparse = types.SimpleNamespace(Integrator=geomint.Integrator, Gonzalez=geomint.Gonzalez, __all__=["Gonzalez"])
    only = geomint_methods(sparse)
    assert [m.label for m in only] == ["Gonzalez"] and only[0].structure_preserving


def test_geomint_methods_reports_constructors_that_reject_the_call():
    def refuses(*args):
        raise TypeError("needs a sub-integrator")

    module = types.SimpleNamespace(Integrator=geomint.Integrator, RK4=geomint.RK4, Projected=refuses, __all__=[])
    skipped = []
    assert [m.label for m in geomint_methods(module, skipped)] == ["RK4"]
    assert skipped == ["Projected(RK4): needs a sub-integrator"]


@pytest.mark.parametrize(("power", "law"), [(0.0, "flat"), (0.5, "sqrt t"), (1.0, "t"), (2.0, "t^2.0")])
def test_growth_law_classifies_power_laws(power, law):
    """Above round-off (1e-13 = 450 ulp; a flat 1e-15 = 5 ulp is round-off: test_diagnostics)."""
    t = np.geomspace(1.0, 1e5, 30)
    p, found = growth_law(t, 1e-13 * t**power * (1 + 0.1 * np.sin(t)), t_min=10.0)
    assert found == law and abs(p - power) < 0.1


def test_windows_keep_the_maximum_of_each_window():
    windows = Windows.log_spaced(1.0, 100.0, 2)
    windows.add(np.array([0.0, 5.0, 9.0, 50.0]), np.array([1.0, 3.0, 2.0, 7.0]))
    assert windows.maxima.tolist() == [3.0, 7.0]
    windows.add(np.array([99.0]), np.array([8.0]))
    assert windows.maxima.tolist() == [3.0, 8.0]


def test_cost_to_reach_interpolates_in_log_log():
    cost, error = [100.0, 1.0, 10.0], [1e-6, 1e-2, 1e-4]
    assert cost_to_reach(cost, error, 1e-5) == pytest.approx(10**1.5)
    assert cost_to_reach(cost, error, 1e-2) == 1.0
    assert np.isnan(cost_to_reach(cost, error, 1e-8))


def test_fixed_point_emulation_matches_geomint_and_loosens_with_the_tolerance():
    problem = problems.quartic_rigid_body(eps=0.1)
    run = fixed_point_gonzalez(problem.system)
    h, n = 0.05, 200
    tight_error, tight_rises, _, x_tight = run(problem.x0, h, n, 0.0, 100)
    solution = geomint.solve(problem.system, problem.x0, (0.0, n * h), h, method=geomint.Gonzalez())
    assert np.max(np.abs(x_tight - solution.x_final)) < 1e-12
    H0 = problem.system.H(problem.x0)
    assert tight_error / H0 < 1e-14 and tight_rises == 0
    loose_error = run(problem.x0, h, n, 1e-5, 100)[0]
    assert loose_error / H0 > 100 * tight_error / H0


def test_quick_drift_on_the_relaxing_body_separates_the_methods():
    problem = problems.relaxing_rigid_body(eps=0.1)
    settings = drift.DriftSettings(50.0, {}, 0.1, 5, 1.0, 5.0, 5.0)
    runs = {run.label: run for run in drift.run_problem(problem, settings, geomint_methods(), log=lambda _: None)}
    gonzalez, rk4 = runs["Gonzalez"], runs["RK4"]
    assert gonzalez.complete and gonzalez.n_steps == 500 and gonzalez.S_rises == 0
    round_off = gonzalez.n_steps * np.finfo(float).eps  # at most an ulp a step (no compensated summation here)
    assert np.nanmax(gonzalez.windows.maxima) < round_off < 1e-4 * np.nanmax(rk4.windows.maxima)
    assert all(run.t_reached > 0 and run.nfev > 0 for run in runs.values())
    rows = drift.table_rows(problem, runs.values(), settings)
    assert len(rows) == len(runs) and all(len(row) == len(drift.HEADERS) for row in rows)


def test_free_rigid_body_closed_form_matches_a_tight_solve_and_the_published_period():
    problem = problems.free_rigid_body()
    solution = scipy_solution(problem.system, problem.x0, (0.0, 30.0), "DOP853", 1e-12)
    assert np.max(np.abs(problem.exact(solution.t) - solution.x)) < 1e-10
    period = 10.7314652348828  # REFERENCES.md R1
    assert np.max(np.abs(problem.exact(np.array([period, 7 * period])) - problem.x0)) < 1e-12
    with pytest.raises(ValueError, match="x0 = "):
        problems.free_rigid_body_exact([0.6, 0.1, 0.8], problems.INERTIA, 1.0)


def test_not_applicable_names_the_error_of_a_method_that_cannot_run():
    problem = problems.relaxing_rigid_body(eps=0.1)
    assert not_applicable(geomint.RK4(), problem.system, problem.x0) is None
    assert not_applicable(geomint.Integrator(), problem.system, problem.x0).startswith("NotImplementedError")


def _pendula_start(N, seed=0):
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(-2.0, 2.0, N), rng.uniform(-1.0, 1.0, N), [0.0]])


#: the benchmark's systems (experiments/engine_speed_rn.py, "Against hand-written exact steps") and smaller ones of
#: the same families: (system, x0, h, steps) of a short run, built when the test runs
FLOOR_CASES = {
    "gas containers": lambda: (geomint.systems.gas_containers(), np.array([0.6, 0.4, 0.2, -0.1]), 0.05, 60),
    "gas containers, gamma 0.3": lambda: (
        geomint.systems.gas_containers(gamma=0.3),
        np.array([1.3, -0.2, 0.5, 0.1]),
        0.1,
        30,
    ),
    "Euler Zeitlin N = 5": lambda: (
        geomint.systems.euler_zeitlin(5, eps=0.05),
        geomint.systems.euler_initial_state(5),
        0.05,
        40,
    ),
    "Euler Zeitlin N = 7": lambda: (
        geomint.systems.euler_zeitlin(7, eps=0.2),
        geomint.systems.euler_initial_state(7),
        0.05,
        10,
    ),
    "random Fish n = 64": lambda: (
        geomint.systems.random_fish(64, seed=1, eps=0.2),
        np.random.default_rng(64).normal(size=64) * 0.5,
        0.05,
        6,
    ),
    "random Fish n = 5": lambda: (
        geomint.systems.random_fish(5, seed=3, eps=1.0),
        np.random.default_rng(5).normal(size=5),
        0.1,
        40,
    ),
    "pendula N = 128": lambda: (geomint.systems.damped_pendula(128), _pendula_start(128), 0.1, 40),
    "pendula N = 4, matrices": lambda: (
        geomint.systems.damped_pendula(4, gamma=0.2, form="matrix"),
        _pendula_start(4, seed=7),
        0.1,
        40,
    ),
}


@pytest.mark.parametrize("case", FLOOR_CASES)
def test_hand_written_floors_are_exact_and_take_geomints_step(case):
    """Each floor of experiments/floors_rn.py is exact at every step of a short run (the library's acceptance: H
    within 4 ulps of its terms of H(x0), S not against its direction by more than 2 ulps; converged at every step)
    and lands where geomint's Gonzalez lands: the same scheme, or it is not a floor of it (a floor with another
    discrete gradient, Gonzalez's correction left out, lands 1e-5 to 1e-3 away; the solvers' own stopping points
    are 1e-11 apart: geomint's fixed point stops short of the root on the pendula, docs/engine_rn_speed.md)."""
    system, x0, h, steps = FLOOR_CASES[case]()
    run = floor_for(system).run(x0, h, steps)
    assert run.failures == 0 and run.unconverged == 0, run
    assert run.worst_H <= ACCEPT_ULPS and run.worst_S <= ACCEPT_S_ULPS, run
    assert run.iterations >= steps and run.refreshes >= 1
    solution = geomint.solve(system, x0, (0.0, steps * h), h, method=geomint.Gonzalez(), save_every=None)
    assert np.max(np.abs(run.x - solution.x_final)) < 1e-10 * max(1.0, np.max(np.abs(solution.x_final)))


def test_floor_for_refuses_what_it_does_not_write():
    assert floor_for(geomint.systems.euler_galerkin(5)) is None
    assert floor_for(geomint.systems.heat_bath_oscillator()) is None
    assert floor_for(geomint.systems.random_fish(4).with_effects(eps=0.0)) is None


#: the relaxing rigid body of experiments/engine_speed.py: moving until t ~ 50, then at its pole
BODY_X0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])


def _body_final(steps, **options):
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    return geomint.solve(body, BODY_X0, (0.0, 0.01 * steps), 0.01, save_every=None, **options).x_final


@pytest.mark.parametrize("strict", [True, False])
def test_exact_gonzalez_floor_is_exact_and_takes_geomints_step(strict):
    """Over the moving phase and onto the pole every step keeps the library's acceptance, and the floor lands where
    geomint's Gonzalez lands (the same scheme: not a cheaper one)."""
    run = floors.gonzalez_exact(0.5, 1.0, 1.5, 0.1, BODY_X0, 0.01, 6000, strict=strict)
    assert run.failures == 0
    assert run.worst_H <= floors.ACCEPT_ULPS and run.worst_S <= floors.ACCEPT_S_ULPS
    assert run.iterations >= 6000
    assert np.max(np.abs(run.x - _body_final(6000))) < 1e-11
    moving = floors.gonzalez_exact(0.5, 1.0, 1.5, 0.1, BODY_X0, 0.01, 1000, strict=strict)
    assert np.max(np.abs(moving.x - _body_final(1000))) < 1e-13


def test_exact_gonzalez_floor_check_fails_when_the_floor_is_not_the_step():
    """The checks can fail: Newton stopped after one iteration misses the acceptance, and the floor with its eps
    term dropped (a cheaper, conservative scheme, exact too) does not land where geomint does."""
    stopped = floors.gonzalez_exact(0.5, 1.0, 1.5, 0.1, BODY_X0, 0.01, 2000, max_iter=1)
    assert stopped.failures > 0
    dropped = floors.gonzalez_exact(0.5, 1.0, 1.5, 0.0, BODY_X0, 0.01, 1000)
    assert dropped.failures == 0
    assert np.max(np.abs(dropped.x - _body_final(1000))) > 1e-3


def test_exact_gonzalez_ensemble_floor_is_exact_and_matches_solve_ensemble():
    starts = np.random.default_rng(3).normal(size=(6, 3))
    starts /= np.linalg.norm(starts, axis=1)[:, None]
    run = floors.gonzalez_exact_ensemble(0.5, 1.0, 1.5, 0.1, starts, 0.01, 300)
    assert run.failures == 0 and run.x.shape == (6, 3)
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    ensemble = geomint.solve_ensemble(body, starts, (0.0, 3.0), 0.01, method=geomint.Gonzalez(), save_every=None)
    assert np.max(np.abs(run.x - ensemble.x[:, -1])) < 1e-13


def test_startup_page_judges_each_line_by_its_median():
    from experiments import startup

    users = [(9.0, 10.0, 0.9, 1.1), (11.0, 12.0, 1.2, 1.4), (9.5, 10.5, 0.95, 1.2)]
    text = startup.page([0.01, 0.4, 0.02], [2.0, 3.5, 2.5], [16.0, 14.0, 14.5], users)
    lines = {row.split(" | ")[0].lstrip("| "): row for row in text.splitlines() if row.startswith("| ")}
    assert "**0.02** | 0.3 | holds" in lines["`import geomint`, warm (in the process)"]
    assert "**2.50** | 3 | holds" in lines["`geomint run rigid_body_distinct`, warm (the process)"]
    assert "**14.50** | 15 | holds" in lines["the same, cold: an empty cache (the process)"]
    assert "**9.50** | 10 | holds" in lines["first `solve` of a new user system, compilation included"]
    assert "**0.95** | 1 | holds" in lines["a second process: import, system, solve (in the process)"]
    late = startup.page([0.01], [3.1], [15.2], [(10.2, 11.0, 1.01, 1.2)])
    assert late.count("| missed |") == 4 and late.count("| holds |") == 1
