"""The model: the paper's lemmas as properties, and validation of user functions."""

import numba
import numpy as np
import pytest
from hypothesis import assume, given

import geomint
import geomint.testing as gt

EPS = np.finfo(float).eps
SUBNORMAL = np.finfo(float).smallest_subnormal


def _scale(*vectors):
    """Product of the norms, without the underflow of squaring tiny components."""
    return np.prod([np.hypot.reduce(v) for v in vectors])


@given(system=gt.catalogue_systems(), x=gt.states())
def test_g_annihilates_grad_H(system, x):
    g, gh = system.g(x), system.grad_H(x)
    assert np.linalg.norm(g @ gh) <= 8 * EPS * _scale(gh, gh, gh)


@given(system=gt.catalogue_systems(), x=gt.states())
def test_g_is_symmetric_negative_semidefinite(system, x):
    g, gh = system.g(x), system.grad_H(x)
    assert np.array_equal(g, g.T)
    eigenvalues = np.linalg.eigvalsh(g)
    assert eigenvalues.max() <= 16 * EPS * np.dot(gh, gh)


@given(system=gt.catalogue_systems(), x=gt.states())
def test_g_has_rank_two_where_grad_H_is_nonzero(system, x):
    gh = system.grad_H(x)
    size = np.dot(gh, gh)
    assume(size > 1e-8)
    eigenvalues = np.sort(np.linalg.eigvalsh(system.g(x)))
    # spectrum of g: {0, -|grad H|^2, -|grad H|^2}
    assert np.allclose(eigenvalues, [-size, -size, 0.0], rtol=0, atol=16 * EPS * size)


@given(system=gt.catalogue_systems(), x=gt.states())
def test_hamiltonian_and_gradient_fields_are_orthogonal(system, x):
    xi_P, xi_g = system.xi_P(x), system.xi_g(x)
    gh, gs, J = system.grad_H(x), system.grad_S(x), system.J(x)
    # the products round in the subnormal range too, where the error is absolute (a few of its steps)
    assert abs(np.dot(xi_P, xi_g)) <= 32 * EPS * _scale(gh, J) * _scale(gh, gh, gs) + 8 * SUBNORMAL


@given(system=gt.catalogue_systems(), x=gt.states())
def test_dissipation_rate_is_minus_sigma_squared(system, x):
    gh, gs = system.grad_H(x), system.grad_S(x)
    sigma = system.sigma(x)
    assert abs(gs @ system.g(x) @ gs + sigma @ sigma) <= 32 * EPS * _scale(gh, gh, gs, gs)
    assert system.dS_dt(x) == pytest.approx(-system.eps * (sigma @ sigma), rel=1e-14, abs=1e-300)


@given(system=gt.catalogue_systems(), x=gt.states())
def test_g_grad_S_is_a_double_cross_product(system, x):
    gh, gs = system.grad_H(x), system.grad_S(x)
    assert np.linalg.norm(system.g(x) @ gs - np.cross(gh, np.cross(gh, gs))) <= 16 * EPS * _scale(gh, gh, gs)


@pytest.mark.nojit
def test_vectorised_evaluation_matches_single_states():
    system = geomint.systems.quartic_rigid_body(eps=0.3)
    X = np.random.default_rng(1).normal(size=(5, 3))
    for method in ("H", "S", "grad_H", "grad_S", "J", "xi_P", "xi_g", "xi", "g", "sigma", "dS_dt"):
        many = getattr(system, method)(X)
        single = np.array([getattr(system, method)(x) for x in X])
        np.testing.assert_array_equal(many, single)


@pytest.mark.parametrize("system", [geomint.systems.quartic_rigid_body(eps=0.3), geomint.systems.damped_pendula(3)])
def test_H_and_S_together_are_H_and_S_alone_bit_for_bit(system):
    X = np.random.default_rng(2).normal(size=(4, system.dim))
    for x in (X[0], X):
        H, S = system.H_and_S(x)
        np.testing.assert_array_equal(H, system.H(x))
        np.testing.assert_array_equal(S, system.S(x))
        assert np.ndim(H) == np.ndim(S) == x.ndim - 1


def test_fields_match_the_papers_equations():
    a, b, c, eps = 0.5, 1.0, 1.5, 0.7
    system = geomint.systems.relaxing_rigid_body(a, b, c, eps=eps)
    x, y, z = m = np.array([0.3, -0.4, 0.8])
    paper = np.array(
        [  # section 2.1, with the gradient part scaled by eps
            (b - c) * y * z + eps * (b * y * (a - b) * x * y + c * z * (a - c) * x * z),
            (c - a) * x * z + eps * (c * z * (b - c) * y * z + a * x * (b - a) * x * y),
            # the paper prints the last term as b y (c - b) y x: a typo for b y (c - b) y z
            (a - b) * x * y + eps * (a * x * (c - a) * x * z + b * y * (c - b) * y * z),
        ]
    )
    np.testing.assert_allclose(system.xi(m), paper, rtol=1e-14)
    oscillator = geomint.systems.dissipative_oscillator((0.0, 0.0, 0.5), eps=1.0)  # S = z^2/2
    np.testing.assert_allclose(oscillator.xi(m), [y + x * z * z, -x + y * z * z, -(x * x + y * y) * z], rtol=1e-14)


def test_the_effects_switches_drop_parts_of_the_field():
    system = geomint.systems.relaxing_rigid_body(eps=0.4)
    x = np.array([0.3, -0.4, 0.8])
    np.testing.assert_array_equal(system.with_effects(hamiltonian=False).xi(x), 0.4 * system.xi_g(x))
    np.testing.assert_array_equal(system.with_effects(eps=0).xi(x), system.xi_P(x))


@pytest.mark.parametrize(
    "system",
    [
        geomint.systems.relaxing_rigid_body(eps=0.4),
        geomint.systems.relaxing_rigid_body(eps=0.4).with_effects(hamiltonian=False),
        geomint.systems.dissipative_oscillator((0.3, 0.0, 0.5), eps=1.0),
    ],
    ids=["body", "body_gradient_only", "oscillator"],
)
def test_xi_on_one_state_is_the_row_of_xi_on_many_bit_for_bit(system):
    """One state takes its own short path (what a scipy right-hand side calls); it must be the same arithmetic."""
    X = np.random.default_rng(3).normal(scale=2.0, size=(50, 3))
    many = system.xi(X)
    for row, value in zip(X, many):
        np.testing.assert_array_equal(system.xi(row), value)
        np.testing.assert_array_equal(system.xi(list(row)), value)


# -- user functions, P form, validation -------------------------------------------------
@numba.njit
def _H(x, p):
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


@numba.njit
def _grad_H(x, p):
    return (x[0], x[1], x[2])


@numba.njit
def _grad_H_array(x, p):
    return np.array([x[0], x[1], x[2]])


@numba.njit
def _S(x, p):
    return 0.5 * x[2] ** 2


@numba.njit
def _grad_S(x, p):
    return (0.0, 0.0, x[2])


@numba.njit
def _grad_S_array(x, p):
    return np.array([0.0, 0.0, x[2]])


@numba.njit
def _J(x, p):
    return (0.0, 0.0, 1.0)


@numba.njit
def _J_array(x, p):
    return np.array([0.0, 0.0, 1.0])


@numba.njit
def _P(x, p):
    return np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


@numba.njit
def _wrong_grad_S(x, p):
    return (0.0, 0.0, 2.0 * x[2])


@numba.njit
def _int_S(x, p):
    return 1


def _oscillator(**overrides):
    functions = dict(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, J=_J)
    functions.update(overrides)
    return geomint.MetriplecticSystem(**functions)


@pytest.mark.parametrize(
    "functions",
    [
        dict(),
        dict(grad_H=_grad_H_array, grad_S=_grad_S_array, J=_J_array),
        dict(J=None, P=_P),
        dict(grad_H=_grad_H_array, grad_S=_grad_S_array, J=None, P=_P),
    ],
    ids=["tuples", "arrays", "P-matrix", "arrays+P"],
)
def test_every_function_form_gives_the_same_trajectory(functions):
    reference = geomint.solve(_oscillator(), [0.6, 0.0, 0.8], (0.0, 1.0), 0.1)
    sol = geomint.solve(_oscillator(**functions), [0.6, 0.0, 0.8], (0.0, 1.0), 0.1)
    np.testing.assert_array_equal(sol.x, reference.x)


def test_plain_python_function_is_refused_with_a_fix():
    with pytest.raises(TypeError, match=r"(?s)`grad_H` must be a numba-jitted function.*@numba.njit"):
        _oscillator(grad_H=lambda x, p: (x[0], x[1], x[2]))


@pytest.mark.parametrize(
    "name, returns",
    [("H", "a float"), ("S", "a float"), ("J", "a 3-tuple of floats"), ("grad_S", "a 3-tuple of floats")],
)
def test_the_fix_for_a_plain_python_function_shows_an_example_of_that_function(name, returns):
    """Issue 26: a non-jitted H was shown an example of grad_H."""
    with pytest.raises(TypeError) as error:
        _oscillator(**{name: lambda x, p: 0.0})
    message = str(error.value)
    assert f"@numba.njit\n    def {name}(x, params):\n        return " in message
    assert f"`{name}` returns {returns}" in message
    assert message.count("def ") == 1


def test_wrong_return_types_are_refused():
    with pytest.raises(TypeError, match=r"`S` must return a float64; it returns Literal\[int\]\(1\)"):
        _oscillator(S=_int_S)
    with pytest.raises(TypeError, match=r"must return the same kind of vector"):
        _oscillator(grad_S=_grad_S_array)
    with pytest.raises(TypeError, match=r"`J` must return a 3-tuple"):
        _oscillator(J=_P)


@numba.njit
def _grad_H_five(x, p):
    return np.array([x[0], x[1], x[2], 0.0, 0.0])


@numba.njit
def _P_two_by_two(x, p):
    return np.zeros((2, 2))


def test_arrays_of_the_wrong_shape_are_refused_with_the_shape():
    """An array's type does not carry its length: the kernels would read past a shorter one."""
    with pytest.raises(ValueError, match=r"`grad_H` must return shape \(3,\); at x = \[.*\] it returned shape \(5,\)"):
        _oscillator(grad_H=_grad_H_five, grad_S=_grad_S_array, J=_J_array)
    with pytest.raises(ValueError, match=r"`P` must return shape \(3, 3\); .* it returned shape \(2, 2\)"):
        _oscillator(J=None, P=_P_two_by_two)


def test_poisson_tensor_is_given_exactly_once():
    with pytest.raises(ValueError, match=r"exactly one of `J`.*and `P`"):
        _oscillator(P=_P)
    with pytest.raises(ValueError, match=r"exactly one of `J`.*and `P`"):
        _oscillator(J=None)


def test_inconsistent_gradient_is_caught():
    with pytest.raises(ValueError, match=r"`grad_S` must match finite differences of S"):
        _oscillator(grad_S=_wrong_grad_S)
    _oscillator(grad_S=_wrong_grad_S, check=False)  # the check can be switched off


@pytest.mark.parametrize(
    "eps, error, match",
    [
        (-0.1, ValueError, r"`eps` must be finite and >= 0; got -0.1"),
        (float("nan"), ValueError, r"`eps` must be finite and >= 0"),
        ("big", TypeError, r"`eps` must be a real number"),
        (True, TypeError, r"`eps` must be a real number; got True \(bool\)"),
    ],
)
def test_bad_eps(eps, error, match):
    with pytest.raises(error, match=match):
        geomint.systems.relaxing_rigid_body(eps=eps)


def test_bad_params_and_catalogue_arguments():
    with pytest.raises(ValueError, match=r"`params` must be finite"):
        geomint.MetriplecticSystem(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, J=_J, params=[1.0, np.inf])
    with pytest.raises(ValueError, match=r"`a` must be a finite positive number; got -1.0"):
        geomint.systems.relaxing_rigid_body(a=-1)
    with pytest.raises(ValueError, match=r"`number` must be 1 or 2"):
        geomint.systems.degenerate_example(3)
    with pytest.raises(TypeError, match=r"`hamiltonian` must be True or False"):
        geomint.systems.degenerate_example(1).with_effects(hamiltonian="no")


@numba.njit
def _H_beyond_five(x, p):
    return np.log(x[0] - 5.0) + 0.5 * (x[1] ** 2 + x[2] ** 2)


@numba.njit
def _grad_H_wrong(x, p):
    return (123.0, x[1], x[2])


def test_a_system_undefined_at_every_sample_point_is_not_accepted_unchecked():
    """H = log(x - 5) is not finite anywhere in [-1, 1]^3: the checks could check nothing (here a wrong
    gradient), and say so instead of passing; check=False builds it."""
    functions = dict(H=_H_beyond_five, grad_H=_grad_H_wrong, S=_S, grad_S=_grad_S, J=_J)
    with pytest.raises(ValueError, match=r"not finite at any of their 6 sample points .* pass check=False"):
        geomint.MetriplecticSystem(**functions)
    assert geomint.MetriplecticSystem(**functions, check=False).name


def test_check_must_be_true_or_false():
    """``check="no"`` was taken as true (the checks ran); a word or a number is refused, in R^3 and in R^n."""
    import importlib

    gas = importlib.import_module("geomint.systems.gas_containers")  # the module (the package names the function)

    with pytest.raises(TypeError, match=r"`check` must be True or False; got 'no'"):
        geomint.MetriplecticSystem(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, J=_J, check="no")
    functions = dict(E=gas._E, grad_E=gas._grad_E, S=gas._S, grad_S=gas._grad_S, L=gas._L, M=gas._M, params=[0.5])
    with pytest.raises(TypeError, match=r"`check` must be True or False; got 0"):
        geomint.GenericSystem(**functions, dim=4, samples=gas.SAMPLES, check=0)
    assert geomint.GenericSystem(**functions, dim=4, samples=gas.SAMPLES, check=False).dim == 4


@pytest.mark.parametrize("dim", [3.0, True])
def test_a_dimension_that_is_not_an_integer_is_named_before_J(dim):
    """``dim=3.0`` is not the integer 3, so the R^n class is asked, which takes no J: the dimension is what is
    wrong, and the message names it."""
    with pytest.raises(TypeError, match=r"`dim` must be an integer >= 2 \(the dimension n of the state\); got"):
        geomint.MetriplecticSystem(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, J=_J, dim=dim)
