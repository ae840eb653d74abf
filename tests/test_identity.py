"""What names a user function across processes (``geomint.model.identity``), and what is cached by that name: the
kernels specialised to it (``tests/test_handles.py``) and its own compiled code (``geomint.model.functions.compiled``,
``geomint._cache.keep_compiled``)."""

import os
import subprocess
import sys
import types
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core import caching

from geomint import _cache
from geomint.model.functions import compiled
from geomint.model.identity import function_key, unseen_part
from geomint.systems import gas_containers

SIGNATURE = (numba.types.float64[::1], numba.types.float64[::1])


@numba.njit
def _H(x, p):
    return 0.5 * (p[0] * x[0] ** 2 + p[1] * x[1] ** 2 + p[2] * x[2] ** 2)


def test_the_key_follows_the_source_file_and_the_compile_options():
    key = function_key(_H)
    assert key is not None and key == function_key(_H)
    copy = types.FunctionType(_H.py_func.__code__, globals(), "_H_fast")
    copy.__qualname__ = "_H_fast"
    globals()["_H_fast"] = fast = numba.njit(fastmath=True)(copy)  # found again under its name
    try:
        other = function_key(fast)
        assert other is not None and other[:3] == (__name__, "_H_fast", key[2]) and other[3] != key[3]
        assert unseen_part(other) != unseen_part(key)  # numba's own index would not tell them apart
    finally:
        del globals()["_H_fast"]


SCALE = 0.5
WEIGHTS = np.array([0.5, 1.0, 1.5])


@numba.njit
def _weighted(x, i):
    return WEIGHTS[i] * x[i] ** 2


@numba.njit
def _H_scaled(x, p):
    return SCALE * (_weighted(x, 0) + _weighted(x, 1) + _weighted(x, 2))


def test_the_key_follows_the_globals_numba_freezes_in():
    """numba compiles a global number or array into the code as a constant: a script that sets one (a size read
    from its command line) must not be served code cached for another value.  The key follows the globals the
    function reads and those of the numba functions it calls; other globals (modules, functions) do not move it."""
    global SCALE, WEIGHTS
    key = function_key(_H_scaled)
    assert key is not None
    try:
        SCALE = 0.25
        scaled = function_key(_H_scaled)
        assert scaled is not None and scaled[:2] == key[:2] and scaled[2] != key[2]
        assert unseen_part(scaled) != unseen_part(key)
        SCALE = 0.5
        assert function_key(_H_scaled) == key
        WEIGHTS = np.array([0.5, 1.0, 2.0])  # read by the helper it calls
        weighted = function_key(_H_scaled)
        assert weighted is not None and weighted[2] not in (key[2], scaled[2])
    finally:
        SCALE, WEIGHTS = 0.5, np.array([0.5, 1.0, 1.5])
    assert function_key(_H_scaled) == key
    assert function_key(_H)[2].split(".")[0] == key[2].split(".")[0]  # the same file


@numba.njit
def _S_kept(x, p):
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


def test_a_module_level_function_is_kept_in_the_cache_root_and_others_are_left_as_they_are():
    result = compiled(_S_kept, SIGNATURE)
    assert result.signature.return_type == numba.types.float64
    if _cache.ROOT is not None:
        locator = _S_kept._cache._impl.locator
        assert isinstance(locator, _cache.UserFunctionLocator)
        assert Path(locator.get_cache_path()).is_relative_to(Path(_cache.ROOT) / "numba" / "user")
        assert locator.get_disambiguator().endswith(unseen_part(function_key(_S_kept)))

    @numba.njit
    def local(x, p):  # made inside a function: nothing names it in another process
        return x[0]

    compiled(local, SIGNATURE)
    assert isinstance(local._cache, caching.NullCache)
    catalogue = gas_containers().functions.H  # njit(cache=...) by geomint: numba's own cache, untouched
    assert not _cache.keep_compiled(catalogue, "tag")
    assert not isinstance(catalogue._cache._impl.locator, _cache.UserFunctionLocator)


#: the user's modules the processes import as ``user`` (R^3) and ``chain`` (R^n)
USER_MODULE = (Path(__file__).parent / "data" / "user_rigid_body.py").read_text()
CHAIN_MODULE = (Path(__file__).parent / "data" / "user_chain.py").read_text()

#: builds the system (no structure checks: no kernel compiled) and prints the five functions' cache hits and misses,
#: and H at (1, 1, 1)
_BUILD = """
import numpy as np, geomint, user
functions = (user.H, user.grad_H, user.S, user.grad_S, user.J)
geomint.MetriplecticSystem(H=user.H, grad_H=user.grad_H, S=user.S, grad_S=user.grad_S, J=user.J, eps=0.1, check=False)
hits = sum(sum(fn.stats.cache_hits.values()) for fn in functions)
misses = sum(sum(fn.stats.cache_misses.values()) for fn in functions)
print(hits, misses, user.H(np.ones(3), np.zeros(0)))
"""


def _build(folder, cache, scale="0.5", script=_BUILD, *arguments):
    """Runs ``script`` (``_BUILD``, or ``_BUILD_N`` with n in ``arguments``) in a fresh process importing from
    ``folder``, geomint's cache in ``cache``: ``(hits, misses, H)``."""
    environment = {**os.environ, "GEOMINT_CACHE_DIR": str(cache), "PYTHONPATH": str(folder), "USER_SCALE": scale}
    out = subprocess.run(
        [sys.executable, "-c", script, *arguments],
        env=environment,
        cwd=folder,
        capture_output=True,
        text=True,
        check=True,
    )
    hits, misses, value = out.stdout.split()[-3:]
    return int(hits), int(misses), float(value)


def test_a_second_process_loads_the_users_functions_and_never_writes_beside_them(tmp_path):
    folder, cache = tmp_path / "src", tmp_path / "cache"
    folder.mkdir()
    (folder / "user.py").write_text(USER_MODULE)
    assert _build(folder, cache) == (0, 5, 3.0)  # compiled, kept
    assert _build(folder, cache) == (5, 0, 3.0)  # loaded
    assert list((cache / "numba" / "user").rglob("user.H-*.nbi"))
    assert not [p for p in folder.rglob("*") if p.suffix in (".nbi", ".nbc")]


def test_the_kept_code_follows_the_frozen_globals_and_the_file(tmp_path):
    """A global read from the environment into the compiled code (numba freezes it) gets code of its value, and
    each value keeps its own; an edit of the file compiles every function of it again."""
    folder, cache = tmp_path / "src", tmp_path / "cache"
    folder.mkdir()
    (folder / "user.py").write_text(USER_MODULE)
    assert _build(folder, cache) == (0, 5, 3.0)
    assert _build(folder, cache, scale="0.25") == (3, 2, 1.5)  # H and grad_H read SCALE; S, grad_S, J do not
    assert _build(folder, cache) == (5, 0, 3.0)  # the first value's code is still there
    (folder / "user.py").write_text(USER_MODULE.replace("3.0 * x[2] ** 2", "7.0 * x[2] ** 2"))
    assert _build(folder, cache) == (0, 5, 5.0)


#: the same for a system in R^n (``dim`` from the command line), its five functions returning arrays
_BUILD_N = """
import sys
import numpy as np, geomint, chain
functions = (chain.H, chain.grad_H, chain.S, chain.grad_S, chain.P)
n = int(sys.argv[1])
geomint.MetriplecticSystem(
    H=chain.H, grad_H=chain.grad_H, S=chain.S, grad_S=chain.grad_S, P=chain.P, eps=0.1, dim=n, check=False
)
hits = sum(sum(fn.stats.cache_hits.values()) for fn in functions)
misses = sum(sum(fn.stats.cache_misses.values()) for fn in functions)
print(hits, misses, chain.H(np.ones(n), np.zeros(0)))
"""


@pytest.mark.parametrize("n", [2, 4, 16, 64])
def test_a_second_process_loads_the_functions_of_a_system_in_rn(n, tmp_path):
    """Arrays in, arrays out, any n: the code numba compiles for ``(x, params)`` does not depend on n, so one
    kept compilation serves every n."""
    folder, cache = tmp_path / "src", tmp_path / "cache"
    folder.mkdir()
    (folder / "chain.py").write_text(CHAIN_MODULE)

    def build(size):
        return _build(folder, cache, "0.5", _BUILD_N, str(size))

    assert build(n) == (0, 5, 0.5 * n)
    assert build(n) == (5, 0, 0.5 * n)
    assert build(n + 1) == (5, 0, 0.5 * (n + 1))  # another n: the same code
    assert not [p for p in folder.rglob("*") if p.suffix in (".nbi", ".nbc")]
