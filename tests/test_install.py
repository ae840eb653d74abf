"""The README's commands in the order a newcomer runs them: a non-editable install that runs a solve, then an
editable install over it, imported from another folder.

Compiled code must land in the user cache folder (``geomint._cache``), never inside the installed package: pip
removes only the files its RECORD lists, and numba cache files left in ``site-packages/geomint/__pycache__``
keep a bare ``site-packages/geomint/`` that shadows a later editable install as an empty namespace package.
"""

import os
import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOLVE = (
    "import geomint; b = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1); "
    "s = geomint.solve(b, [0.6, 0.0, 0.8], (0.0, 1.0), 0.1, method='rk4'); "
    "print(s.success, geomint.__file__)"
)


def _run(args, **kwargs):
    out = subprocess.run(args, capture_output=True, text=True, timeout=900, **kwargs)
    assert out.returncode == 0, f"{' '.join(map(str, args))}\n{out.stdout}\n{out.stderr}"
    return out.stdout


@pytest.mark.slow
def test_install_run_then_editable_install_imports_the_checkout_from_anywhere(tmp_path):
    source, venv, cache, elsewhere = (tmp_path / name for name in ("source", "venv", "cache", "elsewhere"))
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(
            ".git", ".venv", "__pycache__", "build", "*.egg-info", "runs", "site", ".hypothesis", "tests"
        ),
    )
    elsewhere.mkdir()
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])  # pip and setuptools: this one's
    python = venv / "bin" / "python"
    purelib = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).strip())
    # the new environment sees this one's packages (numpy, numba, pip ...): nothing to download but the build backend
    (purelib / "outer.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    pip = [str(python), "-m", "pip", "install", "-q", "--no-deps"]  # the build backend from PyPI, as README's install
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR")}
    env["GEOMINT_CACHE_DIR"] = str(cache)

    _run([*pip, str(source)], env=env)
    installed = purelib / "geomint"
    success, where = _run([str(python), "-c", SOLVE], cwd=elsewhere, env=env).split()
    assert success == "True" and Path(where).is_relative_to(installed)
    assert not [p.name for p in installed.rglob("*") if p.suffix in (".nbi", ".nbc")], "compiled code in the package"
    assert list(cache.rglob("*.nbi")), "nothing was cached in GEOMINT_CACHE_DIR"

    _run([*pip, "-e", str(source)], env=env)
    assert not installed.exists(), f"the non-editable install left {sorted(installed.rglob('*'))[:5]}"
    version, where = _run(
        [str(python), "-c", "import geomint; print(geomint.__version__, geomint.__file__)"], cwd=elsewhere, env=env
    ).split()
    assert Path(where).is_relative_to(source) and version[0].isdigit()
    assert "rigid_body_distinct" in _run([str(venv / "bin" / "geomint"), "list"], cwd=elsewhere, env=env)
