"""The discrete gradients: the defining identity, consistency, symmetry, the switching rule, AVF exactness."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given, settings, target
from hypothesis import strategies as st
from numba import njit

import geomint
import geomint.testing as gt
from geomint._kernels.discrete_field import discrete_axial, polish_moves
from geomint._kernels.discrete_gradient import SWITCH
from geomint._kernels.field import dissipative
from geomint._kernels.vec3 import cross, norm_inf

EPS = np.finfo(float).eps
DISCRETE_GRADIENTS = [
    geomint.Gonzalez(),
    geomint.ItohAbe(),
    geomint.SymmetrizedItohAbe(),
    geomint.AVF(),
    geomint.AVF(nodes=1),
]
IDS = [repr(m) for m in DISCRETE_GRADIENTS]
QUARTIC = geomint.systems.quartic_rigid_body(0.5, 1.0, 1.5, k=0.7)


def _identity_defect(system, method, x, x_new):
    """``|dgF . dx - dF|`` over the ulp-scale of the terms, for F = H and S."""
    dg_h, dg_s, _ = method.discrete_gradients(system, x, x_new)
    dx = x_new - x
    defects = []
    for dg, F, grad in ((dg_h, system.H, system.grad_H), (dg_s, system.S, system.grad_S)):
        change = F(x_new) - F(x)
        scale = gt.term_scale(F(x), F(x_new), grad(x), x) + np.abs(dg) @ np.abs(dx)
        defects.append(abs(dg @ dx - change) / (EPS * max(scale, np.finfo(float).tiny)))
    return max(defects)


@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=IDS)
@given(system=gt.catalogue_systems(), x=gt.states(), dx=gt.states(bound=0.5, min_norm=0.0))
def test_discrete_gradient_identity(method, system, x, dx):
    """``dgF . (x' - x) = F(x') - F(x)`` to a few ulp of the terms, for H and S, any pair."""
    assert _identity_defect(system, method, x, x + dx) <= 32


@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=IDS)
@given(system=gt.catalogue_systems(), x=gt.states())
def test_consistent_and_axial_parallel(method, system, x):
    """``dg(x, x) = grad F(x)`` and ``Jbar`` parallel to ``dgS`` (S a discrete Casimir)."""
    dg_h, dg_s, axial = method.discrete_gradients(system, x, x)
    scale = np.linalg.norm(system.grad_H(x)) + 1.0
    np.testing.assert_allclose(dg_h, system.grad_H(x), rtol=0, atol=8 * EPS * scale)
    np.testing.assert_allclose(dg_s, system.grad_S(x), rtol=0, atol=8 * EPS * (np.linalg.norm(system.grad_S(x)) + 1.0))
    assert np.linalg.norm(np.cross(axial, dg_s)) <= 8 * EPS * np.linalg.norm(axial) * np.linalg.norm(dg_s) + 1e-300


@pytest.mark.parametrize("method", [m for m in DISCRETE_GRADIENTS if m.symmetric], ids=lambda m: m.name)
@given(x=gt.states(), dx=gt.states(bound=0.5, min_norm=1e-3))
def test_symmetric_discrete_gradients_are_symmetric(method, x, dx):
    """``dg(x, x') = dg(x', x)`` for the methods that declare ``symmetric``; Itoh-Abe is not."""
    forward = method.discrete_gradients(QUARTIC, x, x + dx)
    backward = method.discrete_gradients(QUARTIC, x + dx, x)
    for f, b in zip(forward[:2], backward[:2]):
        np.testing.assert_allclose(f, b, rtol=1e-10, atol=1e-10 * np.abs(f).max())


def test_itoh_abe_is_not_symmetric():
    """On the non-separable S of the quartic body (on a separable F Itoh-Abe is symmetric)."""
    x, x_new = np.array([0.3, 0.8, -0.5]), np.array([0.9, 0.1, 0.4])
    forward, backward = (geomint.ItohAbe().discrete_gradients(QUARTIC, *pair)[1] for pair in ((x, x_new), (x_new, x)))
    assert np.max(np.abs(forward - backward)) > 1e-3


@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=IDS)
@pytest.mark.parametrize("factor", [0.0, 1e-6, 0.5, 0.999, 1.001, 2.0, 1e3])
@pytest.mark.parametrize("coordinate", [0, 1, 2])
def test_switching_rule_both_sides(method, factor, coordinate):
    """Increments just below, at and above ``SWITCH |x|`` (and 0/0): finite, exact, continuous.

    One coordinate moves by ``factor * SWITCH * |x|_inf`` (the others move by
    0.3, so Itoh-Abe has a lone tiny edge); the discrete gradient stays within
    ``50 max(factor, 1) SWITCH`` relative of its value for a coordinate that does
    not move (what the increment itself changes), and the identity holds to a few ulp.
    """
    x = np.array([0.7, -0.4, 0.9])
    dx = np.full(3, 0.3)
    dx[coordinate] = factor * SWITCH * np.max(np.abs(x))
    dg = np.concatenate(method.discrete_gradients(QUARTIC, x, x + dx)[:2])
    assert np.all(np.isfinite(dg))
    assert _identity_defect(QUARTIC, method, x, x + dx) <= 32
    dx[coordinate] = 0.0
    limit = np.concatenate(method.discrete_gradients(QUARTIC, x, x + dx)[:2])
    assert np.max(np.abs(dg - limit)) <= 50.0 * max(factor, 1.0) * SWITCH * np.max(np.abs(limit))


@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=IDS)
@pytest.mark.parametrize("size", [1e-14, 1e-10, 1e-6, 1e-4])
def test_tiny_increments_approach_the_gradient(method, size):
    """As ``|dx| -> 0`` the discrete gradient tends to grad F (no blow-up from the quotient's round-off)."""
    x = np.array([0.7, -0.4, 0.9])
    dx = size * np.array([0.3, -1.0, 0.6])
    dg_h, dg_s, _ = method.discrete_gradients(QUARTIC, x, x + dx)
    np.testing.assert_allclose(dg_h, QUARTIC.grad_H(x), rtol=0, atol=10 * max(size, EPS ** (2 / 3)))
    np.testing.assert_allclose(dg_s, QUARTIC.grad_S(x), rtol=0, atol=10 * max(size, EPS ** (2 / 3)))


def test_avf_is_exact_for_polynomials_of_its_degree():
    """On the quartic body (degree 4) AVF with 2 nodes equals AVF with 8 (both integrate exactly);
    with 1 node it is Gonzalez's gradient, which differs."""
    x, x_new = np.array([0.3, 0.8, -0.5]), np.array([0.9, 0.1, 0.4])
    two = geomint.AVF(degree=4).discrete_gradients(QUARTIC, x, x_new)
    eight = geomint.AVF(nodes=8).discrete_gradients(QUARTIC, x, x_new)
    one = geomint.AVF(nodes=1).discrete_gradients(QUARTIC, x, x_new)
    gonzalez = geomint.Gonzalez().discrete_gradients(QUARTIC, x, x_new)
    np.testing.assert_allclose(two[0], eight[0], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(one[0], gonzalez[0], rtol=1e-15, atol=1e-15)
    assert np.max(np.abs(two[0] - one[0])) > 1e-3


def test_avf_nodes_from_degree():
    assert geomint.AVF(degree=4).n_nodes == 2
    assert geomint.AVF(degree=5).n_nodes == 3
    assert geomint.AVF(nodes=5).n_nodes == 5
    assert geomint.AVF().n_nodes == 3
    coeffs = geomint.AVF(nodes=4).lower(None).coeffs
    assert coeffs[4:].sum() == pytest.approx(1.0, abs=1e-15)
    assert np.all((coeffs[:4] > 0) & (coeffs[:4] < 1))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"nodes": 0}, r"`nodes` must be None or an integer in \[1, 16\]; got 0"),
        ({"nodes": 2.5}, r"`nodes` must be None or an integer"),
        ({"degree": -1}, r"`degree` must be None or an integer in \[1, 32\]; got -1"),
        ({"nodes": 1, "degree": 4}, r"`nodes` = 1 is not exact for `degree` = 4"),
        ({"max_newton_iter": 0}, r"`max_newton_iter` must be an integer in \[1, 10\*\*6\]; got 0"),
    ],
)
def test_avf_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        geomint.AVF(**kwargs)


def test_compensated_must_be_bool():
    with pytest.raises(TypeError, match=r"`compensated` must be True or False; got 1"):
        geomint.ItohAbe(compensated=1)


@pytest.mark.parametrize("name", ["itoh_abe", "symmetrized_itoh_abe", "avf", "damped_gonzalez"])
def test_short_names(name):
    assert geomint.integrators.resolve(name).name == name


@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=IDS)
@pytest.mark.parametrize("z", [0.0, 1e-320, 1e-300, 1e-150, 1e-10])
def test_axial_vector_defined_where_dgS_vanishes(method, z):
    """Oscillator (S = z^2/2, J = e_z) with dgS ~ z -> 0, down to subnormal z: Jbar = (0, 0, 1), finite;
    degenerate Example 1 on y = 0 (J = 0 there): Jbar = 0."""
    oscillator = geomint.systems.dissipative_oscillator((0.0, 0.0, 0.5))
    _, dg_s, axial = method.discrete_gradients(oscillator, np.array([0.6, 0.0, z]), np.array([0.5, 0.3, z]))
    assert np.all(np.isfinite(dg_s))
    np.testing.assert_array_equal(axial, [0.0, 0.0, 1.0])
    example = geomint.systems.degenerate_example(1)
    _, _, axial = method.discrete_gradients(example, np.array([0.6, 0.0, z]), np.array([0.5, 0.0, 2 * z]))
    np.testing.assert_array_equal(axial, [0.0, 0.0, 0.0])


@njit(error_model="numpy")
def _unpolished(dg_h, dg_s, axial, eps, h, terms_h, terms_s):
    """The discrete field's F from these parts (``field.dissipative``, the axial vector made parallel to dgS by
    ``discrete_axial``) as the cross products round it, and whether ``discrete_field.polish_moves`` polishes it."""
    g, s = (dg_h[0], dg_h[1], dg_h[2]), (dg_s[0], dg_s[1], dg_s[2])
    j = discrete_axial((axial[0], axial[1], axial[2]), s)
    F = dissipative(g, s, eps, cross(g, j))
    return np.array(F), polish_moves(h, eps, norm_inf(j), norm_inf(g), norm_inf(s), terms_h, terms_s)


#: the least positive subnormal, 2^-1074
SMALLEST = Fraction(1, 2**1074)


def _exact_dot(u, v):
    return sum((Fraction(a) * Fraction(b) for a, b in zip(u, v, strict=True)), Fraction(0))


def _exact_cross(u, v):
    u, v = [Fraction(a) for a in u], [Fraction(b) for b in v]
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def _sized(low=-8, high=8):
    """3-vectors of components in [-2, 2] times 2^k, k in [low, high]."""
    return st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.integers(low, high)).map(
        lambda v: np.array(v[:3]) * 2.0 ** v[3]
    )


@given(
    dg_h=_sized(),
    dg_s=_sized(),
    axial=_sized(),
    x=_sized(),
    eps=st.floats(0.0, 10.0),
    h=st.tuples(st.floats(-2.0, 2.0).filter(lambda v: v != 0.0), st.integers(-40, 3)).map(lambda v: v[0] * 2.0 ** v[1]),
)
@settings(max_examples=300)
def test_polish_is_skipped_only_where_the_rounding_moves_H_and_S_by_under_an_ulp(dg_h, dg_s, axial, x, eps, h):
    """Where ``discrete_field.polish_moves`` skips ``polish``, the step ``h F``, F as the cross products round it,
    moves H and S (``h dgF . F``, in exact arithmetic) by at most an ulp of their terms (``|dgF| . |x|``, the
    least ``roundoff.term_scale`` gives) beyond the exact field (``F . dgH = 0``,
    ``F . dgS = -eps |dgH x dgS|^2``): a quarter of what the acceptance allows.  (A move below the least
    subnormal, where the terms are 0, is none: a float cannot hold it.)"""
    terms_h, terms_s = float(np.abs(dg_h) @ np.abs(x)), float(np.abs(dg_s) @ np.abs(x))
    F, moves = _unpolished(dg_h, dg_s, axial, eps, h, terms_h, terms_s)
    assume(not moves)
    c = _exact_cross(dg_h, dg_s)
    rate = -Fraction(eps) * sum((a * a for a in c), Fraction(0))
    ulp_h, ulp_s = (max(Fraction(EPS) * Fraction(terms), SMALLEST) for terms in (terms_h, terms_s))
    moved_h, moved_s = abs(Fraction(h) * _exact_dot(F, dg_h)), abs(Fraction(h) * (_exact_dot(F, dg_s) - rate))
    target(float(max(moved_h / ulp_h, moved_s / ulp_s)))  # towards the worst rounding
    assert moved_h <= ulp_h
    assert moved_s <= ulp_s


def test_polish_is_skipped_inside_the_time_scale_and_taken_in_a_stiff_step():
    """The relaxing rigid body (0.5, 1, 1.5), eps = 0.1, at x0 = (0.6, 0, 0.8): not polished at h = 0.01, polished
    at h = 1 (``polish_moves``; the bound of the test above, on the same kernel)."""
    x = np.array([0.6, 0.0, 0.8])
    dg_h, dg_s = np.array([0.5, 1.0, 1.5]) * x, x
    terms_h, terms_s = float(np.abs(dg_h) @ np.abs(x)), float(np.abs(dg_s) @ np.abs(x))
    assert not _unpolished(dg_h, dg_s, x, 0.1, 0.01, terms_h, terms_s)[1]
    assert _unpolished(dg_h, dg_s, x, 0.1, 1.0, terms_h, terms_s)[1]
