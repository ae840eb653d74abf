"""Systems from formulas: bit-for-bit against hand-written kernels, symbolic checks, disk cache, injection."""

import os
import subprocess
import sys

import numpy as np
import pytest
from hostile_strings import hostile
from numba import njit

import geomint
from geomint.model import expressions

LORENZ_NEVIR = dict(
    H="(y**2 + z**2)/2 - r*z", S="x**2/2 - sigma*z", J=("-x", "0", "sigma"), params={"sigma": 10.0, "r": 28.0}
)
COSH_EXP = dict(
    H="a*cosh(x) + cosh(y) + exp(z) - z",
    S="cosh(x) + z**2/2",
    J=("exp(y/2)*sinh(x)", "0", "exp(y/2)*z"),
    params={"a": 0.5},
)


# hand-written kernels, spelt the way the generator writes its arithmetic
@njit(cache=True)
def _ln_H(x, p):
    return -p[1] * x[2] + 0.5 * x[1] ** 2 + 0.5 * x[2] ** 2


@njit(cache=True)
def _ln_grad_H(x, p):
    return (0.0, x[1], -p[1] + x[2])


@njit(cache=True)
def _ln_S(x, p):
    return -p[0] * x[2] + 0.5 * x[0] ** 2


@njit(cache=True)
def _ln_grad_S(x, p):
    return (x[0], 0.0, -p[0])


@njit(cache=True)
def _ln_J(x, p):
    return (-x[0], 0.0, p[0])


@njit(cache=True)
def _ce_H(x, p):
    return p[0] * np.cosh(x[0]) - x[2] + np.exp(x[2]) + np.cosh(x[1])


@njit(cache=True)
def _ce_grad_H(x, p):
    return (p[0] * np.sinh(x[0]), np.sinh(x[1]), np.exp(x[2]) - 1.0)


@njit(cache=True)
def _ce_S(x, p):
    return 0.5 * x[2] ** 2 + np.cosh(x[0])


@njit(cache=True)
def _ce_grad_S(x, p):
    return (np.sinh(x[0]), 0.0, x[2])


@njit(cache=True)
def _ce_J(x, p):
    return (np.exp(0.5 * x[1]) * np.sinh(x[0]), 0.0, x[2] * np.exp(0.5 * x[1]))


HAND_WRITTEN = {
    "lorenz_nevir": (LORENZ_NEVIR, (_ln_H, _ln_grad_H, _ln_S, _ln_grad_S, _ln_J), [-2.0, 3.0, 20.0], 0.1),
    "cosh_exp": (COSH_EXP, (_ce_H, _ce_grad_H, _ce_S, _ce_grad_S, _ce_J), [0.7, -0.4, 0.5], 0.3),
}


@pytest.mark.parametrize("name", sorted(HAND_WRITTEN))
def test_expression_system_matches_hand_written_kernels_bit_for_bit(name):
    spec, (H, grad_H, S, grad_S, J), x0, eps = HAND_WRITTEN[name]
    from_text = geomint.MetriplecticSystem.from_expressions(**spec, eps=eps, name=name)
    by_hand = geomint.MetriplecticSystem(
        H=H, grad_H=grad_H, S=S, grad_S=grad_S, J=J, eps=eps, params=list(spec["params"].values()), name=name
    )
    runs = [geomint.solve(system, x0, (0.0, 1e4 * 1e-3), 1e-3, method="gonzalez") for system in (from_text, by_hand)]
    assert all(sol.success and sol.n_steps == 10_000 for sol in runs)
    assert np.array_equal(runs[0].x, runs[1].x)
    assert np.array_equal(runs[0].H, runs[1].H) and np.array_equal(runs[0].S, runs[1].S)
    assert np.ptp(runs[0].x[:, 0]) > 0.1  # the trajectory moves: the comparison is not vacuous


def test_gradients_are_exact_derivatives():
    system = geomint.MetriplecticSystem.from_expressions(**COSH_EXP)
    x = np.array([0.3, -0.2, 0.4])
    np.testing.assert_allclose(system.grad_H(x), [0.5 * np.sinh(0.3), np.sinh(-0.2), np.exp(0.4) - 1.0], rtol=1e-15)
    np.testing.assert_allclose(system.grad_S(x), [np.sinh(0.3), 0.0, 0.4], rtol=1e-15)


def test_a_J_that_fails_jacobi_is_refused_with_the_residual():
    with pytest.raises(ValueError, match=r"`J` fails Jacobi: J \. curl J = 0 .* simplifies to -x\*z"):
        geomint.MetriplecticSystem.from_expressions(H="x**2/2", S="z**2/2", J=("y*z", "0", "x"))


def test_an_S_that_is_not_a_casimir_is_refused_with_the_residual():
    with pytest.raises(ValueError, match=r"`S` is not a Casimir of J: grad S x J = 0 fails; .* \[-x\*z, -y\*z, 0\]"):
        geomint.MetriplecticSystem.from_expressions(H="x**2/2", S="z**2/2", J=("-y", "x", "0"))


def test_a_P_that_is_not_skew_is_refused():
    with pytest.raises(ValueError, match=r"`P` is not skew: P \+ P\^T = 0 fails"):
        geomint.MetriplecticSystem.from_expressions(
            H="x**2/2", S="z**2/2", P=(("0", "z", "0"), ("z", "0", "0"), ("0", "0", "0"))
        )


def test_a_skew_P_gives_the_same_field_as_its_axial_vector():
    P = (("0", "1", "0"), ("-1", "0", "0"), ("0", "0", "0"))  # P v = v x (0, 0, 1)
    as_matrix = geomint.MetriplecticSystem.from_expressions(H="(x**2 + y**2 + z**2)/2", S="z**2/2", P=P, eps=0.5)
    as_axial = geomint.MetriplecticSystem.from_expressions(
        H="(x**2 + y**2 + z**2)/2", S="z**2/2", J=("0", "0", "1"), eps=0.5
    )
    x = np.array([0.6, 0.0, 0.8])
    np.testing.assert_array_equal(as_matrix.functions.poisson(x, np.empty(0)), [[0, 1, 0], [-1, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(as_matrix.xi(x), as_axial.xi(x), rtol=1e-15)
    runs = [geomint.solve(system, x, (0.0, 1.0), 0.1) for system in (as_matrix, as_axial)]
    np.testing.assert_allclose(runs[0].x, runs[1].x, rtol=1e-13, atol=1e-15)
    assert runs[0].S[-1] < runs[0].S[0]


def test_an_identity_that_holds_only_at_the_given_parameter_values_is_accepted():
    spec = dict(H="x**2/2", S="z**2/2", J=("k*x", "0", "z"))
    with pytest.raises(ValueError, match="Casimir"):
        geomint.MetriplecticSystem.from_expressions(**spec, params={"k": 1.0})
    assert geomint.MetriplecticSystem.from_expressions(**spec, params={"k": 0.0}).params.tolist() == [0.0]


SECOND_PROCESS = """
import geomint
system = geomint.MetriplecticSystem.from_expressions(
    H="a*cosh(x) + cosh(y) + exp(z) - z", S="cosh(x) + z**2/2 + b", J=("exp(y/2)*sinh(x)", "0", "exp(y/2)*z"),
    params={"a": 0.5, "b": 1.0})
functions = system.functions
stats = [fn.stats for fn in (functions.H, functions.grad_H, functions.S, functions.grad_S, functions.poisson)]
print(sum(sum(s.cache_hits.values()) for s in stats), sum(sum(s.cache_misses.values()) for s in stats))
"""


def test_a_second_process_loads_the_generated_code_from_the_disk_cache(tmp_path):
    env = {**os.environ, "GEOMINT_CACHE_DIR": str(tmp_path)}
    runs = [
        subprocess.run([sys.executable, "-c", SECOND_PROCESS], capture_output=True, text=True, env=env, timeout=600)
        for _ in range(2)
    ]
    assert all(run.returncode == 0 for run in runs), runs[0].stderr + runs[1].stderr
    (first_hits, first_misses), (hits, misses) = (map(int, run.stdout.split()) for run in runs)
    assert (first_hits, first_misses) == (0, 5)
    assert (hits, misses) == (5, 0)
    assert len(list(tmp_path.glob("expressions/geomint_expr_*.py"))) == 1


def test_the_cache_falls_back_when_the_configured_folder_is_not_writable(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("GEOMINT_CACHE_DIR", str(blocked / "cache"))
    assert expressions.cache_directory() != blocked / "cache"


FIELDS = ["H", "S", "J[0]", "J[1]", "J[2]", "P[0][1]", "P[2][2]"]


def _with(field, text):
    spec = dict(H="x**2/2", S="z**2/2", params={"a": 1.0})
    if field.startswith("P"):
        rows = [["0", "1", "0"], ["-1", "0", "0"], ["0", "0", "0"]]
        rows[int(field[2])][int(field[5])] = text
        spec["P"] = rows
    else:
        spec["J"] = ["0", "0", "1"]
        if field.startswith("J"):
            spec["J"][int(field[2])] = text
        else:
            spec[field] = text
    return spec


@pytest.mark.nojit
@pytest.mark.parametrize("field", FIELDS)
def test_hostile_formulas_are_refused_in_every_field_and_nothing_runs(field, tmp_path):
    sentinel = tmp_path / "pwned"
    strings = hostile(sentinel)
    assert len(strings) >= 30
    for text in strings:
        with pytest.raises(ValueError) as info:
            expressions.build(**_with(field, text))
        assert str(info.value).startswith(f"`{field}`"), (text, str(info.value))
    assert not sentinel.exists()


@pytest.mark.nojit
def test_hostile_parameter_names_are_refused(tmp_path):
    for name in ["__class__", "x", "exp", "os.system", "a b", "_private", "pi", 3]:
        with pytest.raises(ValueError, match="`params` name"):
            expressions.check_parameters({name: 1.0})


@pytest.mark.nojit
def test_grammar_errors_name_the_field_and_the_piece():
    with pytest.raises(ValueError, match=r"`S`: not a whitelisted function: \"__import__\('os'\).system\""):
        expressions.parse("S", "__import__('os').system('ls')")
    unknown = r"`H`: unknown name \(declare parameters in `params`; in a scene file, `parameters`\): 'b'"
    with pytest.raises(ValueError, match=unknown):
        expressions.parse("H", "a*x + b", ["a"])


def test_new_params_reach_the_recorded_formulas_of_saved_results(tmp_path):
    """``with_effects(params=...)`` changes what the system computes; the formulas' record (written into saved
    results beside the parameter vector) takes the new values under the same names, in R^3 and in R^n."""
    lorenz = geomint.MetriplecticSystem.from_expressions(**LORENZ_NEVIR)
    changed = lorenz.with_effects(params=[1.0, 2.0])
    assert changed.expressions["params"] == {"sigma": 1.0, "r": 2.0} and changed.params.tolist() == [1.0, 2.0]
    assert lorenz.expressions["params"] == {"sigma": 10.0, "r": 28.0}
    path = geomint.solve(changed, [1.0, 0.5, 0.2], (0.0, 0.1), 0.05).save(tmp_path / "l", changed)
    saved = geomint.results.io.read_metadata(path)
    recorded = saved["system"]
    assert recorded["params"] == [1.0, 2.0] and recorded["expressions"]["params"] == {"sigma": 1.0, "r": 2.0}
    oscillator = geomint.GenericSystem.from_expressions(
        variables=("q", "p", "s"),
        E="p**2/2 + k*q**2/2 + s",
        S="s",
        L=[["0", "1", "0"], ["-1", "0", "0"], ["0", "0", "0"]],
        M=[["0", "0", "0"], ["0", "g", "-g*p"], ["0", "-g*p", "g*p**2"]],
        params={"k": 1.0, "g": 0.5},
    )
    assert oscillator.with_effects(params=[2.0, 0.25]).expressions["params"] == {"k": 2.0, "g": 0.25}


def test_with_P_given_the_casimir_message_says_J_is_its_axial_vector():
    with pytest.raises(ValueError, match=r"`S` is not a Casimir of J, the axial vector of `P` \(P v = v x J\): grad S"):
        geomint.MetriplecticSystem.from_expressions(
            H="(x**2 + y**2 + z**2)/2", S="z**2/2", P=[["0", "0", "0"], ["0", "0", "1"], ["0", "-1", "0"]]
        )
