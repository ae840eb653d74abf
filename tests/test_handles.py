"""How user functions reach the kernels (``geomint.model.handles``): inlined and cached where they can be found
again by name, first-class elsewhere, with the same results either way."""

import os
import pickle
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core.types.function_type import CompileResultWAP

import geomint
from geomint.model import handles
from geomint.model.identity import function_key
from geomint.systems import relaxing_rigid_body

pytestmark = pytest.mark.inlined  # the step loop as users run it (conftest.py)


@numba.njit
def _H(x, p):
    return 0.5 * (p[0] * x[0] ** 2 + p[1] * x[1] ** 2 + p[2] * x[2] ** 2)


@numba.njit
def _grad_H(x, p):
    return (p[0] * x[0], p[1] * x[1], p[2] * x[2])


@numba.njit
def _S(x, p):
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


@numba.njit
def _grad_S(x, p):
    return (x[0], x[1], x[2])


@numba.njit
def _J(x, p):
    return (x[0], x[1], x[2])


def _body(**functions):
    arguments = dict(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, J=_J, params=[0.5, 1.0, 1.5], eps=0.1)
    return geomint.MetriplecticSystem(**{**arguments, **functions})


X0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])


def test_module_level_functions_are_inlined_and_local_ones_first_class():
    @numba.njit
    def local_S(x, p):
        return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)

    model = _body(S=local_S).inlined_model
    assert isinstance(model.H, handles.InlinedHandle) and model.H.dispatcher is _H
    assert model.H.key[:2] == (__name__, "_H")
    assert isinstance(model.S, CompileResultWAP)  # made inside a function: no stable name to cache it by
    assert function_key(local_S) is None
    assert function_key(lambda x, p: 0.0) is None


def test_the_model_of_every_other_kernel_is_first_class():
    model = _body().model
    assert all(isinstance(fn, CompileResultWAP) for fn in (model.H, model.grad_H, model.S, model.grad_S, model.J))


def test_GEOMINT_INLINE_0_hands_every_function_over_first_class(monkeypatch):
    monkeypatch.setenv("GEOMINT_INLINE", "0")
    model = _body().inlined_model
    assert all(isinstance(fn, CompileResultWAP) for fn in (model.H, model.grad_H, model.S, model.grad_S, model.J))


@pytest.mark.parametrize(
    ("setting", "in_r3", "in_rn"), [(None, True, False), ("1", True, False), ("all", True, True), ("0", False, False)]
)
def test_GEOMINT_INLINE_chooses_where_the_functions_are_inlined(setting, in_r3, in_rn, monkeypatch):
    """Inlined in R^3 by default, in R^n too under ``all``, nowhere under ``0``."""
    if setting is None:
        monkeypatch.delenv("GEOMINT_INLINE", raising=False)
    else:
        monkeypatch.setenv("GEOMINT_INLINE", setting)
    assert (handles.enabled(), handles.enabled(rn=True)) == (in_r3, in_rn)
    assert isinstance(_body().inlined_model.H, handles.InlinedHandle) is in_r3
    gas = geomint.systems.gas_containers()
    assert isinstance(gas.inlined_model.H, handles.InlinedHandle) is in_rn


#: a method of each engine: discrete gradient, explicit, composition, splitting, projected pair (adaptive)
_ENGINES = {
    "gonzalez": lambda: "gonzalez",
    "rk4": lambda: "rk4",
    "yoshida4": lambda: "yoshida4",
    "Strang(Gonzalez(), AVF())": lambda: geomint.Strang(geomint.Gonzalez(), geomint.AVF()),
    "Projected(DormandPrince853()), adaptive": lambda: geomint.Projected(geomint.DormandPrince853()),
}


@pytest.mark.parametrize("name", list(_ENGINES))
def test_inlined_and_first_class_kernels_give_the_same_bits(name, monkeypatch):
    """tests/test_digests.py holds every method on every zoo system to recorded bits with the functions
    first-class (conftest.py); here a method of each engine gives the same bits inlined."""
    h = None if name.endswith("adaptive") else 0.01
    options = {"rtol": 1e-8, "atol": 1e-10} if h is None else {}
    inlined = geomint.solve(_body(), X0, (0.0, 5.0), h, method=_ENGINES[name](), **options)
    monkeypatch.setenv("GEOMINT_INLINE", "0")
    first_class = geomint.solve(_body(), X0, (0.0, 5.0), h, method=_ENGINES[name](), **options)
    np.testing.assert_array_equal(inlined.x, first_class.x)
    np.testing.assert_array_equal(inlined.H, first_class.H)
    np.testing.assert_array_equal(inlined.S, first_class.S)


@pytest.mark.slow  # compiles the R^n step loop for the gas containers (a minute or more)
@pytest.mark.parametrize("adaptive", [False, True], ids=["fixed", "adaptive"])
def test_an_rn_system_specialised_gives_the_bits_of_its_first_class_run(adaptive, monkeypatch):
    """``GEOMINT_INLINE=all`` specialises an R^n system's step loop to its functions (off by default): the same
    states, H and S, bit for bit, as the first-class run, with fixed steps and adaptive ones."""
    gas, x0 = geomint.systems.gas_containers(), np.array([1.2, 0.3, 2.0, 2.0])
    options = {"rtol": 1e-8} if adaptive else {"h": 0.05}
    monkeypatch.setenv("GEOMINT_INLINE", "all")
    assert isinstance(gas.inlined_model.grad_H, handles.InlinedHandle)
    inlined = geomint.solve(gas, x0, (0.0, 20.0), **options)
    monkeypatch.setenv("GEOMINT_INLINE", "0")
    first_class = geomint.solve(geomint.systems.gas_containers(), x0, (0.0, 20.0), **options)
    assert inlined.success and first_class.success, (inlined.message, first_class.message)
    np.testing.assert_array_equal(inlined.x, first_class.x)
    np.testing.assert_array_equal(inlined.H, first_class.H)
    np.testing.assert_array_equal(inlined.S, first_class.S)


def test_a_key_unpickles_to_the_live_type_or_to_one_that_matches_nothing_and_keeps_its_key():
    live = numba.typeof(relaxing_rigid_body().inlined_model.H)
    assert isinstance(live, handles.Inlined)
    assert pickle.loads(pickle.dumps(live)) is live
    key = ("a_module_never_imported", "f", "0" * 16, "0" * 8)
    away = handles._rebuild(key)
    assert isinstance(away, handles.Unloaded) and away != live
    assert pickle.loads(pickle.dumps(away)) == away  # an index rewritten elsewhere keeps the entry's key


def test_a_handle_travels_to_another_process_as_its_function():
    handle = relaxing_rigid_body().inlined_model.grad_H
    again = pickle.loads(pickle.dumps(handle))
    assert isinstance(again, handles.InlinedHandle) and again.key == handle.key
    assert again(X0, np.array([0.5, 1.0, 1.5])) == handle(X0, np.array([0.5, 1.0, 1.5]))


_RUN = """
import numpy as np, geomint, user
from geomint._kernels import loop
system = geomint.MetriplecticSystem(H=user.H, grad_H=user.grad_H, S=user.S, grad_S=user.grad_S, J=user.J, eps=0.1)
geomint.solve(system, np.array([0.6, 0.0, 0.8]), (0.0, 1.0), 0.01, method="rk4")
stats = loop.run.stats
print(sum(stats.cache_hits.values()), sum(stats.cache_misses.values()))
"""


@pytest.mark.slow
def test_a_second_process_loads_the_kernels_compiled_for_a_user_system(tmp_path):
    (tmp_path / "user.py").write_text((Path(__file__).parent / "data" / "user_rigid_body.py").read_text())
    environment = {**os.environ, "GEOMINT_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path)}

    def run():
        out = subprocess.run(
            [sys.executable, "-c", _RUN], env=environment, cwd=tmp_path, capture_output=True, text=True, check=True
        )
        return tuple(int(v) for v in out.stdout.split()[-2:])

    assert run() == (0, 1)  # compiled for this system
    assert run() == (1, 0)  # loaded from disk
