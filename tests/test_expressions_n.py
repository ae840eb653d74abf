"""Systems in R^n written as formulas: named variables, indexed families, rules; the catalogue reproduced, exact
gradients over indexed forms, compact generated code, the structure checks and their messages, the disk cache."""

import os
import pickle
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy
from hostile_strings import hostile

import geomint
from geomint.model import expressions_n, expressions_symbolic
from geomint.model.expressions_variables import Coordinates
from geomint.results import io
from geomint.systems.gas_containers import SAMPLES as GAS_SAMPLES

# N = 128 damped pendula sharing one entropy: the formulas are the lines between "dict(" and ")" (counted below)
PENDULA = dict(
    variables=("q[1..N]", "p[1..N]", "s"),
    sizes={"N": 128},
    params={"gamma": 0.5},
    E="sum(p[i]**2/2 + cos(q[i]), i) + s",
    S="s",
    L={"q[i], p[i]": "1", "p[i], q[i]": "-1"},
    M={"p[i], p[i]": "gamma", "p[i], s": "-gamma*p[i]", "s, p[i]": "-gamma*p[i]", "s, s": "gamma*sum(p[i]**2, i)"},
)

# the two gas containers (geomint.systems.gas_containers), T_i = dE/dS_i
GAS = dict(
    variables=("q", "p", "S1", "S2"),
    define={"T1": "2/3*(exp(S1)/q)**(2/3)", "T2": "2/3*(exp(S2)/(2 - q))**(2/3)"},
    E="p**2/2 + (exp(S1)/q)**(2/3) + (exp(S2)/(2 - q))**(2/3)",
    S="S1 + S2",
    L={"q, p": "1", "p, q": "-1"},
    M={"S1, S1": "gamma/T1**2", "S1, S2": "-gamma/(T1*T2)", "S2, S1": "-gamma/(T1*T2)", "S2, S2": "gamma/T2**2"},
    params={"gamma": 1.0},
    samples=GAS_SAMPLES,
)

# the oscillator with its heat bath (geomint.systems.heat_bath_oscillator), T = U'(s)
HEAT_BATH = dict(
    variables=("q", "p", "s"),
    define={"T": "T0*exp(s/c)"},
    E="p**2/(2*m) + k*q**2/2 + c*T",
    S="s",
    L={"q, p": "1", "p, q": "-1"},
    M={"p, p": "gamma*T", "p, s": "-gamma*p/m", "s, p": "-gamma*p/m", "s, s": "gamma*p**2/(m**2*T)"},
    params={"m": 1.3, "k": 0.7, "gamma": 0.4, "T0": 1.1, "c": 2.0},
)


def _pendula(N, **changes):
    return geomint.GenericSystem.from_expressions(**{**PENDULA, "sizes": {"N": N}, **changes})


def _source(system):
    """The generated module's text."""
    return Path(sys.modules[system.functions.H.py_func.__module__].__file__).read_text()


# -- the catalogue, written as formulas ------------------------------------------------------
def test_128_pendula_are_written_in_under_10_lines_of_formulas():
    text = Path(__file__).read_text()
    block = text.split("PENDULA = dict(\n", 1)[1].split("\n)\n", 1)[0]
    assert len(block.splitlines()) < 10


def test_128_pendula_from_an_indexed_family_equal_the_catalogue():
    formulas, reference = geomint.GenericSystem.from_expressions(**PENDULA), geomint.systems.damped_pendula(128)
    assert formulas.variables == reference.variables and formulas.dim == 257
    X = np.random.default_rng(7).uniform(-3.0, 3.0, size=(8, 257))
    for method in ("xi", "E", "S", "grad_E", "grad_S", "L", "M", "dS_dt"):
        np.testing.assert_allclose(getattr(formulas, method)(X), getattr(reference, method)(X), rtol=0, atol=1e-12)


def test_the_generated_code_is_loops_of_the_same_size_for_every_N():
    small, large = _source(_pendula(8)), _source(_pendula(128))
    assert len(small.splitlines()) == len(large.splitlines()) < 80
    assert "range(1, 129)" in large and "out[_" in large  # loops fill the nonzeros, no n^2 statements
    M = large.split("def M(", 1)[1]
    assert M.count("out[") == 4  # p,p / p,s / s,p in one loop, s,s once: the zero pattern of the rules


@pytest.mark.parametrize(
    "spec, reference", [(GAS, "gas_containers"), (HEAT_BATH, "heat_bath_oscillator")], ids=["gas", "heat_bath"]
)
def test_the_gas_containers_and_the_heat_bath_as_formulas_follow_the_catalogue_to_1e_12(spec, reference):
    formulas = geomint.GenericSystem.from_expressions(**spec)
    if reference == "gas_containers":
        catalogue, x0 = geomint.systems.gas_containers(), [0.6, 0.3, 0.1, -0.2]
    else:
        catalogue, x0 = geomint.systems.heat_bath_oscillator(**spec["params"]), [1.0, 0.5, 0.2]
    assert formulas.variables == catalogue.variables
    runs = [geomint.solve(system, x0, (0.0, 20.0), h=0.05) for system in (formulas, catalogue)]
    assert all(run.success and run.n_steps == 400 for run in runs)
    np.testing.assert_allclose(runs[0].x, runs[1].x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs[0].S, runs[1].S, rtol=0, atol=1e-12)
    assert np.ptp(runs[0].x[:, 0]) > 0.1  # it moves


def test_the_gas_containers_relax_to_their_limit_as_formulas():
    gas = geomint.GenericSystem.from_expressions(**GAS)
    x0 = np.array([0.6, 0.3, 0.1, -0.2])
    sol = geomint.solve(gas, x0, (0.0, 400.0), h=0.1)
    np.testing.assert_allclose(sol.x[-1], geomint.systems.gas_containers_limit(gas.E(x0)), atol=1e-7)


# -- the grammar --------------------------------------------------------------------------------
def test_variables_families_and_sizes_name_the_coordinates():
    c = Coordinates(("q[N]", "r[-1..1]", "p[1..2*N]", "s"), {"N": 2})
    assert c.names == ["q0", "q1", "rm1", "r0", "r1", "p1", "p2", "p3", "p4", "s"]
    assert c.families["p"].position(3) == 7 and c.scalars["s"].offset == 9


SMALL = dict(variables=("q[N]", "p[N]", "s"), sizes={"N": 5}, S="s**2/2", P={"q[i], p[i]": "1", "p[i], q[i]": "-1"})
ENERGIES = [
    "sum(cos(q[i+1] - q[i]), i, 0, N-2) + sum(p[i]**2, i)/2",  # a chain: offsets, explicit range
    "sum(sum((1 - delta(i, j))*cos(q[i] - q[j]), j), i) + sum(p[i]**2, i)",  # all pairs, nested
    "prod(1 + q[i]**2, i) + sqrt(1 + sum(p[i]**2, i))",  # a product, a sum inside a function
    "q[0]*q[N-1] + sum(i*q[i]**2, i) + exp(s)",  # single members, the index as a number
    "sum(p[i]*sum(q[j]**3, j), i) + sum(prod(q[i] + p[j], j), i) + s*sum(q[i], i)",
]


@pytest.mark.parametrize("H", ENERGIES)
def test_gradients_over_indexed_forms_are_the_exact_derivatives(H):
    system = geomint.MetriplecticSystemN.from_expressions(**SMALL, H=H, eps=0.1)
    # the reference: the formula written out (every sum unrolled) and differentiated coordinate by coordinate
    coords = Coordinates(SMALL["variables"], SMALL["sizes"])
    scope = expressions_symbolic.Scope(coords, [])
    unrolled = expressions_symbolic._unrolled(expressions_symbolic.parse("H", H, scope)).xreplace(coords.concrete())
    for x in np.random.default_rng(3).uniform(-1.0, 1.0, size=(3, coords.n)):
        at = dict(zip(coords.symbols, map(sympy.Float, x)))
        exact = [float(sympy.diff(unrolled, v).xreplace(at)) for v in coords.symbols]
        np.testing.assert_allclose(system.grad_H(x), exact, rtol=1e-13, atol=1e-13)
        assert system.H(x) == pytest.approx(float(unrolled.xreplace(at)), rel=1e-13, abs=1e-13)


def _matrix(entries, n=9):
    out = np.zeros((n, n))
    for (r, c), v in entries.items():
        out[r, c] = v
    return out


# N = 4: q at 0..3, p at 4..7, s at 8
METRICS = {
    "diagonal by delta": ({"p[i], p[j]": "delta(i, j)"}, _matrix({(4 + i, 4 + i): 1 for i in range(4)})),
    "dense": ({"q[i], q[j]": "1"}, _matrix({(i, j): 1 for i in range(4) for j in range(4)})),
    "chain": (
        {"q[i], q[i+1]": "1", "q[i+1], q[i]": "2"},
        _matrix({**{(i, i + 1): 1 for i in range(3)}, **{(i + 1, i): 2 for i in range(3)}}),
    ),
    "band by delta": (
        {"p[i], p[j]": "delta(i, j+1) + 2*delta(i+1, j)"},
        _matrix({**{(5 + i, 4 + i): 1 for i in range(3)}, **{(4 + i, 5 + i): 2 for i in range(3)}}),
    ),
    "one row by delta": ({"q[i], p[j]": "delta(i, 2)"}, _matrix({(2, 4 + j): 1 for j in range(4)})),
    "rules add up": (
        {"s, s": "1", "s, p[i]": "1", "p[3], s": "3", "p[i], s": "1"},
        _matrix({(8, 8): 1, **{(8, 4 + i): 1 for i in range(4)}, **{(4 + i, 8): 1 for i in range(3)}, (7, 8): 4}),
    ),
    "list of lists": ([["1" if r == c else "0" for c in range(9)] for r in range(9)], np.eye(9)),
}


@pytest.mark.parametrize("name", sorted(METRICS))
def test_matrices_given_by_rules_fill_their_entries(name):
    spec, expected = METRICS[name]
    system = geomint.MetriplecticSystemN.from_expressions(
        variables=("q[N]", "p[N]", "s"), sizes={"N": 4}, H="s", S="s", P={"s, s": "0"}, metric=spec, check=False
    )
    np.testing.assert_array_equal(system.D(np.zeros(9)), expected)


def test_a_fish_system_with_a_metric_is_the_generic_system_with_the_entropy_reversed():
    common = dict(variables=("q", "p", "s"), params={"gamma": 0.3})
    generic = geomint.GenericSystem.from_expressions(
        **common, E="(q**2 + p**2)/2 + s", S="s", L={"q, p": "1", "p, q": "-1"},
        M={"p, p": "gamma", "p, s": "-gamma*p", "s, p": "-gamma*p", "s, s": "gamma*p**2"},
    )  # fmt: skip
    fish = geomint.MetriplecticSystem.from_expressions(
        **common, H="(q**2 + p**2)/2 + s", S="-s", P={"q, p": "1", "p, q": "-1"},
        metric={"p, p": "-gamma", "p, s": "gamma*p", "s, p": "gamma*p", "s, s": "-gamma*p**2"},
    )  # fmt: skip
    assert isinstance(fish, geomint.MetriplecticSystemN) and fish.variables == ("q", "p", "s")
    X = np.random.default_rng(0).uniform(-1, 1, (5, 3))
    np.testing.assert_allclose(fish.xi(X), generic.xi(X), rtol=1e-15, atol=1e-15)


def test_variables_always_make_a_system_in_R_n_and_J_is_refused_there():
    three = geomint.MetriplecticSystem.from_expressions(
        variables=("a", "b", "c"),
        H="(a**2 + b**2 + c**2)/2",
        S="c**2/2",
        P=[["0", "1", "0"], ["-1", "0", "0"], ["0"] * 3],
    )
    assert type(three) is geomint.MetriplecticSystemN and three.dim == 3 and three.variables == ("a", "b", "c")
    with pytest.raises(TypeError, match="`J` .* with `variables` give `P`"):
        geomint.MetriplecticSystem.from_expressions(variables=("a", "b", "c"), H="a", S="b", J=("0", "0", "1"))
    with pytest.raises(TypeError, match="`sizes`: .* give `variables` too"):
        geomint.MetriplecticSystem.from_expressions(H="x", S="y", J=("0", "0", "1"), sizes={"N": 2})


def test_the_formulas_are_kept_for_saved_results_and_the_system_pickles(tmp_path):
    system = geomint.GenericSystem.from_expressions(**HEAT_BATH, name="bath")
    sol = geomint.solve(system, [1.0, 0.0, 0.0], (0.0, 1.0), h=0.1)
    meta = io.read_metadata(sol.save(tmp_path / "run", system))
    assert meta["system"]["expressions"]["M"] == HEAT_BATH["M"] and meta["system"]["variables"] == ["q", "p", "s"]
    assert meta["system"]["expressions"]["form"] == "GENERIC"
    again = pickle.loads(pickle.dumps(system))
    np.testing.assert_array_equal(again.xi([1.0, 0.5, 0.2]), system.xi([1.0, 0.5, 0.2]))


# -- the structure checks, and errors that name the key and the rule --------------------------
def _broken(**changes):
    return lambda: _pendula(4, **changes)


STRUCTURE_ERRORS = {
    "skew": (
        dict(L={"q[i], p[i]": "1", "p[i], q[i]": "1"}),
        r"^`L` is not skew: L\[q1, p1\] \+ L\[p1, q1\] = 2 \(rule 'q\[i\], p\[i\]'\)",
    ),
    "casimir": (
        dict(L={"q[i], p[i]": "1", "p[i], q[i]": "-1", "p[i], s": "q[i]", "s, p[i]": "-q[i]"}),
        r"^`L` does not annihilate grad S \(S must be a Casimir of it\): \(L grad S\)\[p1\] = q1 \(rule 'p\[i\], s'\)",
    ),
    "symmetric": (
        dict(M={**PENDULA["M"], "s, p[i]": "gamma*p[i]"}),
        r"^`M` is not symmetric: M\[p1, s\] - M\[s, p1\] = -2\*gamma\*p1 \(rule 'p\[i\], s'\)",
    ),
    "M grad E": (
        dict(M={**PENDULA["M"], "s, s": "gamma*sum(p[i]**2, i) + gamma"}),
        r"^`M` does not annihilate grad E \(E must be conserved\): \(M grad E\)\[s\] = gamma "
        r"\(rules 's, p\[i\]', 's, s'\)",
    ),
}


@pytest.mark.parametrize("case", sorted(STRUCTURE_ERRORS))
def test_a_structure_that_fails_names_the_field_the_entry_the_rule_and_the_residual(case):
    changes, message = STRUCTURE_ERRORS[case]
    with pytest.raises(ValueError, match=message) as info:
        _pendula(4, **changes)
    assert "\n" not in str(info.value)


GRAMMAR_ERRORS = {
    "typo in a variable": (dict(E="sum(p[i]**2/2 + cos(q[i]), i) + ss"), r"^`E`: unknown name \(variables: .*'ss'"),
    "typo in a family": (dict(E="sum(pp[i]**2, i) + s"), r"^`E`: unknown family `pp` \(families: q, p\)"),
    "a member by its label": (dict(E="q1 + s"), r"^`E`: unknown name .* a member of a family is written q\[1\]"),
    "a family without index": (dict(E="sum(p**2, i)"), r"^`E`: `p` is a family of 4 variables: index it, p\[i\]"),
    "undeclared index": (dict(E="p[i]**2 + s"), r"^`E`: index `i` is not declared: sum over it"),
    "undeclared index in a rule": (
        dict(M={"p[i], p[i]": "gamma*q[j]"}),
        r"^`M\['p\[i\], p\[i\]'\]`: index `j` is not declared",
    ),
    "a member out of range": (dict(E="q[5] + s"), r"^`E`: outside q's range 1\.\.4: 'q\[5\]'"),
    "an ambiguous range": (
        dict(E="sum(q[i+1]*q[i], i) + s"),
        r"^`E`: the range of `i` in sum\(\.\.\., i\) is ambiguous",
    ),
    "a range too wide": (dict(E="sum(q[i+1], i, 1, N)"), r"^`E`: q\[i \+ 1\] leaves q's range 1\.\.4 at i = 4"),
    "a sum over a parameter": (dict(E="sum(q[gamma], gamma)"), r"^`E`: `gamma` cannot be the index of sum"),
    "a matrix of the wrong size": (dict(L=[["0"] * 9] * 8), r"^`L` must be .* n x n = 9 x 9 .*; got 8 rows\.$"),
    "a row of the wrong size": (dict(L=[["0"] * 9] * 8 + [["0"] * 8]), r"^`L` row 8 \(s\) must hold n = 9 formulas"),
    "a key that is not a pair": (dict(L={"q[i] p[i]": "1"}), r"^`L\['q\[i\] p\[i\]'\]`: the key must be 'row, column'"),
    "a key naming no variable": (dict(L={"q[i], r": "1"}), r"^`L\['q\[i\], r'\]`: `r` is not a variable"),
    "a key without entries": (dict(L={"q[i], p[i+9]": "1"}), r"^`L\['q\[i\], p\[i\+9\]'\]`: the key has no entries"),
    "an unknown size": (dict(variables=("q[1..N]", "p[1..K]", "s")), r"^`variables 'p\[1\.\.K\]'`: 'K' is not"),
    "a name given twice": (dict(variables=("q[1..N]", "q1", "s")), r"^`variables`: the coordinate name 'q1' is given"),
    "a size that is no integer": (dict(sizes={"N": 2.5}), r"^`sizes.N` must be an integer"),
    "a parameter named as a variable": (dict(params={"s": 1.0}), r"^`params` name 's' is already a variable"),
    "a definition using an unknown name": (dict(define={"T": "2*r"}), r"^`define.T`: unknown name"),
    "an index times 2": (dict(E="sum(q[2*i], i)"), r"^`E`: an index is one index plus a constant"),
}


@pytest.mark.parametrize("case", sorted(GRAMMAR_ERRORS))
def test_typos_sizes_and_undeclared_indices_give_one_line_errors_naming_the_key(case):
    changes, message = GRAMMAR_ERRORS[case]
    with pytest.raises(ValueError, match=message) as info:
        _pendula(4, **changes)
    assert "\n" not in str(info.value)


def test_an_identity_that_holds_only_at_the_parameter_values_is_accepted_and_checked_again_at_others():
    spec = dict(variables=("q", "p", "s"), H="(q**2 + p**2)/2", S="s", P={"q, p": "1", "p, q": "-k"})
    assert geomint.MetriplecticSystem.from_expressions(**spec, params={"k": 1.0}).params.tolist() == [1.0]
    assert geomint.MetriplecticSystem.from_expressions(**spec, params={"k": 1.0}).expression_checks == "cached"
    with pytest.raises(ValueError, match=r"`P` is not skew: P\[q, p\] \+ P\[p, q\] = 1 - k"):
        geomint.MetriplecticSystem.from_expressions(**spec, params={"k": 2.0})


def test_beyond_the_symbolic_budget_the_constructors_numeric_checks_remain(monkeypatch):
    monkeypatch.setattr(expressions_symbolic, "MAX_CHECKED_TERMS", 0)
    monkeypatch.setattr(expressions_n, "_cached_module", lambda key, values: None)
    assert _pendula(4).expression_checks == "numeric"
    with pytest.raises(ValueError, match=r"^`L` must be skew-symmetric"):
        _pendula(4, L={"q[i], p[i]": "1", "p[i], q[i]": "1"})
    monkeypatch.undo()  # what the constructor refused is not in the cache: the symbolic check runs again
    with pytest.raises(ValueError, match=r"^`L` is not skew"):
        _pendula(4, L={"q[i], p[i]": "1", "p[i], q[i]": "1"})


def test_check_false_skips_the_symbolic_checks_too():
    system = _pendula(4, L={"q[i], p[i]": "1", "p[i], q[i]": "1"}, check=False)
    assert system.expression_checks in ("skipped", "cached")


FIELDS = ["E", "S", "L value", "L key", "M value", "define", "variables"]


def _hostile_spec(field, text):
    spec = {**PENDULA, "sizes": {"N": 2}}
    if field in ("E", "S"):
        spec[field] = text
    elif field == "L value":
        spec["L"] = {"q[i], p[i]": text, "p[i], q[i]": "-1"}
    elif field == "L key":
        spec["L"] = {text: "1"}
    elif field == "M value":
        spec["M"] = {**PENDULA["M"], "s, s": text}
    elif field == "define":
        spec["define"] = {"T": text}
    else:
        spec["variables"] = ("q[1..N]", "p[1..N]", text)
    return spec


@pytest.mark.parametrize("field", FIELDS)
def test_hostile_formulas_are_refused_in_every_field_and_nothing_runs(field, tmp_path):
    sentinel = tmp_path / "pwned"
    prefixes = {"L value": "`L[", "L key": "`L", "M value": "`M[", "define": "`define.T`", "variables": "`variables"}
    for text in hostile(sentinel):
        with pytest.raises(ValueError) as info:
            geomint.GenericSystem.from_expressions(**_hostile_spec(field, text))
        assert str(info.value).startswith(prefixes.get(field, f"`{field}`")), (text, str(info.value))
        assert "\n" not in str(info.value)
    assert not sentinel.exists()


def test_the_generated_source_is_checked_before_it_is_written():
    expressions_symbolic.check_generated("import math\ndef H(x, p):\n    return math.cos(x[0]) + p[0]\n")
    for bad in ("__import__('os')", "open('f')", "x.__class__", "numpy.load('f')", "(lambda: 1)()"):
        with pytest.raises(AssertionError):
            expressions_symbolic.check_generated(f"def H(x, p):\n    return {bad}\n")


# -- the disk cache ---------------------------------------------------------------------------------
SECOND_PROCESS = """
import sys, time
import geomint
N = {N}
t = time.perf_counter()
system = geomint.GenericSystem.from_expressions(
    variables=("q[1..N]", "p[1..N]", "s"), sizes={{"N": N}}, params={{"gamma": 0.5}},
    E="sum(p[i]**2/2 + cos(q[i]), i) + s", S="s", L={{"q[i], p[i]": "1", "p[i], q[i]": "-1"}},
    M={{"p[i], p[i]": "gamma", "p[i], s": "-gamma*p[i]", "s, p[i]": "-gamma*p[i]", "s, s": "gamma*sum(p[i]**2, i)"}})
seconds = time.perf_counter() - t
f = system.functions
stats = [fn.stats for fn in (f.H, f.grad_H, f.S, f.grad_S, f.P, f.M)]
hits = sum(sum(s.cache_hits.values()) for s in stats)
misses = sum(sum(s.cache_misses.values()) for s in stats)
print(system.expression_checks, "sympy" in sys.modules, hits, misses, seconds)
"""


def _two_processes(tmp_path, N):
    env = {**os.environ, "GEOMINT_CACHE_DIR": str(tmp_path)}
    runs = [
        subprocess.run(
            [sys.executable, "-c", SECOND_PROCESS.format(N=N)], capture_output=True, text=True, env=env, timeout=900
        )
        for _ in range(2)
    ]
    assert all(run.returncode == 0 for run in runs), runs[0].stderr[-2000:] + runs[1].stderr[-2000:]
    return [run.stdout.split() for run in runs]


def test_a_second_process_reuses_the_generated_code_without_sympy(tmp_path):
    first, second = _two_processes(tmp_path, 3)
    assert first[:4] == ["symbolic", "True", "0", "6"]
    assert second[:4] == ["cached", "False", "6", "0"]  # no sympy imported, machine code loaded
    assert len(list(tmp_path.glob("expressions/geomint_expr_*.py"))) == 1
    assert len(list(tmp_path.glob("expressions/geomint_exprn_*.json"))) == 1


@pytest.mark.slow
def test_128_pendula_compile_in_under_30_s_and_load_in_a_few_in_a_second_process(tmp_path):
    first, second = _two_processes(tmp_path, 128)
    print(f"N = 128: first process {float(first[4]):.2f} s, second {float(second[4]):.2f} s")
    assert first[0] == "symbolic" and float(first[4]) < 30.0
    assert second[:4] == ["cached", "False", "6", "0"] and float(second[4]) < 10.0  # ~1 s; more under load


def test_rules_in_another_order_or_other_parameter_values_share_the_generated_module():
    a = geomint.GenericSystem.from_expressions(**{**HEAT_BATH, "params": {**HEAT_BATH["params"], "gamma": 0.1}})
    b = geomint.GenericSystem.from_expressions(**HEAT_BATH)
    c = geomint.GenericSystem.from_expressions(**{**HEAT_BATH, "M": dict(reversed(HEAT_BATH["M"].items()))})
    assert a.functions.M is b.functions.M is c.functions.M  # one compilation serves every value of the parameters
    assert a.M([1.0, 1.0, 0.0])[1, 1] == pytest.approx(0.1 * 1.1) and b.M([1.0, 1.0, 0.0])[1, 1] == pytest.approx(0.44)


def test_the_cache_key_changes_with_the_formulas_and_the_sizes():
    coords = Coordinates(("q[N]", "s"), {"N": 3})
    keys = {
        expressions_n._key("GENERIC", coords, {"a": 1.0}, {"N": 3}, None, {"E": "s"}),
        expressions_n._key("GENERIC", coords, {"a": 1.0}, {"N": 4}, None, {"E": "s"}),
        expressions_n._key("GENERIC", coords, {"a": 1.0}, {"N": 3}, None, {"E": "s + 0"}),
        expressions_n._key("GENERIC", coords, {"b": 1.0}, {"N": 3}, None, {"E": "s"}),
    }
    assert len(keys) == 4
    assert re.fullmatch(r"[0-9a-f]{24}", keys.pop())
