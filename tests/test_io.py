"""Solution.save / geomint.load round trips, metadata without pickles, to_xarray."""

import dataclasses
import json
import sys

import numpy as np
import pytest

import geomint
from geomint.results import io

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
X0 = [0.6, 0.0, 0.8]


@pytest.mark.parametrize(
    "method",
    [
        geomint.Gonzalez(),
        geomint.Strang(gradient_part=geomint.RK4()),
        geomint.Projected(geomint.Yoshida4(), symmetric=True),
        geomint.AVF(nodes=2),
    ],
)
def test_a_saved_solution_loads_back_equal(tmp_path, method):
    sol = geomint.solve(BODY, X0, (0.0, 2.0), 0.1, method=method, save_every=3)
    path = sol.save(tmp_path / "run", system=BODY)
    assert path == tmp_path / "run.npz"
    again = geomint.load(path)
    for key in ("t", "x", "H", "S"):
        np.testing.assert_array_equal(getattr(again, key), getattr(sol, key))
    assert again.method == method
    assert (again.success, again.status, again.message, again.n_steps, again.n_newton, again.nfev) == (
        sol.success,
        sol.status,
        sol.message,
        sol.n_steps,
        sol.n_newton,
        sol.nfev,
    )


def test_the_file_holds_no_pickles_and_names_the_system_and_version(tmp_path):
    sol = geomint.solve(BODY, X0, (0.0, 1.0), 0.1)
    path = sol.save(tmp_path / "run.npz", system=BODY)
    with np.load(path, allow_pickle=False) as data:
        assert sorted(data.files) == ["H", "S", "metadata", "t", "x"]
        meta = json.loads(str(data["metadata"]))
    assert meta["geomint"] == geomint.__version__ and meta["format"] == "geomint-solution"
    assert meta["system"] == {
        "name": "relaxing_rigid_body",
        "form": "Fish",
        "dim": 3,
        "variables": ["x", "y", "z"],
        "direction": -1.0,
        "params": [0.5, 1.0, 1.5],
        "eps": 0.1,
        "hamiltonian": True,
    }
    assert (meta["dim"], meta["S_direction"]) == (3, -1.0)
    assert meta["method"] == {"name": "gonzalez", "max_newton_iter": 50, "compensated": True}
    assert "git" not in json.dumps(meta)


def test_a_failed_run_keeps_its_status_and_failed_step(tmp_path):
    sol = geomint.solve(BODY, X0, (0.0, 2.0), 0.5, method=geomint.Gonzalez(max_newton_iter=1))
    assert not sol.success
    again = geomint.load(sol.save(tmp_path / "failed"))
    assert (again.success, again.status, again.failed_step, again.message) == (
        False,
        sol.status,
        sol.failed_step,
        sol.message,
    )


def test_a_system_from_formulas_records_its_formulas(tmp_path):
    system = geomint.MetriplecticSystem.from_expressions(
        H="(x**2 + y**2 + z**2)/2", S="z**2/2", J=("0", "0", "k"), params={"k": 1.0}, eps=0.2, name="oscillator"
    )
    sol = geomint.solve(system, X0, (0.0, 1.0), 0.1)
    meta = io.read_metadata(sol.save(tmp_path / "formulas", system=system))
    assert meta["system"]["expressions"] == {
        "H": "(x**2 + y**2 + z**2)/2",
        "S": "z**2/2",
        "J": ["0", "0", "k"],
        "params": {"k": 1.0},
    }


def test_a_file_that_is_not_a_solution_is_refused_by_name(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, a=np.zeros(3))
    with pytest.raises(ValueError, match=r"is not a geomint solution file \(no metadata\)"):
        geomint.load(path)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not an archive")  # numpy would read it as a pickle and advise loading it unsafely
    with pytest.raises(ValueError, match=r"garbage.npz' is not a geomint solution file \(not an .npz archive\)"):
        geomint.load(garbage)
    with pytest.raises(ValueError, match=r"not an .npz archive"):
        io.read_metadata(garbage)


def test_to_xarray_has_named_dimensions_and_the_metadata():
    xarray = pytest.importorskip("xarray")
    sol = geomint.solve(BODY, X0, (0.0, 1.0), 0.1)
    data = sol.to_xarray(system=BODY)
    assert isinstance(data, xarray.Dataset)
    assert data["x"].dims == ("t", "component") and list(data["component"].values) == ["x", "y", "z"]
    np.testing.assert_array_equal(data["x"].sel(component="z").values, sol.x[:, 2])
    assert json.loads(data.attrs["method"])["name"] == "gonzalez" and data.attrs["success"] == 1


def test_to_xarray_without_xarray_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "xarray", None)
    sol = geomint.solve(BODY, X0, (0.0, 1.0), 0.1)
    with pytest.raises(ImportError, match=r"pip install geomint\[xarray\]"):
        sol.to_xarray()


def test_the_accuracy_flags_survive_save_and_load(tmp_path):
    """A run flagged as far beyond the dynamics keeps its caveats and step ratio through a file (and xarray)."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    with pytest.warns(geomint.AccuracyWarning):
        sol = geomint.solve(body, [0.6, 0.0, 0.8], (0.0, 2e4), 1e4)
    again = geomint.load(sol.save(tmp_path / "flagged"))
    assert sol.caveats and again.caveats == sol.caveats and again.step_ratio == sol.step_ratio > 1e3
    plain = geomint.load(geomint.solve(body, [0.6, 0.0, 0.8], (0.0, 1.0), 0.1).save(tmp_path / "plain"))
    assert plain.caveats == () and 0 < plain.step_ratio < 1


# -- systems in R^n -------------------------------------------------------------------------------
PENDULA = geomint.systems.damped_pendula(2, gamma=0.5)
PENDULA_X0 = [0.3, -1.0, 0.5, 0.2, 0.0]
FISH = geomint.systems.random_fish(6, seed=3, eps=0.5)
FISH_X0 = np.linspace(-0.5, 0.6, 6)


@pytest.mark.parametrize(
    "system, x0, form, direction",
    [(PENDULA, PENDULA_X0, "GENERIC", 1.0), (FISH, FISH_X0, "Fish", -1.0)],
    ids=["generic", "fish"],
)
def test_a_run_in_rn_round_trips_with_its_dimension_variables_form_and_direction(tmp_path, system, x0, form, direction):
    sol = geomint.solve(system, x0, (0.0, 2.0), 0.1, save_every=3)
    assert sol.S_direction == direction and sol.x.shape == (8, system.dim)
    path = sol.save(tmp_path / "run", system=system)
    again = geomint.load(path)
    for key in ("t", "x", "H", "S"):
        np.testing.assert_array_equal(getattr(again, key), getattr(sol, key))
    assert again.x.shape == (8, system.dim) and again.S_direction == direction and again.method == sol.method
    assert (again.S_rises, again.S_falls, again.S_against_direction) == (sol.S_rises, sol.S_falls, 0)
    meta = io.read_metadata(path)
    assert (meta["dim"], meta["S_direction"]) == (system.dim, direction)
    assert {key: meta["system"][key] for key in ("name", "form", "dim", "variables", "direction")} == {
        "name": system.name,
        "form": form,
        "dim": system.dim,
        "variables": list(system.variables),
        "direction": direction,
    }
    bare = io.read_metadata(sol.save(tmp_path / "bare"))  # without the system: the solution's own
    assert (bare["dim"], bare["S_direction"], bare["system"]) == (system.dim, direction, None)


def test_a_generic_run_counts_the_falls_of_its_entropy_as_against_its_direction():
    """S_rises counts rises whatever the form; for GENERIC the steps against the entropy's direction are falls."""
    sol = geomint.solve(PENDULA, PENDULA_X0, (0.0, 3.0), 0.1)
    assert sol.S_rises == sol.count_S_rises() > 10 and sol.S_falls == 0 and sol.S_against_direction == 0
    reversed_S = dataclasses.replace(sol, S=sol.S[::-1].copy())
    assert reversed_S.S_falls == sol.S_rises and reversed_S.S_against_direction == sol.S_rises
    assert reversed_S.count_S_against_direction(ulps=1e30) == 0 and reversed_S.S_rises == 0
    fish = geomint.solve(FISH, FISH_X0, (0.0, 3.0), 0.1)
    assert fish.S_direction == -1.0 and fish.S_falls > 10 and fish.S_rises == fish.S_against_direction == 0
    assert dataclasses.replace(fish, S=fish.S[::-1].copy()).S_against_direction == fish.S_falls
    assert geomint.solve(BODY, X0, (0.0, 1.0), 0.1).S_direction == -1.0


def test_to_xarray_in_rn_labels_the_components_with_the_variables_and_says_s_is_the_entropy():
    pytest.importorskip("xarray")
    sol = geomint.solve(PENDULA, PENDULA_X0, (0.0, 1.0), 0.1)
    data = sol.to_xarray(system=PENDULA)
    assert data["x"].dims == ("t", "component") and list(data["component"].values) == ["q1", "q2", "p1", "p2", "s"]
    np.testing.assert_array_equal(data["x"].sel(component="s").values, sol.x[:, 4])
    assert data.attrs["S_direction"] == 1.0 and data.attrs["S_meaning"] == "entropy: never falls (GENERIC)"
    assert data["S"].attrs == {"long_name": "entropy", "direction": "never falls"}
    assert json.loads(data.attrs["system"])["form"] == "GENERIC" and data.attrs["dim"] == 5
    plain = geomint.solve(FISH, FISH_X0, (0.0, 1.0), 0.1).to_xarray()  # no system: default names
    assert list(plain["component"].values) == [f"x{i}" for i in range(6)] and plain.attrs["S_direction"] == -1.0
    assert plain["S"].attrs["long_name"] == "Casimir"
    r3 = geomint.solve(BODY, X0, (0.0, 1.0), 0.1).to_xarray()
    assert list(r3["component"].values) == ["x", "y", "z"] and "Casimir" in r3.attrs["S_meaning"]


def test_a_system_of_another_dimension_or_direction_is_refused_by_name(tmp_path):
    sol = geomint.solve(PENDULA, PENDULA_X0, (0.0, 1.0), 0.1)
    with pytest.raises(ValueError, match=r"`system` 'random_fish_6' \(in R\^6, S direction -1\) is not the system"):
        sol.save(tmp_path / "wrong", system=FISH)
    four = geomint.systems.damped_pendula(2).with_effects()  # same dimension, same direction: accepted
    assert sol.save(tmp_path / "right", system=four).exists()
    gas = geomint.systems.gas_containers()
    fish4 = geomint.systems.random_fish(4)
    run = geomint.solve(gas, [1.5, 0.0, 2.0, 2.0], (0.0, 1.0), 0.1)
    with pytest.raises(ValueError, match=r"S direction -1\) is not the system of this solution \(states in R\^4, S"):
        run.to_xarray(system=fish4)
