"""Solution.save / geomint.load round trips, metadata without pickles, to_xarray."""

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
    assert meta["system"] == {"name": "relaxing_rigid_body", "params": [0.5, 1.0, 1.5], "eps": 0.1, "hamiltonian": True}
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
