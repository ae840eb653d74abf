"""Bad scenes: every error names the file, the key and the problem."""

import re

import pytest

from geomint.scene import Scene, SceneError, load, run_scene

VALID = """
title = "test"
[system]
name = "relaxing_rigid_body"
parameters = { a = 0.5, b = 1.0, c = 1.5 }
[effects]
eps = 0.1
[initial]
points = [[0.6, 0.0, 0.8]]
[integrator]
method = "gonzalez"
h = 0.05
duration = 0.5
[output]
every = 1
figures = []
"""


def edit(old, new):
    assert old in VALID
    return VALID.replace(old, new)


# (scene text, "`key`: problem" pattern): checked when the scene is read
STATIC = [
    (VALID + "colour = 1\n", r"`output.colour`: unknown key; `\[output\]` takes every, figures"),
    ("colour = 1\n" + VALID, r"`colour`: unknown key; a scene takes title, description, \[system\], \[effects\]"),
    (edit("eps = 0.1", "dissipation = 0.1"), r"`effects.dissipation`: unknown key"),
    ("effects = 3\n" + edit("[effects]\neps = 0.1", ""), r"`effects`: must be a table `\[effects\]`; got 3"),
    (edit('name = "relaxing_rigid_body"\n', ""), r"`system.name`: missing; it is required"),
    (edit("h = 0.05\n", ""), r"`integrator.h`: missing; it is required"),
    (edit("h = 0.05", 'h = "small"'), r"`integrator.h`: must be a number; got 'small' \(str\)"),
    (edit("h = 0.05", "h = -0.05"), r"`integrator.h`: must be > 0; got -0.05"),
    (edit("h = 0.05", "h = inf"), r"`integrator.h`: must be finite; got inf"),
    (edit("duration = 0.5", "duration = nan"), r"`integrator.duration`: must be finite; got nan"),
    (edit("eps = 0.1", "eps = true"), r"`effects.eps`: must be a number; got True \(bool\)"),
    (edit("eps = 0.1", "eps = 0\nhamiltonian = false"),
     r"`effects`: every effect is off \(hamiltonian = false, eps = 0\): there is nothing to simulate"),
    (edit("eps = 0.1", "eps = -1.0"), r"`effects.eps`: must be >= 0; got -1.0"),
    (edit("eps = 0.1", "eps = 0.1\nhamiltonian = 1"), r"`effects.hamiltonian`: must be true or false; got 1"),
    (edit("a = 0.5", "a = inf"), r"`system.parameters.a`: must be finite; got inf"),
    (edit("a = 0.5", "d = 0.5"), r"`system.parameters.d`: unknown parameter of 'relaxing_rigid_body'; "
                                       r"it takes a, b, c"),
    (edit("a = 0.5", "eps = 0.5"), r"`system.parameters.eps`: set the dissipation as `effects.eps`"),
    (edit('name = "relaxing_rigid_body"', 'name = "pendulum"'),
     r"`system.name`: unknown catalogue system 'pendulum'; known: degenerate_example, dissipative_oscillator"),
    (edit("[[0.6, 0.0, 0.8]]", "[[0.6, 0.0]]"), r"`initial.points\[0\]`: must be a list of 3 numbers"),
    (edit("[[0.6, 0.0, 0.8]]", "[[0.6, 0.0, inf]]"), r"`initial.points\[0\]`: must be finite; got inf"),
    (edit("[[0.6, 0.0, 0.8]]", "[]"), r"`initial.points`: must be a non-empty list of points"),
    (edit("points = [[0.6, 0.0, 0.8]]", ""), r"`initial`: give exactly one of `points` and `level_set`"),
    (edit("points = [[0.6, 0.0, 0.8]]", "points = [[0.6, 0.0, 0.8]]\nlevel_set = { H0 = 1.0, n = 3 }"),
     r"`initial`: give exactly one of `points` and `level_set`"),
    (edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 1.0 }"), r"`initial.level_set.n`: missing"),
    (edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 1.0, n = 0 }"),
     r"`initial.level_set.n`: must be an integer >= 1; got 0"),
    (edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 1.0, n = 2, radius = 1 }"),
     r"`initial.level_set.radius`: unknown key; `level_set` takes H0, center, n"),
    (edit("every = 1", "every = 0"), r"`output.every`: must be an integer >= 1 or \"final\"; got 0"),
    (edit("every = 1", 'every = "final"\nfigures = ["overview"]').replace("figures = []\n", ""),
     r"`output.figures`: figures \['overview'\] draw whole trajectories"),
    (edit("every = 1", 'every = 1\nrecord = ["energy"]'),
     r"`output.record`: unknown observable 'energy'; known: H, S, dS_dt, energy_error"),
    (edit("figures = []", 'figures = ["movie"]'), r"`output.figures`: unknown figure 'movie'"),
    (edit("figures = []", 'figures = "overview"'), r"`output.figures`: must be a list of names"),
    (edit("figures = []", "figures = []\nsections = [[0.0, 0.0, 0.0, 1.0]]"),
     r"`output.sections\[0\]`: the normal \(a, b, c\) must not be zero"),
    (edit('method = "gonzalez"', "method = 3"), r"`integrator.method`: must be a short name or a table"),
    (edit("h = 0.05", "h = 0.05\nh = 0.1"), r"not valid TOML: .*line"),
]

# checked when the scene is resolved (it builds the system and the method)
RESOLVED = [
    (edit('method = "gonzalez"', 'method = "euler"'), r"`integrator.method`: unknown integrator 'euler'; "
                                                      r"known: .*gonzalez, .*rk4"),
    (edit('method = "gonzalez"', 'method = { name = "gonzalez", tolerance = 1e-9 }'),
     r"`integrator.method.tolerance`: unknown option of 'gonzalez'; it takes compensated, max_newton_iter"),
    (edit('method = "gonzalez"', 'method = { name = "gonzalez", max_newton_iter = 0 }'),
     r"`integrator.method`: `max_newton_iter` must be an integer in \[1, 10\*\*6\]; got 0"),
    (edit("a = 0.5", "a = -0.5"), r"`system.parameters`: `a` must be a finite positive number; got -0.5"),
    (edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = -1.0, n = 2 }"),
     r"`initial.level_set`: the level set H = -1.0 must enclose its centre"),
]


def _write(tmp_path, text):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("text, problem", STATIC, ids=[p[:40] for _, p in STATIC])
def test_static_errors_name_file_key_and_problem(tmp_path, text, problem):
    path = _write(tmp_path, text)
    with pytest.raises(SceneError, match=re.escape(str(path)) + ": " + problem):
        Scene.from_toml(path)


@pytest.mark.parametrize("text, problem", RESOLVED, ids=[p[:40] for _, p in RESOLVED])
def test_errors_found_on_resolution_name_file_key_and_problem(tmp_path, text, problem):
    path = _write(tmp_path, text)
    scene = Scene.from_toml(path)
    with pytest.raises(SceneError, match=re.escape(str(path)) + ": " + problem):
        scene.resolved()
    with pytest.raises(SceneError, match=problem):
        run_scene(scene)


def test_the_valid_scene_runs(tmp_path):
    assert run_scene(Scene.from_toml(_write(tmp_path, VALID))).success


def test_missing_file_and_unknown_bundled_name():
    with pytest.raises(SceneError, match=r"no_such_scene: no such scene file, nor a bundled scene; bundled: "
                                         r"degenerate_example1"):
        load("no_such_scene")


def test_python_scene_errors_name_the_key():
    with pytest.raises(SceneError, match=r"<Scene>: `integrator.h`: must be > 0; got 0.0"):
        Scene(system="relaxing_rigid_body", points=[[1.0, 0.0, 0.0]], h=0.0, duration=1.0)
    with pytest.raises(SceneError, match=r"<Scene>: `output.view`: must be a list of 2 angles"):
        Scene(system="relaxing_rigid_body", points=[[1.0, 0.0, 0.0]], h=0.1, duration=1.0, view=[1.0])


def test_a_scene_file_is_never_evaluated(tmp_path):
    text = edit("h = 0.05", 'h = "__import__(\'os\').getcwd()"')
    with pytest.raises(SceneError, match=r"`integrator.h`: must be a number; got \"__import__"):
        Scene.from_toml(_write(tmp_path, text))
