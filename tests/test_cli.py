"""The command line: run, show, list, drift; exit codes; errors without tracebacks."""

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from test_scene_errors import VALID

from geomint import Gonzalez, Projected, Yoshida4
from geomint.cli import BAD_INPUT, FAILED, OK, main
from geomint.integrators.data import short_names
from geomint.scene import Scene, SceneError, bundled_scenes

SHORT = (
    VALID.replace('title = "test"', 'title = "short relaxing rigid body"')
    .replace("eps = 0.1", "eps = 0.5")
    .replace("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 0.6471, n = 3 }")
    .replace("duration = 0.5", "duration = 2.0")
    .replace("every = 1", 'record = ["x", "S", "dS_dt"]\nevery = 4')
    .replace("figures = []", 'figures = ["overview", "invariants", "trajectories"]')
)


def _scene(tmp_path, text=SHORT, name="short"):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def test_run_writes_data_summary_and_figures(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(_scene(tmp_path)), "--out", str(out)]) == OK
    captured = capsys.readouterr()
    report = captured.out
    assert "3 trajectories, 120 steps" in report and "S rises: 0" in report
    # the kernels are loaded (or compiled, said so before the wait) before the progress bar starts, and the time
    # it took is said
    assert re.match(
        r"geomint: loading the compiled kernels \.\.\. (\d+\.\d\d s\n|not cached yet: compiling them "
        r"for gonzalez \(.*\)\ngeomint: compiled in \d+\.\d\d s\n)",
        captured.err,
    )
    # the second line says what ran, in words (it was a repr and a dict); machine epsilon is ulp, ε the dissipation
    assert report.splitlines()[1] == (
        "relaxing_rigid_body with a = 0.5, b = 1, c = 1.5: Hamiltonian part and "
        "dissipation ε = 0.5; integrated with gonzalez (max_newton_iter = 50, compensated "
        "= true), h = 0.05 from t = 0 to 2."
    )
    assert re.search(r"max \|H - H0\|/\|H0\| = \S+ \(\d+\.\d ulp\); S rises: 0", report) and " eps" not in report
    data = np.load(out / "short.npz")
    assert sorted(data.files) == ["S", "dS_dt", "rows", "status", "t", "x", "x0"]
    assert data["x"].shape == (3, 11, 3) and np.all(data["status"] == 0)
    summary = json.loads((out / "short.summary.json").read_text())
    assert summary["totals"]["n_steps"] == 120 and summary["totals"]["S_rises"] == 0
    assert all(t["energy_error_in_ulp"] == t["energy_error"] / np.finfo(float).eps for t in summary["trajectories"])
    assert summary["totals"]["max_energy_error"] < 1e-14
    assert summary["totals"]["n_newton"] > 0 and summary["totals"]["wall_s"] > 0
    assert set(summary["versions"]) == {"geomint", "python", "numpy", "scipy", "numba"}
    assert summary["scene"]["integrator"]["method"] == {"name": "gonzalez", "max_newton_iter": 50, "compensated": True}
    for figure in ("overview", "invariants", "trajectories"):
        png = out / f"short.{figure}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_quiet_prints_nothing(tmp_path, capsys):
    assert main(["run", str(_scene(tmp_path)), "--out", str(tmp_path / "q"), "--quiet"]) == OK
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""


def test_numerical_failure_exits_1_and_keeps_results(tmp_path, capsys):
    # one Newton iteration a start, on a stiff scene (h eps |grad H|^2 = 30 to 100): no start reaches the root
    text = SHORT.replace('method = "gonzalez"', 'method = { name = "gonzalez", max_newton_iter = 1 }').replace(
        "eps = 0.5", "eps = 1000.0"
    )
    out = tmp_path / "fail"
    assert main(["run", str(_scene(tmp_path, text)), "--out", str(out), "--quiet"]) == FAILED
    assert "geomint: run failed: x0 = " in capsys.readouterr().err
    summary = json.loads((out / "short.summary.json").read_text())
    assert summary["totals"]["failed"] == 3
    assert (
        "Step 1 (t = 0 -> 0.05) failed: the Newton iteration did not converge" in summary["trajectories"][0]["message"]
    )


@pytest.mark.parametrize("command", ["run", "show"])
def test_bad_scene_exits_2_with_one_line_and_no_traceback(tmp_path, capsys, command):
    path = _scene(tmp_path, SHORT.replace("eps = 0.5", "eps = -0.5"))
    assert main([command, str(path)]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err == f"geomint: error: {path}: `effects.eps`: must be >= 0; got -0.5.\n"
    with pytest.raises(SceneError, match=r"`effects.eps`"):
        main([command, str(path), "--traceback"])


def test_unknown_scene_exits_2(capsys):
    assert main(["show", "no_such_scene"]) == BAD_INPUT
    assert "no_such_scene: no such scene file, nor a bundled scene" in capsys.readouterr().err


def test_show_prints_the_resolved_scene_as_toml(capsys):
    assert main(["show", "oscillator_z2"]) == OK
    text = capsys.readouterr().out
    data = tomllib.loads(text)
    resolved = Scene.from_toml(bundled_scenes()["oscillator_z2"]).resolved()
    assert Scene.from_dict(data, name="oscillator_z2") == resolved
    assert data["initial"]["level_set"]["center"] == [0.0, 0.0, 0.0]
    assert text.count("\n#   [") == 8  # the sampled initial states


def test_list_names_systems_integrators_and_scenes(capsys):
    assert main(["list"]) == OK
    text = capsys.readouterr().out
    for name in [
        "relaxing_rigid_body",
        "degenerate_example",
        "gonzalez",
        "rk4",
        "dS_dt",
        "overview",
        *bundled_scenes(),
    ]:
        assert f"  {name} " in text


def test_drift_still_runs(capsys):
    assert main(["drift", "--steps", "200"]) == OK
    assert "gonzalez" in capsys.readouterr().out


def test_console_script_runs_a_bundled_scene(tmp_path):
    """The README's main job, as a user runs it (a fresh process)."""
    done = subprocess.run(
        [sys.executable, "-m", "geomint.cli", "run", "oscillator_s0", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])},
    )
    assert done.returncode == OK, done.stderr
    assert (tmp_path / "oscillator_s0.overview.png").exists()
    assert (tmp_path / "oscillator_s0.summary.json").exists()


def test_bad_argument_exits_2(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["run"])
    assert exit_info.value.code == BAD_INPUT


WHOLE_FIELD = sorted(
    name for name, cls in short_names().items() if getattr(cls, "flows", ("full",)) != ("hamiltonian",)
)
# a few steps of a scene for each integrator: the composition's base and a splitting's parts named in TOML
OPTIONS = {
    "yoshida4": 'base = "symmetrized_itoh_abe"',
    "suzuki4": 'base = { name = "gonzalez", compensated = false }',
    "strang": 'hamiltonian_part = "rigid_body_flow"\ngradient_part = "gonzalez"',
    "lie": 'hamiltonian_part = "rotor_splitting"\ngradient_part = "itoh_abe"',
}


def test_there_are_18_whole_field_integrators():
    """The table of short names is complete: 15 structure-preserving and RK4, and the three Runge-Kutta pairs."""
    assert len(WHOLE_FIELD) == 18


@pytest.mark.parametrize("method", WHOLE_FIELD)
def test_every_whole_field_integrator_runs_from_the_command_line(tmp_path, method, capsys):
    """In this process (``main`` is the console entry point; the subprocess path is tested elsewhere)."""
    text = (
        SHORT.replace('method = "gonzalez"', f'method = "{method}"\n{OPTIONS.get(method, "")}')
        .replace("duration = 2.0", "duration = 0.4")
        .replace("n = 3", "n = 2")
        .replace('figures = ["overview", "invariants", "trajectories"]', 'figures = ["overview"]')
    )
    out = tmp_path / "out"
    assert main(["run", str(_scene(tmp_path, text)), "--out", str(out), "--quiet"]) == OK, capsys.readouterr().err
    summary = json.loads((out / "short.summary.json").read_text())
    assert summary["method"]["name"] == method and summary["totals"]["failed"] == 0
    written = summary["scene"]["integrator"]["method"]  # a bare name when the method has no options
    assert (written if isinstance(written, str) else written["name"]) == method
    assert np.load(out / "short.npz")["x"].shape == (2, 3, 3)
    assert (out / "short.overview.png").stat().st_size > 20_000


def test_show_prints_a_nested_method_that_reads_back(tmp_path, capsys):
    text = SHORT.replace(
        'method = "gonzalez"', 'method = "yoshida4"\nbase = { name = "gonzalez", max_newton_iter = 9 }'
    )
    assert main(["show", str(_scene(tmp_path, text))]) == OK
    data = tomllib.loads(capsys.readouterr().out)
    assert data["integrator"]["method"] == {
        "name": "yoshida4",
        "monotone": False,
        "base": {"name": "gonzalez", "max_newton_iter": 9, "compensated": True},
    }
    assert Scene.from_dict(data).build_method() == Yoshida4(base=Gonzalez(max_newton_iter=9))


def test_a_composition_of_avf_runs_from_a_scene(tmp_path):
    path = _scene(tmp_path, SHORT.replace('method = "gonzalez"', 'method = "yoshida4"\nbase = "avf"'))
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == OK


def test_projected_takes_its_inner_method_as_a_table(tmp_path):
    text = SHORT.replace(
        'method = "gonzalez"', 'method = { name = "projected", method = "yoshida4", symmetric = true }'
    )
    assert Scene.from_toml(_scene(tmp_path, text)).build_method() == Projected(Yoshida4(), symmetric=True)


@pytest.mark.parametrize(
    "edit, problem",
    [
        (
            'method = "rigid_body_flow"',
            r"`integrator.method`: `method` RigidBodyFlow\(\) integrates the Hamiltonian part only",
        ),
        (
            'method = "strang"\ngradient_part = "rigid_body_flow"',
            r"`integrator.method`: `gradient_part` must integrate the gradient flow",
        ),
        ('method = "yoshida4"\nbase = "itoh_abe"', r"`integrator.method`: `base` must be symmetric and of order 2"),
        ('method = "yoshida4"\nbase = "euler"', r"`integrator.method.base`: unknown integrator 'euler'; known: avf"),
        ('method = "yoshida4"\nbase = { name = "avf", nodes = 99 }', r"`integrator.method.base`: `nodes` must be None"),
        (
            'method = "strang"\nhamiltonian_part = "yoshida4"',
            r"`integrator.method`: `hamiltonian_part` must be a one-step",
        ),
        (
            'method = "strang"\nhamiltonian_part = "oscillator_rotation"',
            r"`integrator.method`: `method` OscillatorRotation\(\) applies only to systems that declare exact_flows",
        ),
        ('method = { name = "yoshida4" }\nbase = "avf"', r"`integrator.base`: give the method's options either"),
    ],
)
def test_integrator_errors_are_one_line_with_the_key(tmp_path, capsys, edit, problem):
    path = _scene(tmp_path, SHORT.replace('method = "gonzalez"', edit))
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search(re.escape(f"geomint: error: {path}: ") + problem, err), err


def test_bare_geomint_prints_help(capsys):
    assert main([]) == OK
    out = capsys.readouterr().out
    assert out.startswith("usage: geomint") and "geomint run SCENE" in out


def test_list_reads_orders_and_traits_from_instances(capsys):
    assert main(["list"]) == OK
    text = capsys.readouterr().out
    assert "property object" not in text
    assert re.search(r"  yoshida6 +order 6, energy-exact, symmetric, implicit;", text)
    assert re.search(r"  strang +order 2, energy-exact, dissipative, symmetric, implicit;", text)
    assert re.search(r"  rigid_body_flow +exact flow, .*Hamiltonian sub-flow only", text)
    assert re.search(r"  rk4 +order 4;", text)


def test_a_scene_written_as_formulas_runs_from_the_command_line(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "geomint.cli", "run", "lorenz_nevir", "--out", str(tmp_path), "--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert done.returncode == OK, done.stderr
    summary = json.loads((tmp_path / "lorenz_nevir.summary.json").read_text())
    assert summary["scene"]["system"]["H"] == "(y**2 + z**2)/2 - r*z"
    assert summary["totals"]["S_rises"] == 0 and summary["totals"]["max_energy_error"] < 1e-14
    assert (tmp_path / "lorenz_nevir.overview.png").exists()


def test_an_output_folder_that_cannot_be_written_is_one_line(tmp_path, capsys):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    assert main(["run", str(_scene(tmp_path)), "--out", str(blocked / "out"), "--quiet"]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err.startswith("geomint: error: --out ") and "cannot write there (Not a directory)" in err
    assert err.count("\n") == 1


def test_a_misspelt_key_is_named_with_the_nearest_known_key(tmp_path, capsys):
    """Issue 26: `duraton` was reported as `duration: missing`, the unknown key unnamed."""
    path = _scene(tmp_path, SHORT.replace("duration = 2.0", "duraton = 2.0"))
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err == (
        f"geomint: error: {path}: `integrator.duraton`: unknown key; `[integrator]` takes duration, h, "
        "method and the options of 'gonzalez': compensated, max_newton_iter; did you mean `duration`?\n"
    )
    path = _scene(tmp_path, SHORT.replace("[effects]", "[efects]"))
    assert main(["show", str(path)]) == BAD_INPUT
    assert capsys.readouterr().err.endswith("; did you mean `[effects]`?\n")


def test_the_first_compilation_is_announced_once_before_the_wait(monkeypatch, capsys):
    """Issue 26, item 6: a first use compiled for 4-22 s in silence, then said so.  Now the first numba
    compilation (a cache miss) is announced as it starts, once, however many functions compile."""
    import numba

    from geomint import cli

    def compiling_solve(*args, **kwargs):
        for k in range(2):  # two fresh functions: two compilations, one announcement
            assert numba.njit(lambda x, k=k: x + k)(1.0) == 1.0 + k
        print("<wait>", file=sys.stderr)

    monkeypatch.setattr(cli, "solve", compiling_solve)
    cli._prepare(None, Gonzalez(), 0.1, quiet=False)
    err = capsys.readouterr().err
    assert re.fullmatch(
        r"geomint: loading the compiled kernels \.\.\. not cached yet: compiling them for gonzalez "
        r"\(the first use of a method takes 5-25 s, once; the machine code is then cached on disk for "
        r"later runs\)\n<wait>\ngeomint: compiled in \d+\.\d\d s\n",
        err,
    ), err
    cli._prepare(None, Gonzalez(), 0.1, quiet=True)  # compiles again (new functions), in silence
    assert capsys.readouterr().err == "<wait>\n"


MAXWELL_BLOCH = """
title = "real Maxwell-Bloch"
[system]
name = "maxwell_bloch"
H = "x**2/2 + z"
S = "(y**2 + z**2)/2"
J = ["0", "-y", "-z"]
[effects]
eps = 0.05
[initial]
points = [[0.5, 0.8, 0.1], [1.0, 0.3, -0.4], [0.2, -0.6, 0.7], [-0.8, 0.5, 0.5]]
[integrator]
method = "gonzalez"
h = 0.02
duration = 2.0
[output]
every = 5
figures = ["overview"]
"""


def test_a_scene_on_an_unbounded_level_set_runs_without_library_warnings(tmp_path, capsys):
    """Issue 26: the real Maxwell-Bloch equations (x' = y, y' = x z, z' = -x y; H = x^2/2 + z is unbounded below)
    printed 54 scipy overflow warnings from the search for the minimiser of H."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["run", str(_scene(tmp_path, MAXWELL_BLOCH)), "--out", str(tmp_path / "o")]) == OK
    err = capsys.readouterr().err
    assert "Warning" not in err and err.count("\n") <= 2, err
