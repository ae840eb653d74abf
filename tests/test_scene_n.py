"""Scenes in R^n: catalogue systems and formulas in [system], states by name, vector and distribution, the
R^n figures, the bundled R^n scenes from the command line, one-line errors, and 2-D Euler's relaxation to the
lowest shell."""

import json
import re

import numba
import numpy as np
import pytest

import geomint
from geomint import plotting
from geomint.cli import BAD_INPUT, OK, main
from geomint.scene import FIGURES, Scene, SceneError, bundled_scenes, formulas_n, load_scene, run_scene
from geomint.scene.relaxation import decay_rate, lowest_shell_distance, tail_limit
from geomint.systems import RN_CATALOGUE, euler_initial_state, euler_modes, euler_zeitlin

EPS = np.finfo(np.float64).eps
BUNDLED_N = sorted(bundled_scenes(rn=True))

PENDULA = """
title = "pendula"
[system]
catalogue = "damped_pendula"
N = 3
gamma = 0.5
[initial]
state = { q = 1.5, p = 0.0, s = 0.0 }
[integrator]
method = "gonzalez"
h = 0.1
duration = 2.0
[output]
every = 2
figures = []
"""

FORMULAS = """
title = "pendula as formulas"
[system]
name = "pendula"
variables = ["q[1..N]", "p[1..N]", "s"]
sizes = { N = 3 }
parameters = { gamma = 0.5 }
E = "sum(p[i]**2/2 + cos(q[i]), i) + s"
S = "s"
L = { "q[i], p[i]" = "1", "p[i], q[i]" = "-1" }
M = { "p[i], p[i]" = "gamma", "p[i], s" = "-gamma*p[i]", "s, p[i]" = "-gamma*p[i]", "s, s" = "gamma*sum(p[i]**2, i)" }
[initial]
state = { q = [0.5, 1.0, 1.5], p = 0.0, s = 0.0 }
[integrator]
method = "gonzalez"
h = 0.1
duration = 2.0
[output]
figures = []
"""


def _write(tmp_path, text, name="scene"):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _edit(text, old, new):
    assert old in text, old
    return text.replace(old, new)


# -- the bundled scenes from the command line ---------------------------------------------------------------
def test_the_bundled_rn_scenes():
    assert BUNDLED_N == ["damped_pendula", "euler_relaxation", "gas_containers", "heat_bath"]
    assert set(BUNDLED_N).isdisjoint(bundled_scenes())  # the R^3 list is the paper's examples, unchanged


@pytest.mark.parametrize("name", BUNDLED_N)
def test_each_bundled_rn_scene_runs_from_the_command_line_with_its_figures(name, tmp_path, capsys):
    """The whole scene (each runs in about a second warm): E to round-off, S never against its direction, S at
    its closed-form limit, every figure written."""
    out = tmp_path / "out"
    assert main(["run", name, "--out", str(out)]) == OK
    report = capsys.readouterr().out
    assert "S against its direction" in report and "wrote" in report
    scene = load_scene(name)
    for figure in scene.figures:
        png = out / f"{name}.{figure}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000, figure
    summary = json.loads((out / f"{name}.summary.json").read_text())
    totals = summary["totals"]
    assert totals["failed"] == 0 and totals["S_against_direction"] == 0
    assert totals["max_energy_error"] < 8 * EPS
    assert totals["dim"] == len(totals["variables"])
    for trajectory in summary["trajectories"]:
        assert trajectory["S_limit_from"] == "known"
        assert trajectory["S_gap_final"] < 1e-12 * max(1.0, abs(trajectory["S_limit"])), trajectory
        assert trajectory["decay_rate"] is not None and trajectory["decay_rate"] > 0
        if name in ("heat_bath", "damped_pendula"):  # the linearised rate (Euler's is the dissipative part's)
            assert trajectory["decay_rate"] == pytest.approx(trajectory["expected_rate"], rel=0.01)


def test_the_euler_scene_relaxes_to_within_1e_8_of_the_lowest_shell():
    """The acceptance of issue 29 item 5: the final state within 1e-8 of the span of the |k|^2 = 1 modes, the
    energy kept to round-off, the enstrophy at its minimum H0 on the energy level."""
    result = run_scene(load_scene("euler_relaxation"))
    scene, sol = result.scene, result.solutions[0]
    N = scene.arguments["N"]
    assert (scene.system, N, scene.eps, scene.h, scene.duration) == ("euler_zeitlin", 5, 0.05, 0.05, 80.0)
    np.testing.assert_array_equal(sol.x[0], euler_initial_state(N))
    lowest = np.repeat((euler_modes(N) ** 2).sum(axis=1) == 1, 2)
    x = sol.x_final
    distance = np.linalg.norm(x - np.where(lowest, x, 0.0))
    # the same norm over the same coordinates, summed with and without the zeros in between: ulps apart at most
    assert distance < 1e-8 and distance == pytest.approx(lowest_shell_distance(x), rel=4 * EPS, abs=0)
    H0 = sol.H[0]
    assert H0 == pytest.approx(1.1375, rel=1e-15) and np.max(np.abs(sol.H - H0)) <= 4 * EPS * H0
    assert sol.S_rises == 0 and abs(sol.S[-1] - H0) <= 4 * EPS * H0
    relaxed = result.summary()["trajectories"][0]
    assert relaxed["lowest_shell_distance"] == lowest_shell_distance(x) and relaxed["S_limit"] == H0


def test_the_dissipative_part_alone_relaxes_at_the_linearised_rate():
    """8 eps H0 near the lowest shell (shell 2 is the slowest), fitted from the scene's run with the Hamiltonian
    part off; the whole flow relaxes faster (the Hamiltonian part mixes shell 2 into faster shells)."""
    scene = load_scene("euler_relaxation").replace(figures=())
    alone = run_scene(scene.replace(hamiltonian=False))
    H0 = alone.solutions[0].H[0]
    rate = alone.relaxation()[0]["decay_rate"]
    assert rate == pytest.approx(8 * scene.eps * H0, rel=0.01)
    assert run_scene(scene).relaxation()[0]["decay_rate"] > 1.1 * rate


@pytest.mark.parametrize("N", [7, 9])
def test_larger_euler_truncations_relax_to_the_lowest_shell_too(N):
    scene = load_scene("euler_relaxation").replace(arguments={"N": N}, figures=())
    sol = run_scene(scene).solutions[0]
    assert sol.x.shape[1] == N * N - 1 and lowest_shell_distance(sol.x_final) < 1e-8


def test_list_shows_the_rn_catalogue_with_form_and_dimension_and_the_rn_scenes(capsys):
    assert main(["list"]) == OK
    text = capsys.readouterr().out
    assert "systems in R^n" in text
    for name in RN_CATALOGUE:
        assert re.search(rf"^  {name} +(Fish|GENERIC), n = ", text, re.M), name
    assert re.search(r"^  damped_pendula +GENERIC, n = 2N \+ 1 \(9 with the defaults\)", text, re.M)
    assert re.search(r"^  euler_zeitlin +Fish, n = N\^2 - 1 \(24 with the defaults\)", text, re.M)
    assert re.search(r"^  gas_containers +GENERIC, n = 4;", text, re.M)
    assert 'arguments: N = 4, gamma = 0.5, form = "action"' in text
    for name in BUNDLED_N:
        assert f"  {name} " in text
    for figure in ("series", "relaxation", "energy_ulps", "phase", "vorticity"):
        assert f"  {figure} " in text


def test_show_prints_the_resolved_rn_scene_and_its_states_by_name(tmp_path, capsys):
    assert main(["show", str(_write(tmp_path, PENDULA))]) == OK
    text = capsys.readouterr().out
    assert 'catalogue = "damped_pendula"' in text and 'form = "action"' in text and 'limit = "known"' in text
    assert "#   q1 = 1.5, q2 = 1.5, q3 = 1.5, p1 = 0.0, p2 = 0.0, p3 = 0.0, s = 0.0" in text


# -- errors: one line, the key and the rule, exit code 2 -------------------------------------------------------
ERRORS = [
    # the catalogue and its arguments
    (
        PENDULA,
        'catalogue = "damped_pendula"',
        'catalogue = "damped_pendulum"',
        r"`system.catalogue`: unknown R\^n catalogue system 'damped_pendulum'; known: .*"
        r"did you mean `damped_pendula`\?",
    ),
    (
        PENDULA,
        "gamma = 0.5",
        "gama = 0.5",
        r"`system.gama`: unknown argument of 'damped_pendula'; it takes N, form, gamma; did you mean `gamma`\?",
    ),
    (PENDULA, "gamma = 0.5", "gamma = -0.5", r"`system.gamma`: `gamma` must be finite and >= 0; got -0.5"),
    (PENDULA, "N = 3", "N = 0", r"`system.N`: `N` must be an integer >= 1"),
    (PENDULA, "gamma = 0.5", "eps = 0.5", r"`system.eps`: set the dissipation as `effects.eps`"),
    (
        PENDULA,
        'catalogue = "damped_pendula"',
        'name = "damped_pendula"',
        r"`system.name`: 'damped_pendula' is a system in R\^n: name it with catalogue = 'damped_pendula'",
    ),
    (
        PENDULA,
        'catalogue = "damped_pendula"',
        'catalogue = "relaxing_rigid_body"',
        r"`system.catalogue`: 'relaxing_rigid_body' is a system in R\^3",
    ),
    (PENDULA, "N = 3", "N = 3\nparameters = { gamma = 1.0 }", r"`system.parameters`: a catalogue system in R\^n"),
    # states: names, lengths, distributions
    (
        PENDULA,
        "q = 1.5,",
        "qq = 1.5,",
        r"`initial.state.qq`: unknown coordinate 'qq'; the system's coordinates are q1 ... q3, p1 ... p3, s "
        r"\(families q, p\); did you mean `q`\?",
    ),
    (PENDULA, ", s = 0.0 }", " }", r"`initial.state`: coordinates not given: s; give every coordinate .*`initial.fill"),
    (
        PENDULA,
        "q = 1.5,",
        "q = [1.5, 1.0],",
        r"`initial.state.q`: the family q has 3 coordinates \(q1, q2, q3\); got a list of 2",
    ),
    (PENDULA, "q = 1.5,", "q = 1.5, q2 = 1.0,", r"`initial.state.q2`: coordinate q2 is given twice"),
    (
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "points = [[1.5, 1.5, 1.5, 0.0, 0.0, 0.0]]",
        r"`initial.points\[0\]`: a state of the wrong length: the system has n = 7 coordinates .*; got 6 numbers",
    ),
    (
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "level_set = { H0 = 1.0, n = 3 }",
        r"`initial.level_set`: samples a level surface in R\^3; in R\^n give `points`, `state` .* or `random`",
    ),
    (
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "random = { n = 3, around = { q = 1.0 } }",
        r"`initial.random.std`: missing; a Gaussian around a state needs `std`",
    ),
    (
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "random = { n = 3, spread = 1, ranges = { q = 1.0 } }",
        r"`initial.random.spread`: unknown key; `random` takes n, seed, ranges, around, std",
    ),
    (
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "random = { n = 3, ranges = { q = [1.0, -1.0], p = 0, s = 0 } }",
        r"`initial.random.ranges.q`: must be \[low, high\] with low <= high; got \[1.0, -1.0\]",
    ),
    (
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "random = { n = 0, ranges = { q = 1.0 } }",
        r"`initial.random.n`: must be an integer in \[1, 1000000\]",
    ),
    (
        PENDULA,
        "[initial]\n",
        "[initial]\npoints = [[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]]\n",
        r"`initial`: give exactly one of `points` \(vectors\), `state` \(by name\) and `random`",
    ),
    # output
    (
        PENDULA,
        "figures = []",
        'figures = ["overview"]',
        r"`output.figures`: 'overview' draws the level surface of H in R\^3; a system in R\^n draws invariants, drift, "
        r"series, relaxation, energy_ulps, phase\.",
    ),
    (
        PENDULA,
        "figures = []",
        'figures = ["vorticity"]',
        r"`output.figures`: 'vorticity' draws 2-D Euler's vorticity field",
    ),
    (
        PENDULA,
        "figures = []",
        'figures = ["series"]\nseries = ["q1", "pp"]',
        r"`output.series`: unknown coordinate 'pp'; .*did you mean `p`\?",
    ),
    (
        PENDULA,
        "figures = []",
        'figures = ["phase"]\nphase = ["q1", "q2", "p1", "p2"]',
        r"`output.phase`: must name 2 or 3 coordinates to project onto",
    ),
    (PENDULA, "figures = []", 'figures = []\nrecord = ["x", "sigma"]', r"`output.record`: 'sigma' is a cross product"),
    (
        PENDULA,
        "figures = []",
        "figures = []\nsnapshots = [0.0, 5.0]",
        r"`output.snapshots`: the times must lie in the run, \[0, duration = 2\]; got 5",
    ),
    (
        PENDULA,
        "figures = []",
        'figures = []\nlimit = "knwon"',
        r"`output.limit`: must be \"known\".*did you mean `known`\?",
    ),
    (
        PENDULA,
        "figures = []",
        "figures = []\nlimit = [1.0, 2.0]",
        r"`output.limit`: one S_inf per trajectory: the scene has 1; got 2",
    ),
    (
        PENDULA.replace('"damped_pendula"', '"random_fish"').replace("N = 3\ngamma = 0.5", "n = 4"),
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "state = { x = [0.1, 0.2, 0.3, 0.4] }\nlimit = 1",
        r"`initial.limit`: unknown key",
    ),
    (
        PENDULA.replace('"damped_pendula"', '"random_fish"').replace("N = 3\ngamma = 0.5", "n = 4"),
        "figures = []",
        'figures = []\nlimit = "known"',
        r"`output.limit`: 'random_fish' has no closed-form S_inf",
    ),
    (
        PENDULA.replace('"damped_pendula"', '"gas_containers"').replace("N = 3\n", ""),
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "state = [{ q = 1.0, p = 0.0, S = 0.0 }, { q = 2.5, p = 0.0, S = 0.0 }]",
        r"`initial.state\[1\]`: E and S must be finite at the start; at \(q = 2.5, p = 0, S1 = 0, S2 = 0\) "
        r"E = nan, S = 0.0: the state is outside the system's domain",
    ),
    # formulas: the model's structure checks, one line with the key
    (
        FORMULAS,
        '"p[i], q[i]" = "-1"',
        '"p[i], q[i]" = "1"',
        r"`system.L`: `L` is not skew: L\[q1, p1\] \+ L\[p1, q1\] = 2",
    ),
    (
        FORMULAS,
        '"s, s" = "gamma*sum(p[i]**2, i)"',
        '"s, s" = "gamma"',
        r"`system.M`: `M` does not annihilate grad E",
    ),
    (FORMULAS, 'S = "s"', 'S = "s + q[1]"', r"`system.L`: `L` does not annihilate grad S"),
    # formulas: the scene's own checks, before anything is built
    (
        FORMULAS,
        "cos(q[i])",
        "cos(qq[i])",
        r"`system.E`: in 'sum\(p\[i\]\*\*2/2 \+ cos\(qq\[i\]\), i\) \+ s': unknown variable 'qq'; "
        r"the variables are q1, q2, "
        r"q3, p1, p2, p3, s; did you mean `q`\?",
    ),
    (FORMULAS, '+ s"', '+ ss"', r"`system.E`: unknown name 'ss' .*did you mean `s`\?"),
    (FORMULAS, "cos(q[i])", "cos(q[j])", r"`system.E`: index 'j' is not declared"),
    (
        FORMULAS,
        '"p[i], s" = "-gamma*p[i]"',
        '"p[i], s" = "-gamma*p[j]"',
        r'`system.M\["p\[i\], s"\]`: index \'j\' is not declared: an index is a size \(N\) or an index in scope \(i\)',
    ),
    (
        FORMULAS,
        'L = { "q[i], p[i]" = "1", "p[i], q[i]" = "-1" }',
        'L = [["0", "1"], ["-1", "0"]]',
        r"`system.L`: must have n = 7 rows, one per coordinate \(q1, q2, q3, p1, p2, p3, s\); got 2 rows",
    ),
    (
        FORMULAS,
        'L = { "q[i], p[i]" = "1", "p[i], q[i]" = "-1" }',
        "L = [" + ", ".join(['["0"]'] * 7) + "]",
        r"`system.L\[0\]`: row q1 must have n = 7 formulas; got 1 formulas",
    ),
    (
        FORMULAS,
        '"q[i], p[i]" = "1"',
        '"r[i], p[i]" = "1"',
        r'`system.L\["r\[i\], p\[i\]"\]`: unknown variable \'r\'; the variables are .*',
    ),
    (FORMULAS, 'S = "s"', 'H = "s"', r"`system.H`: a key of the Fish form; this system is in the GENERIC form"),
    (
        FORMULAS,
        "cos(q[i])",
        "cso(q[i])",
        r"`system.E`: 'cso' in .* is not a function of the grammar .*did you mean `cos`\?",
    ),
    (FORMULAS, "gamma*sum", "gama*sum", r"`system.M\[\"s, s\"\]`: unknown name 'gama' .*did you mean `gamma`\?"),
    (
        FORMULAS,
        '"q[1..N]"',
        '"q[1..K]"',
        r"`system.variables\[0\]`: 'K' in the bound 'K' is not a declared size \(sizes: N\); "
        r"declare it, sizes = \{ K = 8 \}",
    ),
    (FORMULAS, "cos(q[i])", "__import__('os')", r"`system.E`: '__import__' in .* is not a function of the grammar"),
    (FORMULAS, 'S = "s"', 'S = "s.real"', r"`system.S`: attribute is not allowed: 's.real'"),
    (FORMULAS, "q = [0.5, 1.0, 1.5]", "q = [0.5, 1.0]", r"`initial.state.q`: the family q has 3 coordinates"),
    (
        FORMULAS,
        "state = { q = [0.5, 1.0, 1.5], p = 0.0, s = 0.0 }",
        "points = [[0.5, 0.0, 0.0]]",
        r"`initial.points\[0\]`: a state of the wrong length: the system has n = 7 coordinates",
    ),
]


@pytest.mark.parametrize("base, old, new, problem", ERRORS, ids=[e[3][:50] for e in ERRORS])
def test_scene_errors_are_one_line_naming_the_key_and_exit_2(tmp_path, capsys, base, old, new, problem):
    path = _write(tmp_path, _edit(base, old, new))
    assert main(["show", str(path)]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert re.match(r"geomint: error: " + re.escape(str(path)) + ": " + problem, err), err


def _non_skew_generic(cls, **kwargs):
    """What ``GenericSystem.from_expressions`` hands the constructor when the formulas' L is not skew: the
    model's own check refuses it (a ValueError naming `L`)."""

    @numba.njit
    def E(x, p):
        return 0.5 * x[0] ** 2 + 0.5 * x[1] ** 2 + x[2]

    @numba.njit
    def grad_E(x, p):
        return np.array([x[0], x[1], 1.0])

    @numba.njit
    def S(x, p):
        return x[2]

    @numba.njit
    def grad_S(x, p):
        return np.array([0.0, 0.0, 1.0])

    @numba.njit
    def L(x, p):
        return np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])

    @numba.njit
    def M(x, p):
        return np.zeros((3, 3))

    return cls(E=E, grad_E=grad_E, S=S, grad_S=grad_S, L=L, M=M, dim=3, variables=("q", "p", "s"))


def test_a_non_skew_L_is_the_models_error_in_one_line_with_the_key(tmp_path, capsys, monkeypatch):
    text = _edit(FORMULAS, '"p[i], q[i]" = "-1"', '"p[i], q[i]" = "1"')
    text = _edit(text, '"q[1..N]", "p[1..N]", "s"', '"q", "p", "s"')
    text = _edit(text, "state = { q = [0.5, 1.0, 1.5], p = 0.0, s = 0.0 }", "state = { q = 0.5, p = 0.0, s = 0.0 }")
    text = text.replace("q[i]", "q").replace("p[i]", "p").replace("sum(p**2/2 + cos(q), i)", "p**2/2 + cos(q)")
    text = text.replace("sum(p**2, i)", "p**2").replace("sizes = { N = 3 }\n", "")
    path = _write(tmp_path, text)
    Scene.from_toml(path)  # the scene's own checks pass: only the model can see that L is not skew
    monkeypatch.setattr(formulas_n, "available", lambda: True)
    monkeypatch.setattr(geomint.GenericSystem, "from_expressions", classmethod(_non_skew_generic))
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.match(
        rf"geomint: error: {re.escape(str(path))}: `system.L`: `L` must be skew-symmetric \(P = -P\^T\); at x = ", err
    ), err


def test_the_formula_keys_pass_straight_to_from_expressions(monkeypatch):
    """The scene's keys are the classmethods' keyword arguments (``parameters`` as ``params``)."""
    calls = []

    def capture(cls, **kwargs):
        calls.append(kwargs)
        return geomint.systems.damped_pendula(3, 0.5)

    monkeypatch.setattr(formulas_n, "available", lambda: True)
    monkeypatch.setattr(geomint.GenericSystem, "from_expressions", classmethod(capture))
    scene = Scene.from_dict(__import__("tomllib").loads(FORMULAS), name="pendula")
    result = run_scene(scene)
    (kwargs,) = calls
    assert kwargs == {
        "variables": ["q[1..N]", "p[1..N]", "s"],
        "sizes": {"N": 3},
        "E": "sum(p[i]**2/2 + cos(q[i]), i) + s",
        "S": "s",
        "L": {"q[i], p[i]": "1", "p[i], q[i]": "-1"},
        "M": {
            "p[i], p[i]": "gamma",
            "p[i], s": "-gamma*p[i]",
            "s, p[i]": "-gamma*p[i]",
            "s, s": "gamma*sum(p[i]**2, i)",
        },
        "params": {"gamma": 0.5},
        "name": "pendula",
    }
    np.testing.assert_array_equal(result.solutions[0].x[0], [0.5, 1.0, 1.5, 0.0, 0.0, 0.0, 0.0])
    assert Scene.from_dict(scene.to_dict(), name="pendula") == scene


def test_formulas_without_the_rn_builder_say_so_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(formulas_n, "available", lambda: False)
    assert main(["show", str(_write(tmp_path, FORMULAS))]) == BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "`system.variables`: systems in R^n written as formulas need" in err


@pytest.mark.skipif(not formulas_n.available(), reason="R^n formulas (from_expressions(variables=...)) not merged")
def test_a_scene_written_as_formulas_runs_the_catalogue_system_it_writes():
    """Once the R^n formulas land: the formula pendula step as the catalogue's, to round-off."""
    formulas = run_scene(Scene.from_dict(__import__("tomllib").loads(FORMULAS)))
    catalogue = run_scene(
        Scene.from_dict(__import__("tomllib").loads(_edit(PENDULA, "q = 1.5", "q = [0.5, 1.0, 1.5]")))
    )
    # the catalogue's scene saves every 2nd state, the formulas' every state
    np.testing.assert_allclose(formulas.solutions[0].x[::2], catalogue.solutions[0].x, rtol=0, atol=1e-12)


def test_the_grammar_names_the_functions_of_the_model():
    from geomint.model import expressions

    assert set(formulas_n.FUNCTION_NAMES) == set(expressions.FUNCTIONS)


# -- states by name, vector and distribution ---------------------------------------------------------------
def _states(text):
    return Scene.from_dict(__import__("tomllib").loads(text)).resolved().built().states


def test_states_by_name_by_family_list_and_as_vectors_agree():
    by_name = _states(
        _edit(PENDULA, "q = 1.5, p = 0.0, s = 0.0", "q = [0.5, 1.0, 1.5], p2 = 0.3, p1 = 0, p3 = 0, s = 2")
    )
    vector = _states(
        _edit(PENDULA, "state = { q = 1.5, p = 0.0, s = 0.0 }", "points = [[0.5, 1.0, 1.5, 0, 0.3, 0, 2]]")
    )
    filled = _states(
        _edit(PENDULA, "q = 1.5, p = 0.0, s = 0.0", "q = [0.5, 1.0, 1.5], p2 = 0.3, s = 2 }\nfill = 0.0 #")
    )
    np.testing.assert_array_equal(by_name, [[0.5, 1.0, 1.5, 0.0, 0.3, 0.0, 2.0]])
    np.testing.assert_array_equal(vector, by_name)
    np.testing.assert_array_equal(filled, by_name)
    several = _states(
        _edit(
            PENDULA,
            "state = { q = 1.5, p = 0.0, s = 0.0 }",
            "state = [{ q = 1.5, p = 0.0, s = 0.0 }, { q = 0.5, p = 1.0, s = 0.0 }]",
        )
    )
    np.testing.assert_array_equal(several[:, [0, 3]], [[1.5, 0.0], [0.5, 1.0]])


def test_uniform_draws_are_seeded_within_their_ranges_and_fix_what_is_a_number():
    text = _edit(
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "random = { n = 200, seed = 7, ranges = { q = [-1.0, 1.0], p1 = [0.0, 0.5], p2 = 0.25, p3 = 0, s = 1 } }",
    )
    X = _states(text)
    assert X.shape == (200, 7)
    assert np.all(np.abs(X[:, :3]) <= 1.0) and X[:, :3].std() > 0.4
    assert np.all((X[:, 3] >= 0.0) & (X[:, 3] <= 0.5)) and np.all(X[:, 4] == 0.25) and np.all(X[:, 6] == 1.0)
    np.testing.assert_array_equal(X, _states(text))  # the same states every time
    assert not np.array_equal(X, _states(text.replace("seed = 7", "seed = 8")))


def test_gaussian_draws_around_a_state_with_a_spread_by_name():
    text = _edit(
        PENDULA,
        "state = { q = 1.5, p = 0.0, s = 0.0 }",
        "random = { n = 4000, seed = 3, around = { q = 3.0, p = 0.0, s = 1.0 }, std = { q = 0.1, p1 = 0.2 } }",
    )
    X = _states(text)
    np.testing.assert_allclose(X[:, :3].mean(axis=0), 3.0, atol=0.01)
    np.testing.assert_allclose(X[:, :3].std(axis=0), 0.1, rtol=0.05)
    assert X[:, 3].std() == pytest.approx(0.2, rel=0.05)
    assert np.all(X[:, 4:6] == 0.0) and np.all(X[:, 6] == 1.0)
    vector = _states(text.replace("std = { q = 0.1, p1 = 0.2 }", "std = 0.1"))
    assert np.all(vector.std(axis=0) > 0.09)


# -- results, figures and R^3 compatibility --------------------------------------------------------------
def test_a_generic_scene_counts_its_entropy_rises_as_the_normal_direction():
    result = run_scene(Scene.from_dict(__import__("tomllib").loads(PENDULA)))
    summary = result.summary()
    assert summary["totals"]["form"] == "GENERIC" and summary["totals"]["S_direction"] == 1.0
    assert summary["totals"]["S_rises"] > 0 and summary["totals"]["S_against_direction"] == 0
    (limit,) = result.limits()
    assert limit.source == "known" and limit.value == pytest.approx(result.solutions[0].H[0] + 3, rel=1e-15)
    assert result.records["x"].shape == (1, 11, 7)


def test_round_trips_of_the_rn_scenes():
    for name in BUNDLED_N:
        scene = load_scene(name)
        assert Scene.from_dict(scene.to_dict(), name=name) == scene
        resolved = scene.resolved()
        assert Scene.from_dict(resolved.to_dict(), name=name) == resolved
        assert resolved.to_dict()["system"]["catalogue"] == scene.system


def test_the_rn_figures_draw_for_an_r3_scene_too(tmp_path):
    """series, relaxation, energy_ulps and phase are dimension-free: an R^3 scene may ask for them; the R^3
    defaults are unchanged."""
    scene = Scene(
        system="relaxing_rigid_body",
        points=[[0.6, 0.0, 0.8]],
        h=0.1,
        duration=4.0,
        eps=0.5,
        figures=("series", "relaxation", "energy_ulps", "phase"),
        phase=("x", "y", "z"),
    )
    assert Scene(system="relaxing_rigid_body", points=[[0.6, 0.0, 0.8]], h=0.1, duration=1.0).figures == ("overview",)
    paths = plotting.draw(run_scene(scene), tmp_path)
    assert [p.name.split(".")[1] for p in paths] == ["series", "relaxation", "energy_ulps", "phase"]
    assert set(FIGURES) >= {"overview", "trajectories", "invariants", "drift", "vorticity"}


def test_the_tail_limit_and_the_fitted_rate_of_an_exponential():
    t = np.linspace(0.0, 40.0, 401)
    S = 2.0 + 0.5 * np.exp(-0.3 * t)
    limit = tail_limit(t[:200], S[:200])
    assert limit.source == "tail" and limit.value == pytest.approx(2.0, abs=1e-6)
    rate = decay_rate(t, S, 2.0, direction=-1.0)
    assert rate.rate == pytest.approx(0.3, rel=1e-6)
    assert tail_limit(t, np.full_like(t, 1.5)).value == 1.5  # arrived: the last value
    assert decay_rate(t, np.full_like(t, 1.5), 1.5, -1.0) is None


def test_the_panels_take_solutions_and_names_directly(tmp_path):
    system = euler_zeitlin(5, eps=0.05)
    sol = geomint.solve(system, euler_initial_state(5), (0.0, 4.0), 0.05)
    ax = plotting.coordinate_series(sol, system.variables, ["re_1_0", "re_1_1"])
    assert ax.get_legend_handles_labels()[1] == ["re_1_0", "re_1_1"]
    assert plotting.phase_projection(sol, system.variables, ["re_1_0", "re_0_1"]).get_xlabel() == "re_1_0"
    gap = plotting.entropy_gap(sol, [system.H(sol.x[0])], -1.0)
    assert gap.get_yscale() == "log" and gap.get_ylabel() == "S - S∞"
    image = plotting.vorticity_field(sol.x[-1], 5)
    assert image.get_array().shape == (96, 96)
    with pytest.raises(ValueError, match="`names`: 'nope' is not a coordinate"):
        plotting.coordinate_series(sol, system.variables, ["nope"])


# -- hostile strings: every string an R^n scene interprets is refused in one line, and nothing runs ------------
def _hostile_scene(field, text):
    import tomllib

    base = tomllib.loads(FORMULAS if field.startswith("system.") and field != "system.catalogue" else PENDULA)
    system, initial, output = base["system"], base["initial"], base["output"]
    if field == "system.E":
        system["E"] = text
    elif field == "system.L rule":
        system["L"]["q[i], p[i]"] = text
    elif field == "system.L key":
        system["L"][text] = "1"
    elif field == "system.variables":
        system["variables"][2] = text
    elif field == "system.sizes key":
        system["sizes"][text] = 3
    elif field == "system.define":
        system["define"] = {"T": text}
    elif field == "system.catalogue":
        system["catalogue"] = text
    elif field == "argument key":
        system[text] = 1.0
    elif field == "state key":
        initial["state"][text] = 1.0
    elif field == "random key":
        initial.pop("state")
        initial["random"] = {"n": 2, "ranges": {"q": 1.0, "p": 0.0, "s": 0.0}, text: 1}
    elif field == "output.series":
        output["series"] = [text]
    elif field == "output.limit":
        output["limit"] = text
    return base


HOSTILE_FIELDS = [
    "system.E",
    "system.L rule",
    "system.L key",
    "system.variables",
    "system.sizes key",
    "system.define",
    "system.catalogue",
    "argument key",
    "state key",
    "random key",
    "output.series",
    "output.limit",
]


@pytest.mark.parametrize("field", HOSTILE_FIELDS)
def test_hostile_strings_in_every_rn_field_are_refused_before_anything_is_built(tmp_path, field, monkeypatch):
    from hostile_strings import hostile

    def never(cls, **kwargs):
        raise AssertionError("a hostile scene reached the builder")

    monkeypatch.setattr(formulas_n, "available", lambda: True)
    monkeypatch.setattr(geomint.GenericSystem, "from_expressions", classmethod(never))
    sentinel = tmp_path / "pwned"
    accepted = []
    for text in hostile(sentinel):
        try:
            Scene.from_dict(_hostile_scene(field, text)).resolved()
        except SceneError as exc:
            assert "\n" not in str(exc) and len(str(exc)) < 1500, str(exc)[:300]
        else:
            accepted.append(text)
    assert not sentinel.exists()
    assert accepted == []


def test_the_invariants_panel_marks_steps_against_the_entropys_direction():
    """In GENERIC form S rises by design: the S panel marks falls, and counts none."""
    result = run_scene(Scene.from_dict(__import__("tomllib").loads(PENDULA)))
    assert result.solutions[0].S_rises > 0
    ax = plotting.casimir(result.solutions)
    assert ax.get_title() == "entropy S: 0 falls beyond round-off"
    body = geomint.solve(geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.5), [0.6, 0.0, 0.8], (0, 1), 0.1)
    assert plotting.casimir(body).get_title() == "Casimir S: 0 rises beyond round-off"
