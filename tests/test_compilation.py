"""Compile once: kernels load from numba's disk cache in a new process; a pure-Python lane works; importing
geomint leaves the heavy optional modules (sympy, matplotlib) unloaded until they are used."""

import os
import subprocess
import sys
from pathlib import Path

import numba
import pytest
from numba import njit
from numba.core import event
from numba.extending import overload

from geomint._kernels import jit

FIRST_SOLVE = """
import time
start = time.perf_counter()
import geomint
from geomint._kernels import loop
body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
sol = geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 1.0), 0.05)
stats = loop.run.stats
print(sum(stats.cache_hits.values()), sum(stats.cache_misses.values()), sol.success, time.perf_counter() - start)
"""


def _python(code, *arguments, cwd=None, **env):
    """The standard output of ``code`` run in a fresh process with ``arguments``, in ``cwd``, ``env`` added."""
    result = subprocess.run(
        [sys.executable, "-c", code, *arguments],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=cwd,
        env={**os.environ, **env},
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_a_second_process_loads_the_kernels_from_the_cache():
    _python(FIRST_SOLVE)  # compiles if this machine has not yet
    hits, misses, success, seconds = _python(FIRST_SOLVE).split()
    print(f"first solve in a new process (import included): {float(seconds):.2f} s")
    assert (int(hits), int(misses), success) == (1, 0, "True")


def test_importing_geomint_loads_neither_sympy_nor_matplotlib():
    """sympy (~0.5 s) is for systems written as formulas, matplotlib for figures: a run without either does not
    pay for their import."""
    loaded = _python("import sys, geomint; print(*[m for m in ('sympy', 'matplotlib') if m in sys.modules])")
    assert loaded.split() == []


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1", reason="this test starts the pure-Python lane")
def test_the_pure_python_lane_passes():
    """``NUMBA_DISABLE_JIT=1`` runs the kernels as Python (debugging, coverage): the fast subset passes."""
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-n",
            "0",
            "-m",
            "nojit",
            "-p",
            "no:cacheprovider",
            os.path.dirname(__file__),
        ],
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, "NUMBA_DISABLE_JIT": "1"},
    )
    print(result.stdout[-2000:])
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert " passed" in result.stdout and " failed" not in result.stdout


def _compiled_during(call):
    """The names of the functions numba compiled while ``call()`` ran, and its result."""
    with event.install_recorder("numba:compile") as recorder:
        result = call()
    events = [e for _, e in recorder.buffer if e.is_start and "dispatcher" in e.data]
    names = {e.data["dispatcher"].py_func.__name__ for e in events}
    return names, result


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="compiled code only")
@pytest.mark.parametrize("typed", [True, False], ids=["typed_inline", "numba_overload"])
def test_typed_inline_inlines_its_implementation_without_compiling_it_alone(typed):
    """``jit.typed_inline`` types and inlines the implementation an overload returns without compiling it on its
    own, which numba's ``overload(inline="always")`` does (the implementation shows among the compiled
    functions: the case that shows this test can fail)."""
    if typed and not jit.TYPED_INLINE:
        pytest.skip(f"numba {numba.__version__} is not among the versions typed_inline was checked with")

    def doubled(x):
        return 2.0 * x

    register = jit.typed_inline(doubled) if typed else overload(doubled, inline="always", jit_options=jit.OVERLOADED)

    @register
    def _doubled_typed(x):
        return lambda x: 2.0 * x  # an implementation numba would compile on its own as "<lambda>"

    @njit
    def caller(x):
        return doubled(x) + 1.0

    compiled, value = _compiled_during(lambda: caller(3.0))
    assert value == 7.0
    assert ("<lambda>" in compiled) is not typed
    assert "caller" in compiled


def test_only_types_holding_no_dispatcher_count_as_model_free():
    """``jit._specialised``: a compilation for a function's dispatcher type (an inlined user function), alone or
    inside (nested) tuples such as a model, is specialised to that function object; numbers, arrays and
    first-class function types are not."""
    dispatcher = numba.types.Dispatcher(njit(lambda x: x))
    first_class = numba.types.FunctionType(numba.types.float64(numba.types.float64))
    array = numba.types.float64[:]
    assert not jit._specialised(numba.types.float64)
    assert not jit._specialised(numba.types.UniTuple(numba.types.float64, 3))
    assert not jit._specialised(numba.types.Tuple((array, first_class)))
    assert jit._specialised(dispatcher)
    assert jit._specialised(numba.types.Tuple((array, numba.types.Tuple((numba.types.float64, dispatcher)))))


NEW_SYSTEM = """
import sys
import numpy as np
import geomint
from geomint._kernels import newton
if sys.argv[1] == "user":
    import user as u
    system = geomint.MetriplecticSystem(H=u.H, grad_H=u.grad_H, S=u.S, grad_S=u.grad_S, J=u.J, eps=0.1)
else:
    system = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
sol = geomint.solve(system, [np.cos(1.1), 0.0, np.sin(1.1)], (0.0, 1.0), 0.01)
loaded = lambda kernel: sum(kernel.stats.cache_hits.values())
print(sol.success, loaded(newton.remember), loaded(newton.newton))
"""


@pytest.mark.slow
@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="compiled code only")
def test_a_new_system_loads_the_kernels_that_do_not_depend_on_it(tmp_path):
    """A loop compiled for a new system loads from the cache the kernels whose arguments hold none of the
    system's functions (``newton.remember``) and compiles those that call them (``newton.newton``), which are
    cached only inside the loop: nothing of theirs is written on its own (``jit._ModelFreeCache``)."""
    (tmp_path / "user.py").write_text((Path(__file__).parent / "data" / "user_rigid_body.py").read_text())
    # the library's default (the test session hands functions over first-class: tests/conftest.py)
    env = {"GEOMINT_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path), "GEOMINT_INLINE": "1"}

    def run(which):
        return _python(NEW_SYSTEM, which, cwd=tmp_path, **env).split()

    assert run("catalogue") == ["True", "0", "0"]  # an empty cache: everything compiled
    assert run("user") == ["True", "1", "0"]  # remember loaded, newton compiled for the new system
    cached = [p.name for p in (tmp_path / "cache").rglob("*.nbi")]
    assert any(name.startswith("newton.remember-") for name in cached)
    assert not any(name.startswith("newton.newton-") for name in cached)
