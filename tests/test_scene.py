"""Scenes: bundled paper examples, effects switches, observables, round trips, the level-set sampler."""

import numpy as np
import pytest

import geomint
from geomint import analysis, level_set
from geomint.scene import OBSERVABLES, Scene, bundled_scenes, load, run_scene
from geomint.testing import term_scale

EPS = np.finfo(np.float64).eps
BUNDLED = sorted(bundled_scenes())
SHORT_STEPS = 60


def test_every_paper_example_and_a_system_written_as_formulas_is_bundled():
    assert BUNDLED == sorted(
        [
            "rigid_body_distinct",
            "rigid_body_equal",
            "oscillator_s0",
            "oscillator_z2",
            "degenerate_example1",
            "degenerate_example2",
            "lorenz_nevir",
        ]
    )
    assert "H" in load("lorenz_nevir").expressions


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_scene_short_run_keeps_H_exact_and_never_raises_S(name):
    scene = load(name)
    short = scene.replace(duration=SHORT_STEPS * scene.h, every=1, figures=(), record=("x", "H", "S"))
    result = run_scene(short)
    totals = result.summary()["totals"]
    assert totals["failed"] == 0
    assert totals["S_rises"] == 0
    assert totals["n_steps"] == SHORT_STEPS * scene.n_trajectories
    X, H = result.records["x"], result.records["H"]
    for x, values in zip(X, H):
        for n in range(SHORT_STEPS):
            scale = term_scale(values[n], values[n + 1], result.system.grad_H(x[n]), x[n])
            assert abs(values[n + 1] - values[n]) <= 16 * EPS * scale, (name, n)
    assert totals["max_energy_error"] <= SHORT_STEPS * 16 * EPS * max(
        term_scale(h[0], h[0], result.system.grad_H(x[0]), x[0]) / abs(h[0]) for x, h in zip(X, H)
    )


def _final_states(name):
    result = run_scene(load(name).replace(figures=(), record=("x",), every="final"))
    assert result.success
    return result, np.array([sol.x_final for sol in result.solutions])


def test_rigid_body_distinct_relaxes_to_the_poles_of_the_largest_coefficient():
    result, final = _final_states("rigid_body_distinct")
    H0 = result.scene.level_set["H0"]
    c = result.scene.parameters["c"]
    np.testing.assert_allclose(np.abs(final[:, 2]), np.sqrt(2 * H0 / c), rtol=1e-6)
    np.testing.assert_allclose([sol.S[-1] for sol in result.solutions], H0 / c, rtol=1e-6)


def test_rigid_body_equal_relaxes_onto_the_circle_of_equilibria():
    result, final = _final_states("rigid_body_equal")
    H0, a = result.scene.level_set["H0"], result.scene.parameters["a"]
    assert np.max(np.abs(final[:, 2])) < 1e-4
    np.testing.assert_allclose(np.hypot(final[:, 0], final[:, 1]), np.sqrt(2 * H0 / a), rtol=1e-6)
    angles = np.arctan2(final[:, 1], final[:, 0])
    assert np.ptp(angles) > 3.0  # a circle of equilibria: the end points spread round it


def test_oscillator_s0_runs_horizontal_circles():
    result = run_scene(load("oscillator_s0").replace(figures=()))
    for sol in result.solutions:
        assert np.ptp(sol.x[:, 2]) == 0.0  # z never moves: dz/dt = -(x^2 + y^2) S'(z) = 0
        np.testing.assert_allclose(sol.x_final, sol.x[0], atol=1e-4)  # one period, 2 pi


def test_oscillator_z2_is_attracted_to_the_equator():
    result, final = _final_states("oscillator_z2")
    start = np.array([sol.x[0] for sol in result.solutions])
    assert np.all(np.abs(final[:, 2]) < 0.1 * np.abs(start[:, 2]))


def test_degenerate_examples_plane_y0_invariant_in_example_1_only():
    one = run_scene(load("degenerate_example1").replace(figures=()))
    two = run_scene(load("degenerate_example2").replace(figures=()))
    for sol in one.solutions:
        if sol.x[0, 1] == 0.0:
            assert np.all(sol.x[:, 1] == 0.0)
            assert np.allclose(np.abs(sol.x_final), [1.0, 0.0, 0.0], atol=1e-4)  # z ~ exp(-t)
    for sol in two.solutions:
        assert sol.x[0, 1] == 0.0 and sol.x[0, 2] != 0.0
        assert np.max(np.abs(sol.x[:, 1])) > 1e-3


RIGID = dict(
    system="relaxing_rigid_body",
    parameters={"a": 0.5, "b": 1.0, "c": 1.5},
    points=[[np.cos(1.1), 0.0, np.sin(1.1)], [0.2, 0.9, -0.3]],
    h=0.05,
    duration=5.0,
    figures=(),
)


@pytest.mark.parametrize("method", ["gonzalez", "rk4"])
def test_dissipation_off_is_the_hamiltonian_integrator(method):
    scene = Scene(**RIGID, eps=0.0, integrator=method)
    result = run_scene(scene)
    direct = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.0)
    for x0, sol in zip(scene.points, result.solutions):
        reference = geomint.solve(direct, x0, (0.0, 5.0), 0.05, method=method)
        np.testing.assert_array_equal(sol.x, reference.x)


def test_hamiltonian_off_is_the_gradient_flow():
    scene = Scene(**RIGID, eps=0.3, hamiltonian=False)
    result = run_scene(scene)
    gradient = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.3).with_effects(hamiltonian=False)
    for x0, sol in zip(scene.points, result.solutions):
        np.testing.assert_array_equal(sol.x, geomint.solve(gradient, x0, (0.0, 5.0), 0.05).x)
    full = run_scene(scene.replace(hamiltonian=True))
    assert not np.array_equal(full.solutions[0].x, result.solutions[0].x)


def test_only_recorded_observables_are_stored():
    result = run_scene(Scene(**RIGID, record=("S",)))
    assert set(result.records) == {"rows", "t", "S"}
    final = run_scene(Scene(**RIGID, record=(), every="final"))
    assert set(final.records) == {"rows", "t"}
    assert all(len(sol.t) == 2 for sol in final.solutions)


def test_observables_match_the_system():
    result = run_scene(Scene(**RIGID, eps=0.4, record=tuple(OBSERVABLES), every=7))
    system = result.system
    for i, sol in enumerate(result.solutions):
        np.testing.assert_array_equal(result.records["sigma"][i], system.sigma(sol.x))
        np.testing.assert_array_equal(result.records["dS_dt"][i], system.dS_dt(sol.x))
        np.testing.assert_array_equal(result.records["xi"][i], system.xi(sol.x))
        np.testing.assert_array_equal(result.records["energy_error"][i], np.abs(sol.H - sol.H[0]) / abs(sol.H[0]))
    assert np.all(result.records["dS_dt"] <= 0.0)


def test_progress_reports_every_step_once():
    calls = []
    scene = Scene(**{**RIGID, "duration": 250_000 * 1e-4, "h": 1e-4}, integrator="rk4", every="final")
    run_scene(scene, progress=calls.append)
    assert sum(calls) == scene.steps_per_trajectory * scene.n_trajectories
    assert len(calls) >= 2 * 2 and all(c > 0 for c in calls)  # chunks of ~0.1 s: several per trajectory


def test_scene_round_trips_through_its_dict_and_resolution():
    for name in BUNDLED:
        scene = load(name)
        assert Scene.from_dict(scene.to_dict(), name=name) == scene
        resolved = scene.resolved()
        assert resolved.resolved() == resolved
        assert run_scene(resolved.replace(duration=2 * scene.h, figures=())).success


def test_resolved_writes_every_default():
    resolved = Scene(system="dissipative_oscillator", level_set={"H0": 0.5, "n": 3}, h=0.1, duration=1.0).resolved()
    assert resolved.parameters == {"coefficients": [0.0, 0.0, 1.0]}
    assert resolved.integrator == {"name": "gonzalez", "max_newton_iter": 50, "compensated": True}
    assert resolved.level_set["center"] == [0.0, 0.0, 0.0]


def test_projection_needs_geomint_projected():
    scene = Scene(**RIGID, projection=True)
    if hasattr(geomint, "Projected"):
        assert run_scene(scene).success
    else:
        with pytest.raises(geomint.SceneError, match=r"`effects.projection`: projection is not available"):
            run_scene(scene)


# -- the level-set sampler ------------------------------------------------------------------
@pytest.mark.parametrize(
    "system, H0",
    [
        (geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5), 0.7),
        (geomint.systems.quartic_rigid_body(0.5, 1.0, 1.5, 0.5), 2.0),
        (geomint.systems.degenerate_example(2), 1.3),
    ],
)
def test_level_set_sample_lies_on_the_level_set(system, H0):
    points = level_set.sample(system, H0, 50)
    assert points.shape == (50, 3)
    assert np.all(np.abs(system.H(points) - H0) <= 4 * EPS * H0)
    directions = level_set.fibonacci_directions(50)
    center = level_set.energy_minimiser(system)
    radial = (points - center) / np.linalg.norm(points - center, axis=1)[:, None]
    np.testing.assert_allclose(radial, directions, atol=1e-12)


def test_fibonacci_directions_are_unit_and_spread():
    U = level_set.fibonacci_directions(400)
    np.testing.assert_allclose(np.linalg.norm(U, axis=1), 1.0, rtol=1e-15)
    assert abs(U.mean(axis=0)).max() < 1e-2
    nearest = np.sort(np.linalg.norm(U[:, None] - U[None], axis=2), axis=1)[:, 1]
    assert nearest.min() > 0.5 * np.sqrt(4 * np.pi / 400)


def test_level_set_below_the_centre_is_refused():
    system = geomint.systems.relaxing_rigid_body()
    with pytest.raises(ValueError, match=r"must enclose its centre"):
        level_set.sample(system, -1.0, 5)


@pytest.mark.parametrize(
    "system, H0, expected",
    [
        (
            geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0),
            0.75,
            {
                (0, 0, 1): "stable",
                (0, 0, -1): "stable",
                (0, 1, 0): "unstable",
                (0, -1, 0): "unstable",
                (1, 0, 0): "unstable",
                (-1, 0, 0): "unstable",
            },
        ),
        (geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0)), 0.5, {(0, 0, 1): "unstable", (0, 0, -1): "unstable"}),
        (geomint.systems.dissipative_oscillator((0.0,)), 0.5, {(0, 0, 1): "neutral", (0, 0, -1): "neutral"}),
        (
            geomint.systems.degenerate_example(1),
            0.5,
            {(0, 0, 1): "unstable", (0, 0, -1): "unstable", (1, 0, 0): "stable", (-1, 0, 0): "unstable"},
        ),
    ],
)
def test_equilibria_on_the_level_set_match_the_paper(system, H0, expected):
    found = analysis.equilibrium_points(system, H0, np.zeros(3))
    kinds = {tuple(int(v) for v in np.sign(np.where(np.abs(x) > 1e-6, x, 0.0))): kind for x, kind in found}
    assert len(found) == len(expected) and kinds == expected
    for x, _ in found:
        assert abs(system.H(x) - H0) < 1e-12


def test_a_scene_written_as_formulas_runs_the_system_from_expressions_bit_for_bit():
    scene = load("lorenz_nevir").replace(duration=0.2, figures=())
    result = run_scene(scene)
    spec = scene.expressions
    direct = geomint.MetriplecticSystem.from_expressions(**spec, params=scene.parameters, eps=scene.eps)
    for x0, sol in zip(scene.points, result.solutions):
        np.testing.assert_array_equal(sol.x, geomint.solve(direct, x0, (0.0, 0.2), scene.h, save_every=scene.every).x)


def test_a_composition_scene_names_its_base_and_serialises():
    scene = Scene(**RIGID, integrator={"name": "yoshida4", "base": {"name": "gonzalez", "max_newton_iter": 20}})
    result = run_scene(scene)
    assert result.method == geomint.Yoshida4(base=geomint.Gonzalez(max_newton_iter=20))
    summary = result.summary()
    assert summary["method"] == {
        "name": "yoshida4",
        "monotone": False,
        "base": {"name": "gonzalez", "max_newton_iter": 20, "compensated": True},
    }
    assert Scene.from_dict(result.scene.to_dict()) == result.scene


DOMAIN = dict(
    system="domain",
    expressions={"H": "(x**2 + y**2)/2 + z**2", "S": "sqrt(z + 1.2)", "J": ["0", "0", "1"]},
    parameters={},
    eps=3.0,
    # S is defined for z > -1.2 and the flow lowers z towards -sqrt(H) on its level set: the last two leave the
    # domain (H = 1.485 and 5.5 > 1.44), the first does not (H = 0.215)
    points=[[0.5, 0.0, 0.3], [0.0, 1.7, 0.2], [0.0, -3.0, 1.0]],
    h=0.05,
    duration=10.0,
    record=tuple(OBSERVABLES),
    every=3,
    figures=(),
)


def test_trajectories_run_together_or_one_by_one_give_the_same_records_bit_for_bit(monkeypatch):
    """Two of the three trajectories leave the domain of S mid-run (NaN-padded rows after them)."""
    scene = Scene(**DOMAIN)
    calls = []
    together = run_scene(scene, progress=calls.append)
    assert sum(calls) == scene.steps_per_trajectory * scene.n_trajectories
    assert [sol.status for sol in together.solutions] == [0, -2, -2]
    monkeypatch.setattr("geomint.scene.run.ENSEMBLE_STEPS", 0)  # one by one through solve
    alone = run_scene(scene)
    assert set(together.records) == set(alone.records)
    for name, values in together.records.items():
        assert values.dtype == alone.records[name].dtype and values.tobytes() == alone.records[name].tobytes(), name
    for a, b in zip(together.solutions, alone.solutions):
        assert a.message == b.message and a.x.tobytes() == b.x.tobytes()


def test_a_resolved_scene_is_resolved_once():
    resolved = load("rigid_body_distinct").resolved()
    assert resolved.resolved() is resolved
    system, method, states = resolved.built()
    assert run_scene(resolved).system is system
    np.testing.assert_array_equal(resolved.initial_states(), states)
