"""Systems in R^n: the model (Fish and GENERIC forms), its checks, and the R^n catalogue."""

import functools
import pickle

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba.core.types.function_type import CompileResultWAP

import geomint
from geomint._kernels import layout
from geomint.model import GenericSystem, MetriplecticSystemN
from geomint.model.functions import no_metric
from geomint.systems import (
    RN_CATALOGUE,
    damped_pendula,
    euler_coefficients,
    euler_galerkin,
    euler_initial_state,
    euler_modes,
    euler_vorticity,
    euler_zeitlin,
    gas_containers,
    gas_containers_limit,
    heat_bath_closed_form,
    heat_bath_oscillator,
    random_fish,
)

EPS = np.finfo(float).eps


# -- a small Fish system in R^4: a rotation in (x0, x1), S = x3^2 / 2 -----------------------
@numba.njit
def _H(x, p):
    return 0.5 * np.sum(x * x)


@numba.njit
def _grad_H(x, p):
    return x.copy()


@numba.njit
def _S(x, p):
    return 0.5 * x[3] * x[3]


@numba.njit
def _grad_S(x, p):
    return np.array([0.0, 0.0, 0.0, x[3]])


@numba.njit
def _P(x, p):
    out = np.zeros((4, 4))
    out[0, 1], out[1, 0] = 1.0, -1.0
    return out


@numba.njit
def _metric(x, p):
    """The paper's g, written by the user."""
    return np.outer(x, x) - np.sum(x * x) * np.eye(4)


@numba.njit
def _wrong_sign_metric(x, p):
    return np.sum(x * x) * np.eye(4) - np.outer(x, x)


@numba.njit
def _asymmetric_metric(x, p):
    out = np.outer(x, x) - np.sum(x * x) * np.eye(4)
    out[0, 1] += 0.5
    return out


@numba.njit
def _minus_identity(x, p):
    return -np.eye(4)


@numba.njit
def _wrong_grad_S(x, p):
    return np.array([0.0, 0.0, 0.0, 2.0 * x[3]])


@numba.njit
def _tuple_grad_H(x, p):
    return (x[0], x[1], x[2], x[3])


@numba.njit
def _int_H(x, p):
    return 1


@numba.njit
def _vector_P(x, p):
    return x.copy()


@numba.njit
def _short_grad_H(x, p):
    return x[:3].copy()


@numba.njit
def _three_by_three_P(x, p):
    return np.zeros((3, 3))


@numba.njit
def _symmetric_P(x, p):
    out = np.zeros((4, 4))
    out[0, 1], out[1, 0] = 1.0, 1.0
    return out


@numba.njit
def _P_moving_S(x, p):
    out = np.zeros((4, 4))
    out[0, 3], out[3, 0] = 1.0, -1.0
    return out


@numba.njit
def _raising_S(x, p):
    if x[0] > -2.0:
        raise ValueError("no S here")
    return 0.0


@numba.njit
def _log_H(x, p):
    return np.log(x[0]) + 0.5 * np.sum(x * x)


@numba.njit
def _log_grad_H(x, p):
    out = x.copy()
    out[0] += 1.0 / x[0]
    return out


def _fish(**overrides):
    arguments = dict(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, P=_P, dim=4)
    arguments.update(overrides)
    return geomint.MetriplecticSystem(**arguments)


# -- a small GENERIC system: the heat-bath oscillator's functions, with broken L and M ------------
@numba.njit
def _E(x, p):
    return 0.5 * x[1] * x[1] + 0.5 * x[0] * x[0] + np.exp(x[2])


@numba.njit
def _grad_E(x, p):
    return np.array([x[0], x[1], np.exp(x[2])])


@numba.njit
def _bad_grad_E(x, p):
    return np.array([x[0], x[1], 1.0])


@numba.njit
def _entropy(x, p):
    return x[2]


@numba.njit
def _grad_entropy(x, p):
    return np.array([0.0, 0.0, 1.0])


@numba.njit
def _L(x, p):
    return np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


@numba.njit
def _L_symmetric(x, p):
    return np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


@numba.njit
def _L_moving_S(x, p):
    return np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])


@numba.njit
def _M(x, p):
    T = np.exp(x[2])
    w = np.array([0.0, 1.0, -x[1] / T])
    return T * np.outer(w, w)


@numba.njit
def _M_negative(x, p):
    T = np.exp(x[2])
    w = np.array([0.0, 1.0, -x[1] / T])
    return -T * np.outer(w, w)


@numba.njit
def _M_not_annihilating(x, p):
    return np.eye(3)


@numba.njit
def _M_asymmetric(x, p):
    T = np.exp(x[2])
    w = np.array([0.0, 1.0, -x[1] / T])
    out = T * np.outer(w, w)
    out[0, 1] = 1.0
    return out


def _generic(**overrides):
    arguments = dict(E=_E, grad_E=_grad_E, S=_entropy, grad_S=_grad_entropy, L=_L, M=_M, dim=3)
    arguments.update(overrides)
    return GenericSystem(**arguments)


# -- construction -------------------------------------------------------------------------------
def test_dim_other_than_three_makes_a_system_in_R_n():
    system = _fish()
    assert type(system) is MetriplecticSystemN and isinstance(system, geomint.MetriplecticSystem)
    assert system.dim == 4 and system.direction == -1.0 and system.hamiltonian and system.eps == 1.0
    three = geomint.systems.relaxing_rigid_body()
    assert type(three) is geomint.MetriplecticSystem


def test_dim_three_or_absent_keeps_the_R3_class():
    functions = geomint.systems.relaxing_rigid_body().functions
    arguments = dict(H=functions.H, grad_H=functions.grad_H, S=functions.S, grad_S=functions.grad_S)
    for dim in (None, 3):
        system = geomint.MetriplecticSystem(**arguments, J=functions.poisson, params=[0.5, 1.0, 1.5], dim=dim)
        assert type(system) is geomint.MetriplecticSystem
        assert system.J([1.0, 2.0, 3.0]).tolist() == [1.0, 2.0, 3.0]


def test_the_R_n_form_in_three_dimensions_agrees_with_the_R3_class():
    """The paper's metric written for any n gives the double cross product in R^3."""

    @numba.njit
    def grad_H(x, p):
        return np.array([0.5 * x[0], x[1], 1.5 * x[2]])

    @numba.njit
    def H(x, p):
        return 0.5 * (0.5 * x[0] ** 2 + x[1] ** 2 + 1.5 * x[2] ** 2)

    @numba.njit
    def grad_S(x, p):
        return x.copy()

    @numba.njit
    def P(x, p):  # P v = v x m
        return np.array([[0.0, x[2], -x[1]], [-x[2], 0.0, x[0]], [x[1], -x[0], 0.0]])

    rn = MetriplecticSystemN(H=H, grad_H=grad_H, S=_H, grad_S=grad_S, P=P, dim=3, eps=0.7)
    r3 = geomint.systems.relaxing_rigid_body(eps=0.7)
    X = np.random.default_rng(3).normal(size=(5, 3))
    np.testing.assert_allclose(rn.xi(X), r3.xi(X), rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(rn.dS_dt(X), r3.dS_dt(X), rtol=1e-13)
    np.testing.assert_allclose(rn.g(X), r3.g(X), rtol=1e-15)


@pytest.mark.parametrize(
    "overrides, error, match",
    [
        ({"dim": 2.5}, TypeError, r"`dim` must be an integer >= 2 \(the dimension n of the state\); got 2.5"),
        ({"dim": True}, TypeError, r"`dim` must be an integer >= 2"),
        ({"dim": 1}, ValueError, r"`dim` must be an integer >= 2 .*; got 1"),
        ({"J": _grad_H}, TypeError, r"`J` \(an axial vector\) describes a Poisson tensor in R\^3 only"),
        ({"exact_flows": {"rotor_splitting": ()}}, TypeError, r"`exact_flows` are declared for systems in R\^3"),
        ({"P": None}, TypeError, r"give `P`"),
        ({"H": lambda x, p: 0.0}, TypeError, r"(?s)`H` must be a numba-jitted function.*def H\(x, params\)"),
        ({"H": _int_H}, TypeError, r"`H` must return a float64; it returns"),
        ({"grad_H": _tuple_grad_H}, TypeError, r"`grad_H` must return a contiguous float64 array of length n = 4"),
        ({"P": _vector_P}, TypeError, r"`P` must return an \(n, n\) = \(4, 4\) contiguous float64 array"),
        ({"grad_H": _short_grad_H}, ValueError, r"`grad_H` must return shape \(4,\); at x = .* shape \(3,\)"),
        ({"P": _three_by_three_P}, ValueError, r"`P` must return shape \(4, 4\); at x = .* shape \(3, 3\)"),
        ({"grad_S": _wrong_grad_S}, ValueError, r"`grad_S` must match finite differences of S; at x = \["),
        ({"P": _symmetric_P}, ValueError, r"`P` must be skew-symmetric \(P = -P\^T\); at x = .* entry \[0, 1\]"),
        ({"P": _P_moving_S}, ValueError, r"`P` must satisfy P grad S = 0 \(S must be a Casimir of it\); at x ="),
        ({"metric": _asymmetric_metric}, ValueError, r"`metric` must be symmetric; at x = .* entry \[[01], [01]\]"),
        (
            {"metric": _wrong_sign_metric},
            ValueError,
            r"`metric` must be negative semidefinite \(a metric of the wrong sign: S would rise\); .* eigenvalue",
        ),
        ({"metric": _minus_identity}, ValueError, r"`metric` must satisfy G grad H = 0 \(H must be conserved\)"),
        ({"eps": -1.0}, ValueError, r"`eps` must be finite and >= 0"),
        ({"params": [np.nan]}, ValueError, r"`params` must be finite"),
        ({"samples": np.zeros((2, 3))}, ValueError, r"`samples` must have shape \(k, n\) .* n = dim = 4; got shape"),
        ({"samples": [[np.inf, 0, 0, 0]]}, ValueError, r"`samples` must be finite"),
        ({"S": _raising_S}, geomint.UserFunctionError, r"the user function `S` raised .* give `samples=`"),
    ],
)
def test_construction_errors_name_the_argument(overrides, error, match):
    with pytest.raises(error, match=match):
        _fish(**overrides)


def test_a_users_metric_is_accepted_and_used():
    system = _fish(metric=_metric, eps=0.3)
    paper = _fish(eps=0.3)
    assert system.metric == layout.USER_METRIC and paper.metric == layout.PAPER_METRIC
    X = np.random.default_rng(4).normal(size=(3, 4))
    np.testing.assert_allclose(system.xi(X), paper.xi(X), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(system.D(X), system.g(X), rtol=1e-15, atol=1e-15)


def test_metric_and_samples_need_dim():
    with pytest.raises(TypeError, match=r"`metric` is an argument of the systems in R\^n: pass `dim`"):
        geomint.MetriplecticSystem(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, P=_P, metric=_metric)
    with pytest.raises(TypeError, match=r"`dim` \(the dimension n >= 2 of the state\) is required"):
        MetriplecticSystemN(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, P=_P)


def test_functions_undefined_at_every_sample_ask_for_samples():
    with pytest.raises(ValueError, match=r"`samples`: the functions are not finite at any of the 6 sample points"):
        _fish(H=_log_H, grad_H=_log_grad_H, samples=np.full((6, 4), -0.5))
    system = _fish(H=_log_H, grad_H=_log_grad_H, samples=np.full((1, 4), 0.5))
    assert system.H([1.0, 0.0, 0.0, 0.0]) == 0.5
    _fish(grad_S=_wrong_grad_S, check=False)  # the checks can be switched off


@pytest.mark.parametrize(
    "overrides, error, match",
    [
        ({"grad_E": _bad_grad_E}, ValueError, r"`grad_E` must match finite differences of E"),
        ({"L": _L_symmetric}, ValueError, r"`L` must be skew-symmetric"),
        ({"L": _L_moving_S}, ValueError, r"`L` must satisfy L grad S = 0"),
        ({"M": _M_asymmetric}, ValueError, r"`M` must be symmetric"),
        (
            {"M": _M_negative},
            ValueError,
            r"`M` must be positive semidefinite \(a metric of the wrong sign: the entropy would fall\)",
        ),
        ({"M": _M_not_annihilating}, ValueError, r"`M` must satisfy M grad E = 0 \(E must be conserved\)"),
        ({"E": _int_H}, TypeError, r"(?s)`E` must return a float64.*def E\(x, params\)"),
        ({"M": _vector_P}, TypeError, r"`M` must return an \(n, n\) = \(3, 3\)"),
        ({"dim": 4}, ValueError, r"`grad_E` must return shape \(4,\)"),
    ],
)
def test_generic_construction_errors_name_the_generic_argument(overrides, error, match):
    with pytest.raises(error, match=match):
        _generic(**overrides)


def test_a_state_of_the_wrong_length_is_refused_with_the_rule_and_shape():
    system = _fish()
    for method in ("H", "grad_S", "P", "xi", "dS_dt"):
        with pytest.raises(
            ValueError, match=r"`x` must have shape \(4,\) .* or \(m, 4\) \(m states\); got shape \(3,\)"
        ):
            getattr(system, method)([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"got shape \(2, 2, 4\)"):
        system.xi(np.zeros((2, 2, 4)))
    with pytest.raises(TypeError, match=r"`x` must be a state of n = 4 real numbers"):
        system.H(["a", "b", "c", "d"])


def test_what_only_R3_has_is_refused_clearly():
    system = _fish()
    with pytest.raises(TypeError, match=r"`J` is the axial vector of a Poisson tensor in R\^3; .* use `P\(x\)`"):
        system.J(np.zeros(4))
    with pytest.raises(TypeError, match=r"`sigma` .* R\^3 only"):
        system.sigma(np.zeros(4))
    with pytest.raises(TypeError, match="variables"):  # formulas in R^n name their variables (test_expressions_n)
        MetriplecticSystemN.from_expressions(H="x", S="x")


def test_a_raising_function_is_named_at_evaluation():
    system = _fish(S=_raising_S, check=False)
    with pytest.raises(geomint.UserFunctionError, match=r"the user function `S` raised"):
        system.S(np.zeros(4))
    assert system.raising_function(np.zeros(4))[0] == "S"
    assert _fish().raising_function(np.zeros(4)) is None


# -- the model the kernels receive -------------------------------------------------------------------
@pytest.mark.inlined
def test_the_model_is_a_ModelN_of_first_class_functions_and_the_loops_of_inlined_ones(monkeypatch):
    """The step loop of an R^n system takes its functions first-class by default, inlined under
    ``GEOMINT_INLINE=all`` (``model.handles.enabled``)."""
    for system in (_fish(), _generic()):
        inlined = system.inlined_model
        assert all(isinstance(fn, CompileResultWAP) for fn in (inlined.H, inlined.grad_H, inlined.S, inlined.grad_S))
    monkeypatch.setenv("GEOMINT_INLINE", "all")
    paper, generic = _fish(), _generic()
    for system, metric, direction in ((paper, layout.PAPER_METRIC, -1.0), (generic, layout.USER_METRIC, 1.0)):
        model = system.model
        assert isinstance(model, layout.ModelN) and model is system.model  # cached
        assert model.metric == metric and model.direction == direction
        assert numba.typeof(model.P) == numba.typeof(model.M)
        assert numba.typeof(model.grad_H) == numba.typeof(model.grad_S)
        inlined, f = system.inlined_model, system.functions
        assert isinstance(inlined, layout.ModelN) and inlined is system.inlined_model
        for handle, fn in ((inlined.H, f.H), (inlined.grad_H, f.grad_H), (inlined.S, f.S), (inlined.grad_S, f.grad_S)):
            assert handle.dispatcher is fn  # module-level functions: inlined into the step loop (model.handles)
    np.testing.assert_array_equal(paper.model.origin, [0.0, 0.0])
    np.testing.assert_array_equal(generic.model.origin, [1.0, 0.0])  # E(0) = e^0
    np.testing.assert_array_equal(no_metric(np.zeros(5), np.zeros(0)), np.zeros((5, 5)))
    np.testing.assert_array_equal(_fish(H=_log_H, grad_H=_log_grad_H, check=False).model.origin, [0.0, 0.0])


def test_with_effects_keeps_the_class_and_rechecks_params():
    system = heat_bath_oscillator(gamma=0.5)
    x = np.array([0.3, -0.4, 0.2])
    off = system.with_effects(hamiltonian=False)
    assert type(off) is GenericSystem and not off.hamiltonian and system.hamiltonian
    np.testing.assert_array_equal(off.xi(x), system.xi_g(x))
    np.testing.assert_array_equal(system.with_effects(eps=0.0).xi(x), system.xi_P(x) + 0.0)
    stiffer = system.with_effects(params=[1.0, 4.0, 0.5, 1.0, 1.0])
    assert stiffer.grad_E(x)[0] == 4.0 * 0.3 and system.grad_E(x)[0] == 0.3
    assert "_model" not in stiffer.__dict__ or stiffer.model.params[1] == 4.0
    with pytest.raises(ValueError, match=r"`params` must have 5 values"):
        system.with_effects(params=[1.0])
    with pytest.raises(ValueError, match=r"`m` must be finite and > 0"):
        heat_bath_oscillator(m=0.0)
    with pytest.raises(TypeError, match=r"`hamiltonian` must be True or False"):
        system.with_effects(hamiltonian="no")


@pytest.mark.parametrize("name", sorted(RN_CATALOGUE))
def test_pickling_round_trip(name):
    system = RN_CATALOGUE[name]()
    assert system.model is not None  # compiled: not pickled
    other = pickle.loads(pickle.dumps(system))
    assert type(other) is type(system) and repr(other) == repr(system) and "_model" not in other.__dict__
    X = system._samples
    np.testing.assert_array_equal(other.xi(X), system.xi(X))
    assert other.model.metric == system.model.metric


def test_repr_names_the_system_and_digests_long_params():
    assert repr(_fish(eps=0.5)) == "MetriplecticSystemN(name='custom', dim=4, eps=0.5, params=[])"
    assert "metric=user" in repr(_fish(metric=_metric))
    assert repr(heat_bath_oscillator()).startswith("GenericSystem(name='heat_bath_oscillator', dim=3")
    long = repr(random_fish(5))
    assert "params=<" in long and "sha256" in long and long != repr(random_fish(5, seed=1))


def test_evaluation_over_many_states_is_row_by_row():
    system = damped_pendula(3, gamma=0.7)
    X = np.random.default_rng(5).normal(size=(4, 7))
    for method in ("E", "S", "grad_E", "grad_S", "L", "M", "xi", "xi_P", "xi_g", "dS_dt", "dE_dt"):
        many = getattr(system, method)(X)
        np.testing.assert_array_equal(many, np.array([getattr(system, method)(x) for x in X]))
    assert isinstance(system.H(X[0]), float) and system.P(X).shape == (4, 7, 7)


# -- the catalogue -------------------------------------------------------------------------------------
@functools.cache
def _catalogue():
    """Built once: every entry of RN_CATALOGUE and some other sizes, each through its own structure checks."""
    systems = [make() for make in RN_CATALOGUE.values()]
    systems += [random_fish(2), random_fish(3, seed=2, eps=0.2), random_fish(40)]  # 40 > 32: random directions
    systems += [euler_zeitlin(3), euler_zeitlin(7, eps=0.1), euler_galerkin(3), euler_galerkin(7)]
    systems += [damped_pendula(1), damped_pendula(6, gamma=2.0), gas_containers(gamma=0.3)]
    systems += [heat_bath_oscillator(m=2.0, k=0.5, gamma=2.0, T0=0.5, c=3.0)]
    return systems


def _low(system):
    """The box states are drawn from: the gas containers need 0 < q < 2."""
    low, high = np.full(system.dim, -2.0), np.full(system.dim, 2.0)
    if system.name == "gas_containers":
        low[0], high[0] = 0.05, 1.95
    return low, high


@st.composite
def systems_and_states(draw):
    systems = _catalogue()
    system = systems[draw(st.integers(0, len(systems) - 1))]
    low, high = _low(system)
    unit = draw(st.lists(st.floats(0.0, 1.0), min_size=system.dim, max_size=system.dim))
    return system, low + (high - low) * np.array(unit)


def test_the_catalogue_passes_its_own_checks():
    systems = _catalogue()
    assert len(systems) == len(RN_CATALOGUE) + 11
    for system in systems:
        system._check(True)  # again, explicitly
        assert isinstance(system, geomint.MetriplecticSystem)


@given(case=systems_and_states())
def test_P_is_skew_and_S_its_Casimir_to_round_off(case):
    system, x = case
    P, gs = system.P(x), system.grad_S(x)
    np.testing.assert_array_equal(P, -P.T)  # every catalogue P is skew in floating point
    size = np.abs(P) @ np.abs(gs)
    if system.name.startswith("random_fish"):  # the projection leaves round-off of the matrix it projects
        size = size + np.abs(_unprojected(system, x)).max() * np.linalg.norm(gs) * system.dim
    assert np.all(np.abs(P @ gs) <= 4 * system.dim * EPS * size + 1e-300)


def _unprojected(system, x):
    """``A + sum_k x_k B_k`` of a random Fish system."""
    n, params = system.dim, system.params
    A = params[2 + n : 2 + n + n * n].reshape(n, n)
    return A + np.tensordot(x, params[2 + n + n * n :].reshape(n, n, n), axes=1)


@given(case=systems_and_states())
def test_the_metric_is_symmetric_semidefinite_and_annihilates_grad_H(case):
    system, x = case
    D, gh = system.D(x), system.grad_H(x)
    np.testing.assert_array_equal(D, D.T)
    size = np.abs(D) @ np.abs(gh)
    if system.metric == layout.PAPER_METRIC:  # g's diagonal is a difference of terms of size |grad H|^2
        size = size + (gh @ gh) * np.abs(gh).sum()
    assert np.all(np.abs(D @ gh) <= 4 * system.dim * EPS * size + 1e-300)
    eigenvalues = np.linalg.eigvalsh(D) * system.direction
    assert eigenvalues.min() >= -64 * system.dim * EPS * np.abs(eigenvalues).max()


@given(case=systems_and_states())
def test_dS_dt_has_the_sign_of_the_form(case):
    """<= 0 in the Fish form (exactly, for the paper's metric), >= 0 in GENERIC (to round-off)."""
    system, x = case
    rate, gs = system.dS_dt(x), system.grad_S(x)
    if system.direction < 0:
        assert rate <= 0.0
    else:
        assert rate >= -8 * EPS * (np.abs(gs) @ np.abs(system.M(x)) @ np.abs(gs))
    assert rate == pytest.approx(gs @ system.xi(x), rel=1e-9, abs=1e-9 * np.abs(gs) @ np.abs(system.xi(x)))
    assert abs(system.dH_dt(x)) <= 1e-12 * (1.0 + np.abs(system.grad_H(x)) @ np.abs(system.xi(x)))


def test_catalogue_arguments_are_checked():
    with pytest.raises(ValueError, match=r"`n` must be an integer in \[2, 256\]"):
        random_fish(1)
    with pytest.raises(ValueError, match=r"`seed` must be an integer >= 0"):
        random_fish(4, seed=-1)
    with pytest.raises(ValueError, match=r"`N` must be an odd integer >= 3"):
        euler_zeitlin(4)
    with pytest.raises(ValueError, match=r"`N` must be at least 5"):
        euler_initial_state(3)
    with pytest.raises(ValueError, match=r"`N` must be an integer >= 1"):
        damped_pendula(0)
    with pytest.raises(ValueError, match=r"`gamma` must be finite and >= 0"):
        gas_containers(gamma=-1.0)
    with pytest.raises(TypeError, match=r"`gamma` must be a real number"):
        damped_pendula(2, gamma="strong")


# -- random Fish systems ---------------------------------------------------------------------------------
def test_random_fish_is_drawn_from_its_seed():
    assert np.array_equal(random_fish(5, seed=3).params, random_fish(5, seed=3).params)
    assert not np.array_equal(random_fish(5, seed=3).params, random_fish(5, seed=4).params)
    system = random_fish(5)
    D = system.params[2:7]
    assert np.all((0.5 <= D) & (D <= 2.0))
    x = np.array([0.3, -0.2, 0.5, 0.1, -0.7])
    assert system.H(x) == pytest.approx(0.5 * np.sum(D * x * x) + 0.2 * np.sum(np.cos(x)), rel=1e-15)
    assert system.S(x) == pytest.approx(0.5 * x @ x + 0.075 * np.sum(x**4), rel=1e-15)
    P0 = system.P(np.zeros(5))  # Pi_S = I at grad S = 0: P(0) = A
    np.testing.assert_allclose(P0, system.params[7:32].reshape(5, 5), rtol=0, atol=1e-15)


def test_random_fish_P_depends_on_x_and_projects():
    """P = Pi (A + sum_k x_k B_k) Pi against the formula written with numpy."""
    n = 6
    system = random_fish(n, seed=7)
    x = np.random.default_rng(8).normal(size=n)
    s = system.grad_S(x) / np.linalg.norm(system.grad_S(x))
    Pi = np.eye(n) - np.outer(s, s)
    np.testing.assert_allclose(system.P(x), Pi @ _unprojected(system, x) @ Pi, rtol=0, atol=1e-14)
    assert np.abs(system.P(x) - system.P(2 * x)).max() > 0.1


# -- 2-D Euler --------------------------------------------------------------------------------------------
def _direct_field(x, N, galerkin):
    """``d omega_k / dt = sum_{p + q = k} c(p, q) psi_p omega_q`` over all modes, written directly."""
    F = euler_coefficients(x, N)
    M = (N - 1) // 2
    box = range(-M, M + 1)
    out = np.zeros((N, N), dtype=complex)
    for k1 in box:
        for k2 in box:
            for p1 in box:
                for p2 in box:
                    q1, q2 = k1 - p1, k2 - p2
                    if (p1, p2) == (0, 0) or (q1 % N, q2 % N) == (0, 0):
                        continue
                    if galerkin and (abs(q1) > M or abs(q2) > M):
                        continue
                    cross = p1 * q2 - p2 * q1
                    c = cross if galerkin else N / (2 * np.pi) * np.sin(2 * np.pi * cross / N)
                    out[k1 % N, k2 % N] += c * F[p1 % N, p2 % N] / (p1 * p1 + p2 * p2) * F[q1 % N, q2 % N]
    values = np.array([out[k1 % N, k2 % N] for k1, k2 in euler_modes(N)])
    return np.stack([values.real, values.imag], axis=1).reshape(-1)


@settings(max_examples=10)
@given(seed=st.integers(0, 2**32 - 1), N=st.sampled_from([3, 5]), galerkin=st.booleans())
def test_euler_P_grad_H_is_the_convolution(seed, N, galerkin):
    system = (euler_galerkin if galerkin else euler_zeitlin)(N)
    x = np.random.default_rng(seed).normal(size=N * N - 1)
    direct = _direct_field(x, N, galerkin)
    np.testing.assert_allclose(system.xi_P(x), direct, rtol=0, atol=64 * EPS * (1.0 + np.abs(direct).max()) * N * N)


@pytest.mark.parametrize("N", [3, 5])
def test_zeitlins_P_satisfies_Jacobi_and_galerkins_does_not(N):
    """P is linear in x, so its derivative along e_l is P(e_l); the cyclic sum of ``P_li d_l P_jk``."""
    n = N * N - 1
    x = np.random.default_rng(N).normal(size=n)
    residuals = []
    for system in (euler_zeitlin(N), euler_galerkin(N)):
        P, dP = system.P(x), system.P(np.eye(n))
        J = np.einsum("li,ljk->ijk", P, dP)
        cyclic = J + np.einsum("ijk->jki", J) + np.einsum("ijk->kij", J)
        residuals.append(np.abs(cyclic).max() / np.abs(J).max())
    assert residuals[0] < 1e-14 and residuals[1] > 0.1


def test_the_two_truncations_differ_and_agree_where_they_should():
    x = np.random.default_rng(9).normal(size=24)
    zeitlin, galerkin = euler_zeitlin(5), euler_galerkin(5)
    assert np.abs(zeitlin.P(x) - galerkin.P(x)).max() > 0.1
    np.testing.assert_array_equal(zeitlin.H(x), galerkin.H(x))
    np.testing.assert_array_equal(zeitlin.xi_g(x), galerkin.xi_g(x))


@pytest.mark.parametrize("N", [5, 7, 9])
@pytest.mark.parametrize("make", [euler_zeitlin, euler_galerkin])
def test_euler_data_give_the_reference_H0_and_S0(make, N):
    system, x0 = make(N), euler_initial_state(N)
    assert system.dim == N * N - 1 == x0.size
    assert system.H(x0) == 1.1375 and system.S(x0) == 1.3125
    F = euler_coefficients(x0, N)
    assert F[1, 0] == 1.0 and F[1, 1] == 0.5 and F[2, 1] == 0.25j and F[-2, -1] == -0.25j
    assert system.dS_dt(x0) < 0.0


def test_the_dissipative_part_is_the_shell_formula():
    """``g grad S = 8 (H / |k|^2 - K) omega_k``, ``K = sum_half |omega_k|^2 / |k|^4``: the rate 8 eps H_0 of the
    docstring (the shell |k|^2 = 2 near the end)."""
    system = euler_galerkin(7)
    x = np.random.default_rng(10).normal(size=48)
    shells = np.repeat(np.sum(euler_modes(7) ** 2, axis=1), 2)
    K = np.sum(x * x / shells**2)
    np.testing.assert_allclose(system.xi_g(x), 8 * (system.H(x) / shells - K) * x, rtol=1e-12, atol=1e-12)


def test_the_lowest_shell_is_where_S_equals_H_and_dissipation_stops():
    system = euler_zeitlin(5)
    x = np.zeros(24)
    for i, (k1, k2) in enumerate(euler_modes(5)):
        if k1 * k1 + k2 * k2 == 1:
            x[2 * i], x[2 * i + 1] = 0.3 * (i + 1), -0.2
    assert system.S(x) == pytest.approx(system.H(x), rel=1e-15)
    np.testing.assert_allclose(system.xi_g(x), 0.0, atol=1e-15)


def test_euler_vorticity_is_the_trigonometric_sum():
    x0 = euler_initial_state(5)
    theta = 2 * np.pi * np.arange(16) / 16
    t1, t2 = np.meshgrid(theta, theta, indexing="ij")
    exact = 2 * np.cos(t1) + np.cos(t1 + t2) - 0.5 * np.sin(2 * t1 + t2)
    np.testing.assert_allclose(euler_vorticity(x0, 5, size=16), exact, atol=1e-14)
    assert euler_vorticity(x0, 5).shape == (5, 5)
    with pytest.raises(ValueError, match=r"`size` must be an integer >= N = 5"):
        euler_vorticity(x0, 5, size=3)
    with pytest.raises(ValueError, match=r"`x` must have shape \(24,\)"):
        euler_coefficients(np.zeros(5), 5)


# -- GENERIC systems against their hand formulas --------------------------------------------------------------
@given(case=systems_and_states())
def test_xi_of_the_generic_systems_is_the_hand_formula(case):
    system, x = case
    if system.name.startswith("damped_pendula"):
        N, gamma = (system.dim - 1) // 2, system.params[0]
        q, p = x[:N], x[N : 2 * N]
        hand = np.concatenate([p, np.sin(q) - gamma * p, [gamma * p @ p]])
    elif system.name == "gas_containers":
        q, p, S1, S2 = x
        gamma = system.params[0]
        T1, T2 = (2 / 3) * (np.exp(S1) / q) ** (2 / 3), (2 / 3) * (np.exp(S2) / (2 - q)) ** (2 / 3)
        flow = gamma * (1 / T1 - 1 / T2)
        hand = np.array([p, T1 / q - T2 / (2 - q), flow / T1, -flow / T2])
    elif system.name == "heat_bath_oscillator":
        m, k, gamma, T0, c = system.params
        q, p, s = x
        T = T0 * np.exp(s / c)
        hand = np.array([p / m, -k * q - gamma * p / m, gamma * p * p / (m * m * T)])
    else:
        return
    np.testing.assert_allclose(system.xi(x), hand, rtol=1e-12, atol=1e-12 * (1 + np.abs(hand).max()))


def test_pendula_and_gas_come_to_rest_where_the_reference_says():
    pendula = damped_pendula(3)
    x0 = np.array([0.1, 2.0, -1.0, 0.5, 0.0, -0.3, 0.2])
    rest = np.concatenate([np.full(3, np.pi), np.zeros(3), [pendula.E(x0) + 3]])
    assert pendula.E(rest) == pytest.approx(pendula.E(x0), rel=1e-15)  # S_inf = E_0 + N
    np.testing.assert_allclose(pendula.xi(rest), 0.0, atol=1e-15)
    gas = gas_containers()
    E0 = gas.E([0.7, 0.3, 0.2, -0.4])
    limit = gas_containers_limit(E0)
    assert limit[2] + limit[3] == pytest.approx(3 * np.log(E0 / 2), rel=1e-15)
    assert gas.E(limit) == pytest.approx(E0, rel=1e-14)
    np.testing.assert_allclose(gas.xi(limit), 0.0, atol=1e-14)  # equal temperatures and pressures
    T = gas.grad_E(limit)
    assert T[2] == pytest.approx(T[3], rel=1e-15) and T[0] == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("gamma", [0.5, 2.0, 3.0])  # under-, critically and overdamped for m = k = 1
def test_heat_bath_closed_form_solves_the_systems_equations(gamma):
    system = heat_bath_oscillator(gamma=gamma, T0=0.7, c=2.0)
    t = np.linspace(0.0, 6.0, 13)
    state = heat_bath_closed_form(t, 0.8, -0.3, gamma=gamma, s0=0.1, T0=0.7, c=2.0)
    np.testing.assert_allclose(state[0], [0.8, -0.3, 0.1], rtol=1e-14)
    h = 1e-5
    ahead = heat_bath_closed_form(t + h, 0.8, -0.3, gamma=gamma, s0=0.1, T0=0.7, c=2.0)
    behind = heat_bath_closed_form(t - h, 0.8, -0.3, gamma=gamma, s0=0.1, T0=0.7, c=2.0)
    np.testing.assert_allclose((ahead - behind) / (2 * h), system.xi(state), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(system.E(state), system.E(state[0]), rtol=1e-14)
    assert np.all(np.diff(state[:, 2]) >= 0.0)
    assert heat_bath_closed_form(2.0, 0.8, -0.3, gamma=gamma).shape == (2,)


def test_gas_containers_default_samples_stay_in_the_domain():
    samples = gas_containers()._samples
    assert np.all((0.0 < samples[:, 0]) & (samples[:, 0] < 2.0))
    with pytest.raises(ValueError, match=r"`samples`: the functions are not finite"):
        GenericSystem(
            E=gas_containers().functions.H,
            grad_E=gas_containers().functions.grad_H,
            S=gas_containers().functions.S,
            grad_S=gas_containers().functions.grad_S,
            L=gas_containers().functions.P,
            M=gas_containers().functions.M,
            params=[1.0],
            dim=4,
            samples=[[-0.5, 0.0, 0.0, 0.0], [2.5, 0.0, 0.0, 0.0]],
        )


def test_the_flows_reach_the_reference_limits():
    """The model's field integrated by scipy (no geomint kernel): S_inf = E_0 + N for the pendula, 3 ln(E_0 / 2)
    for the gas containers, H_0 for Euler's selective decay."""
    from scipy.integrate import solve_ivp

    def end(system, x0, t):
        return solve_ivp(lambda _, x: system.xi(x), (0.0, t), x0, rtol=1e-10, atol=1e-12, method="LSODA").y[:, -1]

    pendula = damped_pendula(3, gamma=0.5)
    x0 = np.array([0.1, 2.0, -1.0, 0.5, 0.0, -0.3, 0.2])
    assert end(pendula, x0, 100.0)[-1] == pytest.approx(pendula.E(x0) + 3, rel=1e-8)
    gas = gas_containers()
    x0 = np.array([0.7, 0.3, 0.2, -0.4])
    np.testing.assert_allclose(end(gas, x0, 200.0), gas_containers_limit(gas.E(x0)), atol=1e-7)
    euler, x0 = euler_zeitlin(5), euler_initial_state(5)
    assert euler.S(end(euler, x0, 10.0)) == pytest.approx(1.1375, rel=1e-8)


# -- operators given as actions ------------------------------------------------------------------------------
@numba.njit
def _P_apply(x, v, p):
    """``_P`` as an action: a rotation in (x0, x1)."""
    out = np.zeros(x.shape[0])
    out[0], out[1] = v[1], -v[0]
    return out


@numba.njit
def _metric_apply(x, v, p):
    """The paper's g as an action: ``(x . v) x - |x|^2 v``."""
    return (x @ v) * x - (x @ x) * v


@numba.njit
def _symmetric_P_apply(x, v, p):
    out = np.zeros(x.shape[0])
    out[0], out[1] = v[1], v[0]
    return out


@numba.njit
def _short_P_apply(x, v, p):
    return np.zeros(x.shape[0] - 1)


@numba.njit
def _matrix_P_apply(x, v, p):
    return np.zeros((x.shape[0], x.shape[0]))


@numba.njit
def _wrong_sign_metric_apply(x, v, p):
    return (x @ x) * v - (x @ v) * x


def _fish_action(**overrides):
    arguments = dict(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, P_apply=_P_apply, dim=4)
    arguments.update(overrides)
    return MetriplecticSystemN(**arguments)


def test_operators_given_as_actions_are_the_same_system():
    """P and the metric as actions give the matrices' field, D, P (formed column by column) and the kernels' one
    numba type, with the unused forms as placeholders."""
    matrices = _fish(metric=_metric, eps=0.3)
    actions = _fish_action(metric_apply=_metric_apply, eps=0.3)
    assert matrices.actions == 0 and actions.actions == layout.P_ACTION | layout.M_ACTION
    assert actions.metric == layout.USER_METRIC and "metric=user" in repr(actions)
    X = np.random.default_rng(6).normal(size=(3, 4))
    for method in ("xi", "xi_P", "xi_g", "dS_dt", "P", "D"):
        np.testing.assert_allclose(getattr(actions, method)(X), getattr(matrices, method)(X), rtol=1e-14, atol=1e-15)
    assert numba.typeof(actions.model) == numba.typeof(matrices.model) == numba.typeof(damped_pendula(2).model)
    pendula, matrix_pendula = damped_pendula(3), damped_pendula(3, form="matrix")
    assert pendula.actions == layout.P_ACTION | layout.M_ACTION and matrix_pendula.actions == 0
    Y = np.random.default_rng(7).normal(size=(4, 7))
    for method in ("L", "M", "xi", "xi_P", "xi_g", "dS_dt"):
        np.testing.assert_allclose(getattr(pendula, method)(Y), getattr(matrix_pendula, method)(Y), rtol=1e-15)


@pytest.mark.parametrize(
    "overrides, error, match",
    [
        ({"P": _P}, TypeError, r"give `P` \(a matrix function of \(x, params\)\) or `P_apply` .*not both"),
        ({"P_apply": None}, TypeError, r"give `P`, the Poisson tensor .* or `P_apply`, its action"),
        ({"metric": _metric, "metric_apply": _metric_apply}, TypeError, r"give `metric` .* or `metric_apply`"),
        ({"P_apply": lambda x, v, p: v}, TypeError, r"(?s)`P_apply` must be a numba-jitted function.*\(x, v, params\)"),
        ({"P_apply": _P}, TypeError, r"`P_apply` does not compile for \(x, v, params\)"),
        ({"P_apply": _matrix_P_apply}, TypeError, r"`P_apply` must return a contiguous float64 array of length n"),
        ({"P_apply": _short_P_apply}, ValueError, r"`P_apply` must return shape \(4,\); at x = .* shape \(3,\)"),
        ({"P_apply": _symmetric_P_apply}, ValueError, r"`P_apply` must be skew-symmetric \(P = -P\^T\); at x ="),
        (
            {"metric_apply": _wrong_sign_metric_apply},
            ValueError,
            r"`metric_apply` must be negative semidefinite \(a metric of the wrong sign: S would rise\)",
        ),
    ],
)
def test_construction_errors_name_the_action(overrides, error, match):
    with pytest.raises(error, match=match):
        _fish_action(**overrides)


@numba.njit
def _pendula_L_not_skew(x, v, p):
    out = np.zeros(x.shape[0])
    N = (x.shape[0] - 1) // 2
    for i in range(N):
        out[i] = v[N + i]
        out[N + i] = v[i]
    return out


@numba.njit
def _pendula_L_moving_S(x, v, p):
    out = np.zeros(x.shape[0])
    N = (x.shape[0] - 1) // 2
    for i in range(N):
        out[i] = v[N + i]
        out[N + i] = -v[i]
    out[0] += v[-1]
    out[-1] -= v[0]
    return out


@numba.njit
def _pendula_M_negative(x, v, p):
    out = np.zeros(x.shape[0])
    N = (x.shape[0] - 1) // 2
    for i in range(N):
        c = v[N + i] - x[N + i] * v[-1]
        out[N + i] = -c
        out[-1] += x[N + i] * c
    return out


@pytest.mark.parametrize("N", [3, 40])  # n = 7: the matrix by columns; n = 81: random probes
@pytest.mark.parametrize(
    "overrides, match",
    [
        ({"L_apply": _pendula_L_not_skew}, r"`L_apply` must be skew-symmetric"),
        ({"L_apply": _pendula_L_moving_S}, r"`L_apply` must satisfy L grad S = 0 \(S must be a Casimir of it\)"),
        ({"M_apply": _pendula_M_negative}, r"`M_apply` must be positive semidefinite"),
    ],
)
def test_generic_actions_are_checked_by_columns_or_by_probes(N, overrides, match):
    pendula = damped_pendula(N)
    functions = pendula.functions
    arguments = dict(E=functions.H, grad_E=functions.grad_H, S=functions.S, grad_S=functions.grad_S)
    arguments.update(L_apply=functions.P_apply, M_apply=functions.M_apply, params=[0.5], dim=2 * N + 1)
    arguments.update(overrides)
    with pytest.raises(ValueError, match=match):
        GenericSystem(**arguments)
    with pytest.raises(TypeError, match=r"give `M`, the friction matrix .* or `M_apply`"):
        GenericSystem(**{**arguments, "M_apply": None})


def test_damped_pendula_form_is_checked():
    with pytest.raises(ValueError, match=r"`form` must be one of \('action', 'matrix'\); got 'sparse'"):
        damped_pendula(2, form="sparse")


def test_no_states_give_empty_arrays_of_the_values_shape_as_in_R3():
    gas, body = geomint.systems.gas_containers(), geomint.systems.relaxing_rigid_body()
    assert body.grad_H(np.zeros((0, 3))).shape == (0, 3) and body.H(np.zeros((0, 3))).shape == (0,)
    none = np.zeros((0, 4))
    assert gas.H(none).shape == (0,) and gas.S(none).shape == (0,) and gas.dS_dt(none).shape == (0,)
    assert gas.grad_H(none).shape == (0, 4) and gas.xi(none).shape == (0, 4) and gas.P(none).shape == (0, 4, 4)
    assert gas.grad_H(np.ones((2, 4))).shape == (2, 4) and np.shape(gas.H(np.ones(4))) == ()


@numba.njit
def _L_writing_into_x(x, p):
    x[1] = 7.0
    n = x.shape[0]
    out = np.zeros((n, n))
    out[0, 1], out[1, 0] = 1.0, -1.0
    return out


def test_a_user_function_that_writes_into_x_is_named_not_another():
    """A function that changes its argument would corrupt the kernels' state; the checks (which used to see the
    changed sample and blame the next function) name it, and the samples stay as they were."""
    import importlib

    gas = importlib.import_module("geomint.systems.gas_containers")  # the module (the package names the function)
    samples = gas.SAMPLES.copy()
    with pytest.raises(ValueError, match=r"the user function `L` wrote into its argument x \(called at x = \["):
        geomint.GenericSystem(
            E=gas._E, grad_E=gas._grad_E, S=gas._S, grad_S=gas._grad_S, L=_L_writing_into_x, M=gas._M,
            params=[0.5], dim=4, samples=gas.SAMPLES,
        )  # fmt: skip
    np.testing.assert_array_equal(gas.SAMPLES, samples)
    system = geomint.GenericSystem(
        E=gas._E, grad_E=gas._grad_E, S=gas._S, grad_S=gas._grad_S, L=_L_writing_into_x, M=gas._M,
        params=[0.5], dim=4, samples=gas.SAMPLES, check=False,
    )  # fmt: skip
    x = np.array([1.5, 0.0, 2.0, 2.0])
    with pytest.raises(ValueError, match=r"`L` wrote into its argument x .* x became \[1.5, 7.0, 2.0, 2.0\]"):
        system.L(x)
    assert x.tolist() == [1.5, 0.0, 2.0, 2.0]  # the caller's state as it was
