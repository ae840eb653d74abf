"""geomint.analysis: the paper's propositions at random points, equilibria and their stability checked by simulation."""

import numba
import numpy as np
import pytest

import geomint
from geomint import analysis, level_set
from geomint.systems import CATALOGUE


# -- systems users bring (Lorenz-Nevir, a coupled rigid body, a non-polynomial one) -------------
@numba.njit(cache=True)
def _lorenz_H(x, p):
    return 0.5 * (x[1] ** 2 + x[2] ** 2) - p[1] * x[2]


@numba.njit(cache=True)
def _lorenz_grad_H(x, p):
    return (0.0, x[1], x[2] - p[1])


@numba.njit(cache=True)
def _lorenz_S(x, p):
    return 0.5 * x[0] ** 2 - p[0] * x[2]


@numba.njit(cache=True)
def _lorenz_grad_S(x, p):
    return (x[0], 0.0, -p[0])


@numba.njit(cache=True)
def _lorenz_J(x, p):
    return (-x[0], 0.0, p[0])


@numba.njit(cache=True)
def _coupled_H(x, p):
    return 0.5 * (p[0] * x[0] ** 2 + p[1] * x[1] ** 2 + p[2] * x[2] ** 2) + p[3] * x[0] ** 2 * x[1] ** 2


@numba.njit(cache=True)
def _coupled_grad_H(x, p):
    return (p[0] * x[0] + 2 * p[3] * x[0] * x[1] ** 2, p[1] * x[1] + 2 * p[3] * x[1] * x[0] ** 2, p[2] * x[2])


@numba.njit(cache=True)
def _sphere_S(x, p):
    return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)


@numba.njit(cache=True)
def _sphere_grad_S(x, p):
    return (x[0], x[1], x[2])


@numba.njit(cache=True)
def _identity_J(x, p):
    return (x[0], x[1], x[2])


@numba.njit(cache=True)
def _cosh_H(x, p):
    return np.cosh(x[0]) + 0.5 * x[1] ** 2 + np.exp(0.3 * x[2]) - 0.3 * x[2]


@numba.njit(cache=True)
def _cosh_grad_H(x, p):
    return (np.sinh(x[0]), x[1], 0.3 * np.exp(0.3 * x[2]) - 0.3)


@numba.njit(cache=True)
def _z_cubed_S(x, p):
    return x[2] ** 3 / 3.0 - x[2]


@numba.njit(cache=True)
def _z_cubed_grad_S(x, p):
    return (0.0, 0.0, x[2] ** 2 - 1.0)


@numba.njit(cache=True)
def _axial_J(x, p):
    return (0.0, 0.0, 1.0 + x[2] ** 2)


def lorenz_nevir(sigma=10.0, r=28.0):
    return geomint.MetriplecticSystem(
        H=_lorenz_H,
        grad_H=_lorenz_grad_H,
        S=_lorenz_S,
        grad_S=_lorenz_grad_S,
        J=_lorenz_J,
        params=[sigma, r],
        name="lorenz_nevir",
    )


def coupled_rigid_body(a=0.5, b=1.0, c=1.5, k=0.4):
    return geomint.MetriplecticSystem(
        H=_coupled_H,
        grad_H=_coupled_grad_H,
        S=_sphere_S,
        grad_S=_sphere_grad_S,
        J=_identity_J,
        params=[a, b, c, k],
        name="coupled_rigid_body",
    )


def cosh_system():
    return geomint.MetriplecticSystem(
        H=_cosh_H, grad_H=_cosh_grad_H, S=_z_cubed_S, grad_S=_z_cubed_grad_S, J=_axial_J, name="cosh"
    )


def _special_points(name, system):
    """Points where the propositions have something to say (equilibria, dS = 0, P = 0)."""
    if name == "lorenz_nevir":  # the z axis (grad S || grad H) and the line y = 0, z = r (grad H = 0)
        s = np.linspace(-40.0, 80.0, 13)
        return np.vstack([np.stack([0 * s, 0 * s, s], 1), np.stack([s, 0 * s, 28.0 + 0 * s], 1)])
    if name == "cosh":  # z = +-1 (dS = 0), and the vertical line through the minimiser of H
        s = np.linspace(-2.0, 2.0, 9)
        return np.vstack([np.stack([s, s, 1.0 + 0 * s], 1), np.stack([0 * s, 0 * s, s], 1)])
    H0 = float(system.H([0.6, 0.5, 0.7]))
    found = analysis.equilibria(system, H0, "xi", np.zeros(3), n=600)
    return np.vstack([f.points if isinstance(f, analysis.EquilibriumCurve) else f.x[None] for f in found])


ZOO = {
    **{name: make() for name, make in CATALOGUE.items()},
    "degenerate_example_2": geomint.systems.degenerate_example(2),
    "relaxing_rigid_body_equal": geomint.systems.relaxing_rigid_body(1.5, 1.5, 0.5),
    "oscillator_double_well": geomint.systems.dissipative_oscillator((0.0, 0.0, -0.5, 0.0, 0.25)),
    "lorenz_nevir": lorenz_nevir(),
    "coupled_rigid_body": coupled_rigid_body(),
    "cosh": cosh_system(),
}


@pytest.fixture(scope="module", params=sorted(ZOO))
def zoo_points(request):
    system = ZOO[request.param]
    rng = np.random.default_rng(14)
    scale = 40.0 if request.param == "lorenz_nevir" else 2.0
    X = np.vstack([rng.uniform(-scale, scale, (300, 3)), _special_points(request.param, system)])
    return request.param, system, X


def test_lemma_8_prop_9_regular_equilibria_are_shared(zoo_points):
    name, system, X = zoo_points
    c = analysis.conditions(system, X)
    assert analysis.shared_equilibria_hold(system, X).all()
    assert np.any(c.xi_zero), f"{name}: no equilibrium among the points: the test says nothing"


def test_prop_10_regular_equilibria_are_critical_points_of_H_or_tangencies(zoo_points):
    _, system, X = zoo_points
    assert analysis.regular_equilibria_explained(system, X).all()


def test_prop_11_gradient_part_vanishes_exactly_where_grad_S_is_parallel_or_a_gradient_vanishes(zoo_points):
    name, system, X = zoo_points
    assert analysis.gradient_zeros_explained(system, X).all()
    assert np.any(analysis.conditions(system, X).xi_g_zero), f"{name}: no zero of xi_g among the points"


def test_the_proposition_functions_fail_when_S_is_not_a_casimir():
    @numba.njit
    def H(x, p):
        return 0.5 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2)

    @numba.njit
    def gH(x, p):
        return (x[0], x[1], x[2])

    @numba.njit
    def S(x, p):
        return x[0] * x[2]

    @numba.njit
    def gS(x, p):
        return (x[2], 0.0, x[0])

    @numba.njit
    def J(x, p):
        return (1.0, 0.0, 0.0)

    broken = geomint.MetriplecticSystem(H=H, grad_H=gH, S=S, grad_S=gS, J=J, check=False)
    assert not analysis.shared_equilibria_hold(broken, [[1.0, 0.0, 0.0]]).any()  # xi_P = 0 but xi_g != 0


def test_every_regular_equilibrium_found_is_explained(zoo_points):
    name, system, _ = zoo_points
    if name in ("lorenz_nevir", "cosh"):
        pytest.skip("level sets not bounded / not star-shaped about the minimiser")
    found = analysis.equilibria(system, float(system.H([0.6, 0.5, 0.7])), "xi", np.zeros(3), n=600)
    assert found
    for f in found:  # for eps > 0, xi = 0 needs xi_g = 0 (Lemma 6), hence a reason of Prop. 11
        assert f.reasons, f"{name}: equilibrium at {f.x} without a reason"


# -- acceptance: stability verdicts against simulation from nearby starts ----------------------
def _nearby_starts(system, H0, x, center, delta):
    """Four starts on H = H0 at distance ~delta from x, along +-the tangent basis."""
    T = analysis.tangent_basis(system, x)
    directions = np.array([x + delta * s * t for t in T for s in (1.0, -1.0)]) - center
    return level_set.on_rays(system, H0, directions / np.linalg.norm(directions, axis=1)[:, None], center)


def _distances(system, starts, x, duration, h):
    """Distance from x at the start and at the end of each run."""
    finals = []
    for x0 in starts:
        sol = geomint.solve(system, x0, (0.0, duration), h, method="gonzalez", save_every=None)
        assert sol.success
        finals.append(np.linalg.norm(sol.x_final - x))
    return np.linalg.norm(starts - x, axis=1), np.array(finals)


def _assert_simulation_agrees(system, H0, x, verdict, duration, center=None, delta=1e-2, h=0.02):
    center = np.zeros(3) if center is None else center
    start, end = _distances(system, _nearby_starts(system, H0, x, center, delta), x, duration, h)
    if verdict == "stable":
        assert np.all(end < 0.1 * start), (x, start, end)
    else:
        assert verdict == "unstable" and np.any(end > 5 * start), (x, start, end)


@pytest.mark.parametrize("eps", [0.05, 0.5, 3.0])
def test_rigid_body_pole_of_the_largest_coefficient_is_stable_the_others_unstable(eps):
    a, b, c, H0 = 0.5, 1.0, 1.5, 0.75
    body = geomint.systems.relaxing_rigid_body(a, b, c, eps=eps)
    found = analysis.equilibria(body, H0, n=600)
    assert len(found) == 6 and all(isinstance(f, analysis.Equilibrium) for f in found)
    for f in found:
        axis = int(np.argmax(np.abs(f.x)))
        assert f.reasons == ("grad S || grad H",) and f.regular
        assert f.verdict == ("stable" if axis == 2 else "unstable"), (f.x, f.eigenvalues)
        if f.x[axis] > 0:  # the mirror images behave alike
            real = f.eigenvalues.real  # the slowest decay, or the fastest growth
            rate = float(np.min(-real) if f.verdict == "stable" else np.max(real))
            _assert_simulation_agrees(body, H0, f.x, f.verdict, duration=4.0 / rate, h=min(0.05, 0.2 / rate))


def test_rigid_body_with_a_equal_b_has_one_curve_of_equilibria():
    body = geomint.systems.relaxing_rigid_body(1.5, 1.5, 0.5, eps=0.5)
    found = analysis.equilibria(body, 0.75, n=600)
    curves = [f for f in found if isinstance(f, analysis.EquilibriumCurve)]
    points = [f for f in found if isinstance(f, analysis.Equilibrium)]
    assert len(curves) == 1 and len(points) == 2
    [circle] = curves
    assert circle.closed and circle.verdict == "stable" and circle.reasons == ("grad S || grad H",)
    np.testing.assert_allclose(circle.points[:, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(circle.points, axis=1), 1.0, rtol=1e-9)
    assert np.ptp(np.arctan2(circle.points[:, 1], circle.points[:, 0])) > 6.0  # all the way round
    assert all(p.verdict == "unstable" and abs(abs(p.x[2]) - np.sqrt(3.0)) < 1e-9 for p in points)
    # simulation: from near the circle the distance to it shrinks; from near a pole it grows
    x = circle.points[0]
    starts = _nearby_starts(body, 0.75, x, np.zeros(3), 1e-2)
    for x0 in starts:
        end = geomint.solve(body, x0, (0.0, 15.0), 0.02, method="gonzalez", save_every=None).x_final
        assert abs(end[2]) < 1e-3 * max(abs(x0[2]), 1e-12) or abs(end[2]) < 1e-8
    _assert_simulation_agrees(body, 0.75, points[0].x, "unstable", duration=10.0)


def test_oscillator_z2_equator_cycle_attracts_and_poles_are_unstable():
    osc = geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0), eps=1.0)
    found = analysis.equilibria(osc, 0.5, n=600)
    assert sorted(np.round(f.x[2], 9) for f in found) == [-1.0, 1.0]
    assert all(f.verdict == "unstable" and f.kind == "focus" for f in found)
    [cycle] = analysis.rest_cycles(osc, 0.5, n=600)
    assert cycle.periodic and cycle.verdict == "stable"
    assert cycle.exponent == pytest.approx(-2.0, rel=1e-6)  # -eps rho^2 S''(0) on the unit sphere
    assert cycle.period == pytest.approx(2 * np.pi, rel=1e-3)
    np.testing.assert_allclose(cycle.points[:, 2], 0.0, atol=1e-9)
    for x0 in ([0.0, 0.99, 0.1], [0.99, 0.0, -0.1]):  # near the cycle: z -> 0
        x0 = np.array(x0) / np.linalg.norm(x0)
        end = geomint.solve(osc, x0, (0.0, 8.0), 0.02, method="gonzalez", save_every=None).x_final
        assert abs(end[2]) < 1e-5
    for f in found:
        _assert_simulation_agrees(osc, 0.5, f.x, "unstable", duration=3.0)


def test_degenerate_example_1_plus_r0_is_stable_minus_r0_unstable():
    ex1 = geomint.systems.degenerate_example(1, eps=1.0)
    found = {tuple(np.round(f.x, 6) + 0.0): f for f in analysis.equilibria(ex1, 0.5, n=600)}
    assert set(found) == {(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)}
    plus, minus = found[(1.0, 0.0, 0.0)], found[(-1.0, 0.0, 0.0)]
    assert (plus.verdict, minus.verdict) == ("stable", "unstable") and minus.kind == "saddle"
    assert not plus.regular and plus.reasons == ("dS = 0",) and "Section 2.3" in plus.proposition
    assert found[(0.0, 0.0, 1.0)].verdict == "unstable" and found[(0.0, 0.0, 1.0)].reasons == ("grad S || grad H",)
    _assert_simulation_agrees(ex1, 0.5, plus.x, "stable", duration=8.0)
    _assert_simulation_agrees(ex1, 0.5, minus.x, "unstable", duration=8.0)


# -- equilibria of the parts, regular and non-regular points ------------------------------------
def test_xi_P_of_the_degenerate_example_vanishes_on_the_whole_plane_y_0():
    ex1 = geomint.systems.degenerate_example(1)
    [curve] = analysis.equilibria(ex1, 0.5, field="xi_P", n=600)
    assert isinstance(curve, analysis.EquilibriumCurve) and curve.closed and not curve.regular.any()
    np.testing.assert_allclose(curve.points[:, 1], 0.0, atol=1e-9)
    assert curve.reasons == () and "non-regular" in curve.proposition
    # across the curve the eigenvalue is -x: attracting where x > 0, repelling where x < 0
    np.testing.assert_allclose(curve.normal_eigenvalues, -curve.points[:, 0], atol=1e-6)
    assert curve.verdict == "mixed"


def test_xi_g_of_the_oscillator_vanishes_on_the_equator_and_at_the_poles():
    osc = geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0))
    found = analysis.equilibria(osc, 0.5, field="xi_g", n=600)
    curves = [f for f in found if isinstance(f, analysis.EquilibriumCurve)]
    assert len(curves) == 1 and curves[0].reasons == ("dS = 0",) and "Prop. 11" in curves[0].proposition
    assert len(found) == 3


def test_explain_names_the_reasons():
    body = geomint.systems.relaxing_rigid_body()
    assert analysis.explain(body, [0.0, 0.0, 1.0]) == (
        True,
        ("grad S || grad H",),
        "Prop. 9/10: regular equilibrium, shared with the Hamiltonian system",
    )
    lorenz = lorenz_nevir()
    assert analysis.explain(lorenz, [3.0, 0.0, 28.0])[1] == ("critical point of H",)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda s: analysis.equilibria(s, 0.75, field="xi_x"), r"`field` must be one of xi, xi_P, xi_g; got 'xi_x'"),
        (lambda s: analysis.equilibria(s, float("nan")), r"`H0` must be finite; got nan"),
        (lambda s: analysis.equilibria(s, 0.75, n=5), r"`n` must be an integer >= 20; got 5"),
        (lambda s: analysis.linearise(s, [[1.0, 2.0]]), r"`x` must have shape \(3,\) or \(n, 3\); got shape \(1, 2\)"),
        (lambda s: analysis.tangent_basis(s, [0.0, 0.0, 0.0]), r"`x` must not be a critical point of H"),
        (lambda s: analysis.refine(s, [0.6, 0.0, 0.8], -1.0), r"`x0` must lie near a zero of xi on H = -1.0"),
        (lambda s: analysis.conditions(s, [0.0, 0.0, 1.0], rtol=2.0), r"`rtol` must be a number in \[0, 1\); got 2.0"),
        (lambda s: analysis.factorise(s, [0.0, 0.0, 0.0]), r"`x` must be a regular point with grad H != 0"),
    ],
)
def test_bad_input_is_refused_with_the_rule(call, message):
    with pytest.raises(ValueError, match=message):
        call(geomint.systems.relaxing_rigid_body())


def test_bad_H0_type_is_refused():
    with pytest.raises(TypeError, match=r"`H0` must be a real number; got 'a'"):
        analysis.equilibria(geomint.systems.relaxing_rigid_body(), "a")


# -- the factorisation behind "no bifurcation at eps > 0" ----------------------------------------
@pytest.mark.parametrize(
    "name, H0",
    [
        ("quartic_rigid_body", 2.0),
        ("coupled_rigid_body", 1.2),
        ("relaxing_rigid_body", 0.75),
        ("dissipative_oscillator", 0.5),
    ],
)
def test_tangent_jacobian_factorises_and_S_on_the_level_set_decides_stability(name, H0):
    system = ZOO[name]
    expected = {"minimum": "stable", "maximum": "unstable", "saddle": "unstable"}
    found = [f for f in analysis.equilibria(system, H0, n=600) if f.regular and f.reasons == ("grad S || grad H",)]
    assert len(found) >= 2
    for f in found:
        factors = analysis.factorise(system, f.x)
        for eps in (0.0, 0.03, 1.0, 30.0):
            jacobian = analysis.linearise(system.with_effects(eps=eps), f.x)[0]
            np.testing.assert_allclose(factors.jacobian(eps), jacobian, atol=1e-7 * np.abs(jacobian).max())
            if eps > 0:
                lam = np.linalg.eigvals(jacobian)
                assert analysis.verdict(lam, np.linalg.norm(jacobian)) == expected[factors.constrained_type]


def test_explain_refuses_a_state_that_is_not_a_zero_of_its_field():
    """The propositions explain equilibria: a moving state is refused with |field| there, not called one."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5)
    with pytest.raises(ValueError, match=r"`x` must be a zero of `xi` .* \|xi\| = 0\.\d+"):
        analysis.explain(body, [0.5, 0.5, 0.5])
    assert analysis.explain(body, [0.0, 0.0, 1.0])[0]
    assert analysis.conditions(body, np.zeros((0, 3))).regular.shape == (0,)
