"""Faults at the edges of the command line and the file system: one line, the documented exit code, no
traceback, and never a partial file under a final name."""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_scene_errors import VALID

from geomint.cli import BAD_INPUT, INTERRUPTED, OK, main

FIGURED = VALID.replace("figures = []", 'figures = ["invariants"]').replace("every = 1", "every = 2")
BIG = "1" * 400


def _cli(argv, capsys):
    """``(exit code, stderr)`` of ``geomint argv`` run in this process (argparse errors exit through SystemExit)."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exit_:
        code = exit_.code
    return code, capsys.readouterr().err


def _one_line_error(err, pattern):
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("usage:")]
    assert "Traceback" not in err
    assert len(lines) == 1 and "error" in lines[0], err
    assert re.search(pattern, lines[0]), lines[0]


def _no_files_left(folder):
    """Nothing under the final names, and no temporary file either."""
    return not folder.exists() or not any(
        p.suffix in (".npz", ".json", ".png") or ".part" in p.name for p in folder.iterdir()
    )


def _scene(tmp_path, text, name="scene", binary=False):
    path = tmp_path / f"{name}.toml"
    path.write_bytes(text) if binary else path.write_text(text)
    return path


# -- scene files -------------------------------------------------------------------------------
SCENE_FAULTS = {
    "non-UTF-8 bytes": (b'title = "caf\xe9"\n' + VALID.encode(), r"not UTF-8 text \(byte 0xe9 at position 12\)"),
    "nested 100 000 deep": ("a = " + "{a = " * 100_000 + "1" + "}" * 100_000, r"nested too deeply"),
    "arrays nested 100 000 deep": ("a = " + "[" * 100_000 + "]" * 100_000, r"nested too deeply"),
    "400-digit parameter": (VALID.replace("a = 0.5", f"a = {BIG}"), r"`system.parameters.a`: .*400 digits"),
    "400-digit duration": (VALID.replace("duration = 0.5", f"duration = {BIG}"), r"`integrator.duration`: .*400"),
    "400-digit eps": (VALID.replace("eps = 0.1", f"eps = {BIG}"), r"`effects.eps`: .*400 digits"),
    "duration 1e308, h 1e-308": (
        VALID.replace("h = 0.05", "h = 1e-308").replace("duration = 0.5", "duration = 1e308"),
        r"`integrator.h`: .*at most 2\*\*52",
    ),
    "1e12 steps saved every step": (
        VALID.replace("h = 0.05", "h = 1e-12").replace("duration = 0.5", "duration = 1.0"),
        r"`output.every`: saving 1000000000002 states .* GiB, more than half",
    ),
    "unbalanced mathtext title": (
        FIGURED.replace('title = "test"', 'title = "$x^{$"'),
        r"`title`: its \$\.\.\.\$ math",
    ),
    "method that cannot run": (
        VALID.replace('method = "gonzalez"', 'method = "rigid_body_flow"'),
        r"`integrator.method`: .*Hamiltonian part only",
    ),
    "empty file": ("", r"`system.name`: missing"),
    "unknown key": (VALID.replace("every = 1", "every = 1\nfoo = 2"), r"`output.foo`: unknown key"),
    "h as a string": (VALID.replace("h = 0.05", 'h = "0.05"'), r"`integrator.h`: must be a number; got '0.05'"),
    "h negative": (VALID.replace("h = 0.05", "h = -0.05"), r"`integrator.h`: must be > 0"),
    "h nan": (VALID.replace("h = 0.05", "h = nan"), r"`integrator.h`: must be finite"),
    "duration inf": (VALID.replace("duration = 0.5", "duration = inf"), r"`integrator.duration`: must be finite"),
    "every 0": (VALID.replace("every = 1", "every = 0"), r"`output.every`: must be an integer >= 1"),
    "unknown figure": (VALID.replace("figures = []", 'figures = ["movie"]'), r"`output.figures"),
    "unknown method": (VALID.replace('method = "gonzalez"', 'method = "euler"'), r"`integrator.method`"),
    "point of 2 components": (VALID.replace("[[0.6, 0.0, 0.8]]", "[[0.6, 0.0]]"), r"`initial.points"),
    "level set of 10**7 states": (
        VALID.replace("points = [[0.6, 0.0, 0.8]]", "level_set = { H0 = 0.5, n = 10000000 }"),
        r"`initial.level_set.n`: must be an integer in \[1, 1000000\]",
    ),
    "level set of a 400-digit count": (
        VALID.replace("points = [[0.6, 0.0, 0.8]]", f"level_set = {{ H0 = 0.5, n = {BIG} }}"),
        r"`initial.level_set.n`: must be an integer in",
    ),
    "parameter as a string": (VALID.replace("a = 0.5", 'a = "half"'), r"`system.parameters.a`"),
    "not TOML": ("title = = 1", r"not valid TOML"),
    "random bytes": (bytes(range(256)) * 4, r"not UTF-8 text"),
}


@pytest.mark.parametrize("command", ["run", "show"])
@pytest.mark.parametrize("case", sorted(SCENE_FAULTS))
def test_a_bad_scene_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, case, command):
    text, pattern = SCENE_FAULTS[case]
    path = _scene(tmp_path, text, binary=isinstance(text, bytes))
    out = tmp_path / "out"
    code, err = _cli([command, path] + (["--out", out, "--quiet"] if command == "run" else []), capsys)
    assert code == BAD_INPUT
    _one_line_error(err, pattern)
    assert str(path) in err or "scene.toml" in err
    assert _no_files_left(out)


@pytest.mark.parametrize(
    "target, pattern",
    [
        ("missing.toml", r"no such scene file, nor a bundled scene"),
        (".", r"is a folder"),
    ],
)
def test_a_scene_that_is_not_a_file(tmp_path, capsys, target, pattern):
    code, err = _cli(["run", tmp_path / target, "--out", tmp_path / "out"], capsys)
    assert code == BAD_INPUT
    _one_line_error(err, pattern)


# -- command-line options ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv, pattern",
    [
        (["--steps", 10**20], r"argument --steps: must be finite and > 0 and <= 4\.5036e\+15; got 1000"),
        (["--steps", "abc"], r"argument --steps: must be an integer; got 'abc'"),
        (["--steps", 0], r"argument --steps: must be finite and > 0"),
        (["--h", "inf"], r"argument --h: must be finite and > 0; got inf"),
        (["--h", "-1"], r"argument --h: must be finite and > 0; got -1"),
        (["--h", "nan"], r"argument --h: must be finite"),
        (["--eps", "nan"], r"argument --eps: must be finite and >= 0; got nan"),
        (["--eps", "-0.1"], r"argument --eps: must be finite and >= 0"),
        (["--eps", "1e999"], r"argument --eps: must be finite"),
        (["--steps", 10**9, "--h", "1e300"], r"the span steps \* h = .* is not finite"),
    ],
)
def test_bad_drift_options_are_one_line_exit_2(capsys, argv, pattern):
    code, err = _cli(["drift", *argv], capsys)
    assert code == BAD_INPUT
    _one_line_error(err, pattern)


# -- output locations: checked before the run, written atomically ------------------------------------
def test_out_that_is_a_file_or_below_a_file_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    ran = []
    monkeypatch.setattr("geomint.cli.run_scene", lambda *a, **k: ran.append(1))
    taken = tmp_path / "taken"
    taken.write_text("keep me")
    scene = _scene(tmp_path, VALID)
    for out, pattern in (
        (taken, r"--out .*taken: cannot write there \(File exists\)"),
        (taken / "sub", r"--out .*sub: cannot write there \(Not a directory\)"),
        (Path("/dev/full"), r"--out /dev/full: cannot write there"),
    ):
        code, err = _cli(["run", scene, "--out", out], capsys)
        assert code == BAD_INPUT
        _one_line_error(err, pattern)
    assert taken.read_text() == "keep me" and not ran


def test_a_result_name_taken_by_a_folder_is_refused_before_the_run(tmp_path, capsys):
    out = tmp_path / "out"
    (out / "scene.summary.json").mkdir(parents=True)
    code, err = _cli(["run", _scene(tmp_path, VALID), "--out", out], capsys)
    assert code == BAD_INPUT
    _one_line_error(err, r"scene.summary.json exists and is not a file")
    assert not (out / "scene.npz").exists()


@pytest.mark.parametrize("failing", ["numpy.savez_compressed", "matplotlib.figure.Figure.savefig"])
def test_a_disk_that_fills_while_writing_leaves_no_partial_file(tmp_path, capsys, monkeypatch, failing):
    """The write starts (bytes reach the temporary file), then the disk is full: exit 2, one line, and no file
    under the final name of the one being written."""

    def full(target, *args, **kwargs):
        target = args[0] if failing.endswith("savefig") else target
        Path(target).write_bytes(b"half a file")
        raise OSError(28, "No space left on device", str(target))

    monkeypatch.setattr(failing, full)
    out = tmp_path / "out"
    code, err = _cli(["run", _scene(tmp_path, FIGURED), "--out", out, "--quiet"], capsys)
    assert code == BAD_INPUT
    _one_line_error(err, r"No space left on device")
    names = sorted(p.name for p in out.iterdir())
    assert not any(".part" in name for name in names)
    assert names == ([] if failing.startswith("numpy") else ["scene.npz", "scene.summary.json"])


def test_written_files_have_the_usual_permissions(tmp_path, capsys):
    out = tmp_path / "out"
    assert _cli(["run", _scene(tmp_path, FIGURED), "--out", out, "--quiet"], capsys)[0] == OK
    umask = os.umask(0)
    os.umask(umask)
    for path in out.iterdir():
        assert path.stat().st_mode & 0o777 == 0o666 & ~umask, path


def test_list_and_drift_take_traceback_too(capsys):
    assert _cli(["list", "--traceback"], capsys)[0] == OK
    assert _cli(["drift", "--steps", 10, "--traceback"], capsys)[0] == OK


# -- subprocesses: permissions, Ctrl-C, read-only installs --------------------------------------------
ROOT = Path(__file__).resolve().parents[1]


def _answer_sigint():
    """In the child before it starts: SIGINT's default action, which a runner started as a background job (SIGINT
    ignored, and inherited as ignored) would otherwise pass on, so that the Ctrl-C tests cannot be sent nothing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _unprivileged():
    """A command prefix that runs without root's right to ignore file permissions (None if impossible)."""
    if os.geteuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        return None
    return [setpriv, "--inh-caps=-all", "--bounding-set=-dac_override,-dac_read_search,-fowner"]


def _geomint(args, cwd, env=None, prefix=()):
    return subprocess.run(
        [*prefix, sys.executable, "-m", "geomint.cli", *map(str, args)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )


#: ``geomint`` command lines run one after another in one process: argv[1] is a JSON list of ``[cwd, argv]``;
#: prints a JSON list of ``[exit code, stderr]``
_CLI_CASES = """
import contextlib, io, json, os, sys
from geomint.cli import main
results = []
for cwd, argv in json.loads(sys.argv[1]):
    os.chdir(cwd)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exit_:
            code = exit_.code
    results.append([code, err.getvalue()])
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def warm_cli(tmp_path_factory):
    """One short run of ``VALID`` in a subprocess, so that numba's disk cache holds its kernels before a test
    times a subprocess (shared by the Ctrl-C tests: each ran the same warm-up run before)."""
    folder = tmp_path_factory.mktemp("warm")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    _geomint(["run", _scene(folder, VALID, "warm"), "--out", folder / "out", "--quiet"], folder, env)
    return env


def test_unwritable_out_and_unwritable_working_folder(tmp_path):
    prefix = _unprivileged()
    if prefix is None:
        pytest.skip("running as root without setpriv: permissions cannot be enforced")
    scene = _scene(tmp_path, VALID)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cases = (
        (["run", scene, "--out", locked / "out"], tmp_path, "--out .*locked/out"),
        (["run", scene], locked, "--out runs/scene"),
    )
    # both cases in one unprivileged process (``main`` is the console entry point), each from its own folder
    done = subprocess.run(
        [
            *prefix,
            sys.executable,
            "-c",
            _CLI_CASES,
            json.dumps([[str(cwd), [str(a) for a in args]] for args, cwd, _ in cases]),
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    results = json.loads(done.stdout)
    assert len(results) == len(cases)
    for (code, err), (_, _, pattern) in zip(results, cases):
        assert code == BAD_INPUT and "Traceback" not in err
        _one_line_error(err, pattern + r": cannot write there \(Permission denied\)")
    assert list(locked.iterdir()) == []


def test_ctrl_c_in_a_cli_run_writes_what_was_done_and_exits_130(tmp_path, warm_cli):
    long = (
        VALID.replace("points = [[0.6, 0.0, 0.8]]", "points = [[0.6, 0.0, 0.8], [0.0, 0.6, 0.8]]")
        .replace("duration = 0.5", "duration = 1e8")  # the first trajectory alone is ~100 s of steps
        .replace("every = 1", "every = 1000000")
    )
    scene, out = _scene(tmp_path, long), tmp_path / "out"
    env = warm_cli
    process = subprocess.Popen(
        [sys.executable, "-m", "geomint.cli", "run", str(scene), "--out", str(out), "--quiet"],
        cwd=tmp_path,
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_answer_sigint,
    )
    time.sleep(4.0)
    process.send_signal(signal.SIGINT)
    sent = time.perf_counter()
    _, err = process.communicate(timeout=120)
    assert process.returncode == INTERRUPTED and "Traceback" not in err
    assert "interrupted: 1 of 2 trajectories written" in err
    assert time.perf_counter() - sent < 10  # the states are in hand within a chunk (~0.1 s); writing adds the rest
    summary = json.loads((out / "scene.summary.json").read_text())
    assert summary["totals"]["partial"] is True and summary["trajectories"][0]["status"] == 2
    data = np.load(out / "scene.npz")
    assert data["status"].tolist() == [2] and data["rows"][0] > 1
    assert not any(".part" in p.name for p in out.iterdir())


def test_a_read_only_install_with_a_read_only_home_imports_and_solves(tmp_path):
    """The package copied into a read-only folder, HOME read-only: geomint's cache moves to the temporary folder;
    with no writable temporary folder either, kernels compile without a cache after one warning."""
    prefix = _unprivileged()
    if prefix is None:
        pytest.skip("running as root without setpriv: permissions cannot be enforced")
    site, home, tmp = tmp_path / "site", tmp_path / "home", tmp_path / "tmp"
    shutil.copytree(ROOT / "geomint", site / "geomint", ignore=shutil.ignore_patterns("__pycache__"))
    for folder in (home, tmp):
        folder.mkdir()
    code = (
        "import geomint; b = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1); "
        "s = geomint.solve(b, [0.6, 0.0, 0.8], (0.0, 1.0), 0.1, method='rk4'); "
        "print(s.success, geomint._cache.CACHE, geomint._cache.ROOT)"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_CACHE", "GEOMINT_CACHE", "XDG_", "PYTHON"))}
    env.update(PYTHONPATH=str(site), HOME=str(home), TMPDIR=str(tmp))
    for path in [*site.rglob("*"), site, home]:
        path.chmod(0o555 if path.is_dir() else 0o444)
    try:
        with_tmp = subprocess.run(
            [*prefix, sys.executable, "-c", code], cwd=home, env=env, capture_output=True, text=True, timeout=600
        )
        assert with_tmp.returncode == 0, with_tmp.stderr
        assert with_tmp.stdout.split()[:2] == ["True", "True"] and str(tmp) in with_tmp.stdout
        for path in [tmp, *tmp.rglob("*")]:  # and no other temporary folder: Python would fall back to /tmp
            path.chmod(0o555 if path.is_dir() else 0o444)
        pinned = f"import tempfile; tempfile.tempdir = {str(tmp)!r}; " + code
        without = subprocess.run(
            [*prefix, sys.executable, "-c", pinned], cwd=home, env=env, capture_output=True, text=True, timeout=600
        )
        assert without.returncode == 0, without.stderr
        assert without.stdout.split()[:2] == ["True", "False"]
        assert "no writable folder for numba's cache" in without.stderr and "Traceback" not in without.stderr
    finally:
        for path in [site, *site.rglob("*"), home, tmp, *tmp.rglob("*")]:
            path.chmod(0o755)


def test_resume_from_a_checkpoint_gives_the_uninterrupted_run_bit_for_bit(tmp_path, capsys, warm_cli):
    """Ctrl-C once the run's first checkpoint is on disk, then --resume: the arrays equal a run never stopped.
    (Not a fixed delay: on a loaded machine the process may not have started stepping after 2 s.)"""
    scene_text = (
        VALID.replace("points = [[0.6, 0.0, 0.8]]", "points = [[0.6, 0.0, 0.8], [0.0, 0.6, 0.8]]")
        .replace("duration = 0.5", "duration = 1.5e5")
        .replace("every = 1", "every = 997")
    )
    scene = _scene(tmp_path, scene_text)
    env = warm_cli
    out = tmp_path / "resumed"
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "geomint.cli",
            "run",
            str(scene),
            "--out",
            str(out),
            "--quiet",
            "--checkpoint-every",
            "20000",
        ],
        cwd=tmp_path,
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_answer_sigint,
    )
    running = out / "scene.checkpoint" / "running.npz"
    deadline = time.monotonic() + 120
    while not running.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == INTERRUPTED and "resume with --resume" in err, err
    assert json.loads((out / "scene.summary.json").read_text())["totals"]["partial"] is True
    assert (out / "scene.checkpoint" / "running.npz").exists()
    code, err = _cli(["run", scene, "--out", out, "--quiet", "--resume"], capsys)
    assert code == OK, err
    assert not (out / "scene.checkpoint").exists()
    code, _ = _cli(["run", scene, "--out", tmp_path / "whole", "--quiet"], capsys)
    assert code == OK
    resumed, whole = np.load(out / "scene.npz"), np.load(tmp_path / "whole" / "scene.npz")
    assert sorted(resumed.files) == sorted(whole.files)
    for name in whole.files:
        np.testing.assert_array_equal(resumed[name], whole[name])
    summary = json.loads((out / "scene.summary.json").read_text())
    assert summary["totals"]["partial"] is False and summary["totals"]["n_steps"] == 2 * 3_000_000


def test_resume_without_a_checkpoint_or_for_another_scene_is_one_line(tmp_path, capsys):
    scene = _scene(tmp_path, VALID)
    code, err = _cli(["run", scene, "--out", tmp_path / "out", "--resume"], capsys)
    assert code == BAD_INPUT
    _one_line_error(
        err, r"--resume: no checkpoint in .*scene.checkpoint \(the run finished, .*\); run with a checkpoint first"
    )
    assert _cli(["run", scene, "--out", tmp_path / "out", "--checkpoint-every", 3, "--quiet"], capsys)[0] == OK
    (tmp_path / "out" / "scene.checkpoint").mkdir()
    (tmp_path / "out" / "scene.checkpoint" / "checkpoint.json").write_text('{"scene": {}, "every": 3}')
    code, err = _cli(["run", scene, "--out", tmp_path / "out", "--resume"], capsys)
    assert code == BAD_INPUT
    _one_line_error(err, r"--resume: the checkpoint in .* was written for another scene")
