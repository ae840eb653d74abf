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
    # issue 26: a misspelt key is named with the nearest known key (`duraton` was "duration: missing")
    (
        edit("duration = 0.5", "duraton = 0.5"),
        r"`integrator.duraton`: unknown key; `\[integrator\]` takes duration, h, "
        r"method and the options of 'gonzalez': compensated, max_newton_iter; "
        r"did you mean `duration`\?",
    ),
    (
        edit("eps = 0.1", "epsilon = 0.1"),
        r"`effects.epsilon`: unknown key; `\[effects\]` takes eps, hamiltonian, "
        r"projection; did you mean `eps`\?",
    ),
    (edit("every = 1", "evry = 1"), r"`output.evry`: unknown key; .*; did you mean `every`\?"),
    (edit("[output]", "[outptu]"), r"`outptu`: unknown key; a scene takes .*; did you mean `\[output\]`\?"),
    (
        edit("a = 0.5", "aa = 0.5"),
        r"`system.parameters.aa`: unknown parameter of 'relaxing_rigid_body'; it takes "
        r"a, b, c; did you mean `a`\?",
    ),
    ("effects = 3\n" + edit("[effects]\neps = 0.1", ""), r"`effects`: must be a table `\[effects\]`; got 3"),
    (edit('name = "relaxing_rigid_body"\n', ""), r"`system.name`: missing; it is required"),
    (edit("h = 0.05\n", ""), r"`integrator.h`: missing; it is required"),
    (edit("h = 0.05", 'h = "small"'), r"`integrator.h`: must be a number; got 'small' \(str\)"),
    (edit("h = 0.05", "h = -0.05"), r"`integrator.h`: must be > 0; got -0.05"),
    (edit("h = 0.05", "h = inf"), r"`integrator.h`: must be finite; got inf"),
    (edit("duration = 0.5", "duration = nan"), r"`integrator.duration`: must be finite; got nan"),
    (edit("eps = 0.1", "eps = true"), r"`effects.eps`: must be a number; got True \(bool\)"),
    (
        edit("eps = 0.1", "eps = 0\nhamiltonian = false"),
        r"`effects`: every effect is off \(hamiltonian = false, eps = 0\): there is nothing to simulate",
    ),
    (edit("eps = 0.1", "eps = -1.0"), r"`effects.eps`: must be >= 0; got -1.0"),
    (edit("eps = 0.1", "eps = 0.1\nhamiltonian = 1"), r"`effects.hamiltonian`: must be true or false; got 1"),
    (edit("a = 0.5", "a = inf"), r"`system.parameters.a`: must be finite; got inf"),
    (
        edit("a = 0.5", "d = 0.5"),
        r"`system.parameters.d`: unknown parameter of 'relaxing_rigid_body'; "
        r"it takes a, b, c",
    ),
    (edit("a = 0.5", "eps = 0.5"), r"`system.parameters.eps`: set the dissipation as `effects.eps`"),
    (
        edit('name = "relaxing_rigid_body"', 'name = "pendulum"'),
        r"`system.name`: unknown catalogue system 'pendulum'; known: degenerate_example, dissipative_oscillator",
    ),
    (edit("[[0.6, 0.0, 0.8]]", "[[0.6, 0.0]]"), r"`initial.points\[0\]`: must be a list of 3 numbers"),
    (edit("[[0.6, 0.0, 0.8]]", "[[0.6, 0.0, inf]]"), r"`initial.points\[0\]`: must be finite; got inf"),
    (edit("[[0.6, 0.0, 0.8]]", "[]"), r"`initial.points`: must be a non-empty list of points"),
    (edit("points = [[0.6, 0.0, 0.8]]", ""), r"`initial`: give exactly one of `points` and `level_set`"),
    (
        edit("points = [[0.6, 0.0, 0.8]]", "points = [[0.6, 0.0, 0.8]]\nlevel_set = { H0 = 1.0, n = 3 }"),
        r"`initial`: give exactly one of `points` and `level_set`",
    ),
    (edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 1.0 }"), r"`initial.level_set.n`: missing"),
    (
        edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 1.0, n = 0 }"),
        r"`initial.level_set.n`: must be an integer in \[1, 1000000\]; got 0",
    ),
    (
        edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 1.0, n = 2, radius = 1 }"),
        r"`initial.level_set.radius`: unknown key; `level_set` takes H0, center, n",
    ),
    (edit("every = 1", "every = 0"), r"`output.every`: must be an integer >= 1 or \"final\"; got 0"),
    (
        edit("every = 1", 'every = "final"\nfigures = ["overview"]').replace("figures = []\n", ""),
        r"`output.figures`: figures \['overview'\] draw whole trajectories",
    ),
    (
        edit("every = 1", 'every = 1\nrecord = ["energy"]'),
        r"`output.record`: unknown observable 'energy'; known: H, S, dS_dt, energy_error",
    ),
    (edit("figures = []", 'figures = ["movie"]'), r"`output.figures`: unknown figure 'movie'"),
    (edit("figures = []", 'figures = "overview"'), r"`output.figures`: must be a list of names"),
    (
        edit("figures = []", "figures = []\nsections = [[0.0, 0.0, 0.0, 1.0]]"),
        r"`output.sections\[0\]`: the normal \(a, b, c\) must not be zero",
    ),
    (edit('method = "gonzalez"', "method = 3"), r"`integrator.method`: must be a short name or a table"),
    (edit("h = 0.05", "h = 0.05\nh = 0.1"), r"not valid TOML: .*line"),
]

# checked when the scene is resolved (it builds the system and the method)
RESOLVED = [
    (
        edit('method = "gonzalez"', 'method = "euler"'),
        r"`integrator.method`: unknown integrator 'euler'; "
        r"known: .*gonzalez, .*rk4",
    ),
    (
        edit('method = "gonzalez"', 'method = { name = "gonzalez", tolerance = 1e-9 }'),
        r"`integrator.method.tolerance`: unknown option of 'gonzalez'; it takes compensated, max_newton_iter",
    ),
    (
        edit('method = "gonzalez"', 'method = { name = "gonzalez", max_newton_iters = 9 }'),
        r"`integrator.method.max_newton_iters`: unknown option of 'gonzalez'; .*; did you mean `max_newton_iter`\?",
    ),
    (
        edit('method = "gonzalez"', 'method = { name = "gonzalez", max_newton_iter = 0 }'),
        r"`integrator.method`: `max_newton_iter` must be an integer in \[1, 10\*\*6\]; got 0",
    ),
    (edit("a = 0.5", "a = -0.5"), r"`system.parameters`: `a` must be a finite positive number; got -0.5"),
    (
        edit("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = -1.0, n = 2 }"),
        r"`initial.level_set`: the level set H = -1.0 must enclose its centre",
    ),
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
    with pytest.raises(
        SceneError,
        match=r"no_such_scene: no such scene file, nor a bundled scene; bundled: "
        r"degenerate_example1",
    ):
        load("no_such_scene")


def test_python_scene_errors_name_the_key():
    with pytest.raises(SceneError, match=r"<Scene>: `integrator.h`: must be > 0; got 0.0"):
        Scene(system="relaxing_rigid_body", points=[[1.0, 0.0, 0.0]], h=0.0, duration=1.0)
    with pytest.raises(SceneError, match=r"<Scene>: `output.view`: must be a list of 2 angles"):
        Scene(system="relaxing_rigid_body", points=[[1.0, 0.0, 0.0]], h=0.1, duration=1.0, view=[1.0])


def test_a_scene_file_is_never_evaluated(tmp_path):
    text = edit("h = 0.05", "h = \"__import__('os').getcwd()\"")
    with pytest.raises(SceneError, match=r"`integrator.h`: must be a number; got \"__import__"):
        Scene.from_toml(_write(tmp_path, text))


# -- injection: every string a scene interprets is refused, and nothing in a scene ever runs -----------------------
FORMULAS = {
    "system": {
        "name": "lorenz_nevir",
        "H": "(y**2 + z**2)/2 - r*z",
        "S": "x**2/2 - sigma*z",
        "J": ["-x", "0", "sigma"],
        "parameters": {"sigma": 10.0, "r": 28.0},
    },
    "effects": {"eps": 0.01},
    "initial": {"points": [[-2.0, 3.0, 20.0]]},
    "integrator": {"method": "gonzalez", "h": 0.01, "duration": 0.05},
    "output": {"figures": []},
}


def _put(path, text):
    """``FORMULAS`` with the string at ``path`` (keys, ints for list items, "*key" to rename a key) set to ``text``."""
    import copy

    data = copy.deepcopy(FORMULAS)
    *parents, last = path
    target = data
    for key in parents:
        target = target[key]
    if isinstance(last, str) and last.startswith("*"):
        target[text] = target.pop(last[1:])
    else:
        target[last] = text
    return data


INTERPRETED = {
    "system.H": ("system", "H"),
    "system.S": ("system", "S"),
    "system.J[0]": ("system", "J", 0),
    "system.J[2]": ("system", "J", 2),
    "system.parameters name": ("system", "parameters", "*sigma"),
    "system.name": ("system", "name"),
    "integrator.method": ("integrator", "method"),
    "output.record": ("output", "record", None),
    "output.figures": ("output", "figures", None),
    "output.every": ("output", "every"),
    "section key": ("*output",),
    "integrator option key": ("integrator", "*h"),
    "system.P[1][2]": ("system", "P", 1, 2),
    "integrator.base": ("integrator", "base"),
    "integrator option value": ("integrator", "monotone"),
    "initial.level_set key": ("initial", "level_set", "*H0"),
}


def _scene_with(field, text):
    path = INTERPRETED[field]
    if field == "system.P[1][2]":
        data = _put(("system", "J"), None)
        del data["system"]["J"]
        data["system"]["P"] = [["0", "sigma", "0"], ["-sigma", "0", text], ["0", "x", "0"]]
        return data
    if field in ("integrator.base", "integrator option value"):
        data = _put(("integrator", "method"), "yoshida4")
        data["integrator"][path[-1]] = text
        return data
    if field == "initial.level_set key":
        data = _put(("initial",), {"level_set": {"H0": 300.0, "n": 2}})
        data["initial"]["level_set"][text] = data["initial"]["level_set"].pop("H0")
        return data
    if path[-1] is None:  # a list of names
        return _put(path[:-1], [text])
    if path == ("*output",):
        data = _put(("output",), {})
        data[text] = data.pop("output")
        return data
    return _put(path, text)


@pytest.mark.parametrize("field", sorted(INTERPRETED))
def test_hostile_strings_in_every_interpreted_field_are_refused_and_nothing_runs(tmp_path, field):
    from hostile_strings import hostile

    sentinel = tmp_path / "pwned"
    strings = hostile(sentinel)
    assert len(strings) >= 30
    accepted = []
    for text in strings:
        try:
            run_scene(Scene.from_dict(_scene_with(field, text)))
        except SceneError as exc:
            assert "\n" not in str(exc)
        else:
            accepted.append(text)
    assert not sentinel.exists()
    if field == "system.name":  # a label of an expression system: a harmless name is fine, nothing else
        assert all(re.fullmatch(r"[A-Za-z][A-Za-z0-9_.-]*", text) for text in accepted), accepted
    else:
        assert accepted == []


def test_hostile_labels_are_kept_as_text_and_nothing_runs(tmp_path):
    from hostile_strings import hostile

    sentinel = tmp_path / "pwned"
    for text in hostile(sentinel):
        scene = Scene.from_dict({**_put(("system", "name"), "lorenz_nevir"), "title": text, "description": text})
        assert run_scene(scene).scene.title == text
    assert not sentinel.exists()


def test_a_scene_name_that_is_a_path_is_refused():
    with pytest.raises(SceneError, match=r"`name`: must be a label of letters, digits and _ \. -"):
        Scene.from_dict(FORMULAS, name="../../etc/passwd")


def test_formula_errors_name_the_key_in_the_scene():
    with pytest.raises(SceneError, match=r"<dict>: `system.J\[0\]`: not a whitelisted function: 'eval'"):
        Scene.from_dict(_put(("system", "J", 0), "eval('1')"))
    with pytest.raises(
        SceneError,
        match=r"`system.S` is not a Casimir of J: grad S x J = 0 fails; the residual "
        r"simplifies to \[sigma\*x\*\*2\*y, sigma\*x\*\(1 - y\*\*2\), x\*\*3\*y\]\.",
    ):
        Scene.from_dict(_put(("system", "S"), "x**2*y**2/2 - sigma*z")).resolved()
    with pytest.raises(SceneError, match=r"<dict>: give exactly one of `system.J` \(3 formulas, axial vector\)"):
        Scene.from_dict(_put(("system", "J"), None))


def test_the_scene_entry_points_name_an_argument_of_the_wrong_type():
    with pytest.raises(
        TypeError, match=r"`scene` must be a geomint.Scene; got 'rigid_body_distinct' \(str\)\. Read one"
    ):
        run_scene("rigid_body_distinct")  # pyright: ignore[reportArgumentType]
    with pytest.raises(TypeError, match=r"`scene` must be a scene file's path or a bundled scene's name"):
        load(3)  # pyright: ignore[reportArgumentType]
    with pytest.raises(TypeError, match=r"`path` must be a scene file's path; got None"):
        Scene.from_toml(None)  # pyright: ignore[reportArgumentType]
