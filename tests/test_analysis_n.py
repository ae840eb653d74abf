"""geomint.analysis in R^n: critical points of S on a level set of H, their type and linear stability, continuation.

The acceptance cases of issue 29 (item 4): the gas containers' one equilibrium, the damped pendula's rest states,
the lowest shell of 2-D Euler (Zeitlin) as the enstrophy minimum, and residuals of every point found for random
Fish systems; with the argument errors.
"""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import geomint
from geomint import analysis
from geomint.analysis.continuation import continuation, continuation_n

ACCEPT = 1e-10  # the residuals critical_points keeps a solution at


def _gas_state(q, p, S1, S2):
    return np.array([q, p, S1, S2])


# -- gas containers: one equilibrium, the entropy maximum ------------------------------------------------------------


def test_gas_containers_have_one_equilibrium_at_equal_temperatures_and_pressures():
    gas = geomint.systems.gas_containers()
    E0 = float(gas.H([1.5, 0.0, 2.0, 2.0]))
    [c] = analysis.critical_points(gas, E0)
    sigma = 1.5 * np.log(E0 / 2.0)  # S1 = S2 = 3 ln(E0 / 2) / 2
    np.testing.assert_allclose(c.x, [1.0, 0.0, sigma, sigma], rtol=0.0, atol=1e-12)
    assert c.S == pytest.approx(3.0 * np.log(E0 / 2.0), rel=1e-14)
    assert c.type == "maximum" and c.lyapunov_stable and c.equilibrium
    assert c.verdict == "stable" and np.all(c.eigenvalues.real < 0.0)
    assert c.manifold_dim == 0 and c.points.shape == (1, 4)
    assert max(c.gradient_residual, c.level_residual) <= ACCEPT
    assert max(c.hamiltonian_residual, c.field_residual) <= 1e-12
    # the tangent space of E = E0 is 3-dimensional; the Jacobian of xi has the eigenvalues of J_T and a zero
    assert c.jacobian.shape == (3, 3) and len(c.hessian_eigenvalues) == 3


@settings(max_examples=6, deadline=None)
@given(
    q=st.floats(0.3, 1.7),
    p=st.floats(-1.0, 1.0),
    S1=st.floats(-1.0, 2.0),
    S2=st.floats(-1.0, 2.0),
)
def test_gas_containers_relax_to_their_limit_from_any_energy(q, p, S1, S2):
    gas = geomint.systems.gas_containers()
    E0 = float(gas.H(_gas_state(q, p, S1, S2)))
    found = analysis.critical_points(gas, E0, n_starts=12)
    assert len(found) == 1
    np.testing.assert_allclose(found[0].x, geomint.systems.gas_containers_limit(E0), rtol=1e-12, atol=1e-12)
    assert found[0].verdict == "stable" and found[0].lyapunov_stable


# -- damped pendula: the rest states, only all-down stable ---------------------------------------------------------


def test_damped_pendula_rest_states_are_found_and_only_all_down_is_stable():
    pendula = geomint.systems.damped_pendula(2)
    x0 = np.array([1.0, -2.0, 0.3, 0.2, 0.5])
    E0 = float(pendula.H(x0))
    found = analysis.critical_points(pendula, E0, box=(-4.0, 4.0))
    classes = set()
    for c in found:
        q, p, s = c.x[:2], c.x[2:4], c.x[4]
        cos_q = np.cos(q)
        np.testing.assert_allclose(np.abs(cos_q), 1.0, rtol=0.0, atol=1e-12)  # q_i in {0, pi} modulo 2 pi
        np.testing.assert_allclose(p, 0.0, atol=1e-12)
        assert s == pytest.approx(E0 - cos_q.sum(), abs=1e-12)
        assert c.lam == pytest.approx(1.0, rel=1e-12)  # grad S = e_s = grad E there
        down = bool(np.all(cos_q < 0.0))
        classes.add(tuple(np.sign(cos_q).astype(int)))
        assert c.equilibrium and max(c.gradient_residual, c.level_residual) <= ACCEPT
        assert (c.verdict == "stable") == down and (c.type == "maximum") == down and c.lyapunov_stable == down
        if not down:  # a pendulum at the top: a saddle of the entropy, a saddle of the flow
            assert c.type == "saddle" and c.verdict == "unstable" and c.kind == "saddle"
    assert classes == {(1, 1), (1, -1), (-1, 1), (-1, -1)}


# -- 2-D Euler (Zeitlin, N = 5): the lowest shell is the enstrophy minimum ------------------------------------------


def test_euler_zeitlin_lowest_shell_is_the_stable_enstrophy_minimum():
    euler = geomint.systems.euler_zeitlin(5, eps=1.0)
    H0 = float(euler.H(geomint.systems.euler_initial_state(5)))  # 1.1375
    found = analysis.critical_points(euler, H0, n_starts=16)
    lowest = found[0]
    assert lowest.S == pytest.approx(H0, rel=1e-12)  # S_inf = H0
    assert lowest.lam == pytest.approx(1.0, rel=1e-10)
    assert lowest.type == "minimum" and lowest.manifold_dim == 3  # a 3-sphere in the four lowest-shell coordinates
    assert lowest.verdict == "stable" and lowest.lyapunov_stable
    assert np.all(lowest.eigenvalues.real < 0.0) and lowest.jacobian.shape == (20, 20)
    shell = np.sum(geomint.systems.euler_modes(5) ** 2, axis=1)  # |k|^2 of each half mode
    outside = np.repeat(shell != 1, 2)
    assert len(lowest.points) > 1
    for x in lowest.points:
        np.testing.assert_allclose(x[outside], 0.0, atol=1e-10)
        assert float(euler.S(x)) == pytest.approx(H0, rel=1e-12)
    # the other critical points: single shells |k|^2 = m, S = m H0, none stable
    for c in found[1:]:
        m = c.S / H0
        assert m == pytest.approx(round(m), rel=1e-10) and round(m) in (2, 4, 5, 8)
        assert c.lam == pytest.approx(m, rel=1e-10)
        assert c.verdict == "unstable" and not c.lyapunov_stable


# -- random Fish systems: residuals, and the type decides the verdict -----------------------------------------------


@settings(max_examples=8, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    x=st.lists(st.floats(-1.5, 1.5), min_size=4, max_size=4),
    eps=st.sampled_from([0.3, 1.0, 3.0]),
)
def test_random_fish_every_critical_point_satisfies_the_residuals(seed, x, eps):
    fish = geomint.systems.random_fish(4, seed=seed, eps=eps)
    H0 = float(fish.H(np.array(x)))
    if H0 <= float(fish.H(np.zeros(4))) + 1e-3:
        return  # the level set is a point or empty (H has its minimum at 0)
    found = analysis.critical_points(fish, H0, n_starts=8, seed=seed)
    assert found
    for c in found:
        gh, gs = fish.grad_H(c.x), fish.grad_S(c.x)
        assert np.linalg.norm(gs - c.lam * gh) <= 2 * ACCEPT * np.linalg.norm(gs)
        assert abs(float(fish.H(c.x)) - H0) <= ACCEPT * abs(H0)
        assert c.gradient_residual <= ACCEPT and c.level_residual <= ACCEPT
        # P grad S = 0 makes P grad H = P grad S / lam vanish: an equilibrium of the full flow
        assert c.hamiltonian_residual <= 1e-9 and c.field_residual <= 1e-9 and c.equilibrium
        assert np.linalg.norm(fish.xi(c.x)) <= 1e-9 * np.linalg.norm(fish.P(c.x)) * np.linalg.norm(gh) * (1 + eps)
        if c.type != "degenerate":
            # the inertia theorem (L_T J_T + J_T^T L_T = -2 eps |grad H|^2 L_T^2): as many unstable eigenvalues as
            # negative eigenvalues of the constrained Hessian; the minimum stable, the others unstable
            assert np.sum(c.eigenvalues.real > 0.0) == np.sum(c.hessian_eigenvalues < 0.0)
            assert (c.verdict == "stable") == (c.type == "minimum") == c.lyapunov_stable


def test_random_fish_exact_hessians_give_the_same_points():
    fish = geomint.systems.random_fish(4, seed=7)
    cos, quartic, D = fish.params[0], fish.params[1], fish.params[2:6]

    def hess_H(x):
        return np.diag(D - cos * np.cos(x))

    def hess_S(x):
        return np.diag(1.0 + 12.0 * quartic * x * x)

    by_differences = analysis.critical_points(fish, 1.6, n_starts=12)
    exact = analysis.critical_points(fish, 1.6, n_starts=12, hess_H=hess_H, hess_S=hess_S)
    assert len(exact) == len(by_differences) > 0
    for a in by_differences:  # H and S are even: the points come in pairs +-x of one S, in either order
        b = min(exact, key=lambda b: np.linalg.norm(b.x - a.x))
        np.testing.assert_allclose(a.x, b.x, atol=1e-12)
        np.testing.assert_allclose(a.hessian_eigenvalues, b.hessian_eigenvalues, rtol=1e-6, atol=1e-8)
        assert (a.type, a.verdict) == (b.type, b.verdict)


# -- the R^3 systems: the same equilibria as the R^3 search ---------------------------------------------------------


def test_in_R3_the_critical_points_are_the_equilibria_the_surface_search_finds():
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0)
    found = analysis.critical_points(body, 0.75)
    surface = analysis.equilibria(body, 0.75, n=1000)
    assert len(found) == len(surface) == 6
    for c in found:
        [e] = [e for e in surface if np.linalg.norm(e.x - c.x) < 1e-9]
        assert c.verdict == e.verdict and c.kind == e.kind
        np.testing.assert_allclose(np.sort_complex(c.eigenvalues), np.sort_complex(e.eigenvalues), atol=1e-7)
    assert [c.type for c in found] == ["minimum"] * 2 + ["saddle"] * 2 + ["maximum"] * 2


def test_in_R3_the_circle_of_equilibria_is_one_manifold_of_minima():
    flat = geomint.systems.relaxing_rigid_body(1.5, 1.5, 0.5, eps=0.5)
    circle = analysis.critical_points(flat, 0.75)[0]
    assert circle.manifold_dim == 1 and circle.type == "minimum" and len(circle.points) > 1
    np.testing.assert_allclose(circle.points[:, 2], 0.0, atol=1e-12)  # the equator of the axis of c
    np.testing.assert_allclose(np.linalg.norm(circle.points, axis=1), 1.0, rtol=1e-12)
    assert circle.verdict == "stable" and circle.eigenvalues.shape == (1,)  # across the circle


# -- deduplication, the level-set projection, linearise in R^n -------------------------------------------------------


def test_starts_that_reach_one_point_give_it_once():
    gas = geomint.systems.gas_containers()
    E0 = float(gas.H([1.5, 0.0, 2.0, 2.0]))
    limit = geomint.systems.gas_containers_limit(E0)
    starts = limit + np.array([[0.0] * 4, [1e-9, 0.0, -1e-9, 0.0], [0.05, 0.01, 0.1, -0.1], [0.0] * 4])
    [c] = analysis.critical_points(gas, E0, starts=starts)
    assert c.points.shape == (1, 4)
    [same] = analysis.critical_points(gas, E0, starts=limit, slide=False)
    np.testing.assert_array_equal(same.x, analysis.critical_point(gas, E0, limit).x)


@settings(max_examples=10, deadline=None)
@given(x=st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4), level=st.floats(1.0, 3.0))
@example(
    x=[0.0, 0.0, 0.0, 5.96e-8], level=1.0
)  # next to H's critical point at 0: a Newton step of 3e6 (found by hypothesis)
def test_to_level_set_lands_on_the_level(x, level):
    fish = geomint.systems.random_fish(4, seed=1)
    y = analysis.to_level_set(fish, np.array(x), level)
    if np.all(np.isfinite(y)):
        assert abs(float(fish.H(y)) - level) <= 1e-12 * max(level, float(np.abs(y * fish.grad_H(y)).sum()))
    else:
        assert np.linalg.norm(fish.grad_H(np.array(x))) == 0.0 or level < float(fish.H(np.zeros(4)))


def test_linearise_in_Rn_is_the_tangent_space_jacobian():
    gas = geomint.systems.gas_containers()
    x = geomint.systems.gas_containers_limit(4.0)
    jacobian, eigenvalues = analysis.linearise(gas, x)
    assert jacobian.shape == (3, 3)
    # at an equilibrium the full Jacobian maps into the tangent space: its eigenvalues are J_T's and a zero
    step = 1e-6 * (1 + np.linalg.norm(x))
    full = np.stack([(gas.xi(x + step * e) - gas.xi(x - step * e)) / (2 * step) for e in np.eye(4)], axis=1)
    expected = np.sort_complex(np.linalg.eigvals(full))
    got = np.sort_complex(np.append(eigenvalues, 0.0))
    np.testing.assert_allclose(got, expected, atol=1e-7)
    # with S conserved too (a point where grad S and grad H are independent) the tangent space loses a dimension
    y = np.array([0.8, 0.3, 0.5, 1.0])
    assert analysis.tangent_basis(gas, y).shape == (3, 4)
    assert analysis.tangent_basis(gas, y, conserved=("S",)).shape == (2, 4)
    assert analysis.linearise(gas, y, field="xi_P", conserved=["S"])[0].shape == (2, 2)
    assert analysis.linearise(gas, np.stack([x, y]))[0].shape == (2, 3, 3)


# -- continuation in eps -------------------------------------------------------------------------------------------


def test_random_fish_continuation_verdicts_are_fixed_for_every_positive_eps():
    fish = geomint.systems.random_fish(4, seed=3)
    result = continuation_n(fish, 1.6, [0.0, 0.1, 1.0, 10.0], n_starts=8)
    assert result.branches
    for branch in result.branches:
        kind = branch.label.split(" of S")[0]
        assert branch.displacement < 1e-12 and branch.eigenvalues.shape == (4, 3)
        assert set(branch.verdicts[1:]) == {"stable" if kind == "minimum" else "unstable"}
        assert all(ch.at_zero for ch in branch.changes if ch.before[0] != ch.after[0])
    assert len(result.rows()) == len(result.branches)


# -- errors --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"H0": float("nan")}, ValueError, "`H0` must be finite"),
        ({"H0": "high"}, TypeError, "`H0` must be a real number"),
        ({"H0": -10.0}, ValueError, "`H0` = -10.0: no start could be moved onto the level set"),
        ({"starts": np.zeros(3)}, ValueError, "`starts` must have shape (4,)"),
        ({"starts": np.zeros((2, 5))}, ValueError, "`starts` must have shape (4,)"),
        ({"starts": [[np.nan] * 4]}, ValueError, "`starts` must be finite"),
        ({"starts": "abc"}, TypeError, "`starts` must be real numbers"),
        ({"n_starts": 0}, ValueError, "`n_starts` must be an integer >= 1"),
        ({"seed": -1}, ValueError, "`seed` must be an integer >= 0"),
        ({"box": (1.0, -1.0)}, ValueError, "`box` must be (low, high)"),
        ({"box": ([0.0] * 3, 1.0)}, ValueError, "`box` must be (low, high)"),
        ({"xtol": 0.0}, ValueError, "`xtol` must be a number in (0, 1)"),
        ({"hess_H": "exact"}, TypeError, "`hess_H` must be a function"),
        ({"hess_S": lambda x: np.eye(3)}, ValueError, "`hess_S` must return an (4, 4) array"),
    ],
)
def test_bad_arguments_are_refused_naming_them(kwargs, error, message):
    fish = geomint.systems.random_fish(4, seed=1)
    arguments = {"H0": 1.6, "n_starts": 2, **kwargs}
    with pytest.raises(error, match=message.replace("(", r"\(").replace(")", r"\)")):
        analysis.critical_points(fish, **arguments)


def test_a_start_far_from_any_critical_point_and_of_the_wrong_shape_are_refused():
    gas = geomint.systems.gas_containers()
    with pytest.raises(ValueError, match=r"`x0` must have shape \(4,\)"):
        analysis.critical_point(gas, 8.0, [1.0, 0.0, 2.0])
    with pytest.raises(ValueError, match="`x0` must be one state"):
        analysis.critical_point(gas, 8.0, np.ones((2, 4)))
    with pytest.raises(ValueError, match="`x0` must lie near a critical point"):
        analysis.critical_point(gas, 8.0, [-1.0, 0.0, 2.0, 2.0])  # q < 0: outside the box, nothing is defined


def test_the_R3_tools_refuse_a_system_in_Rn_naming_the_Rn_one():
    fish = geomint.systems.random_fish(4)
    for call, name, instead in (
        (lambda: analysis.equilibria(fish, 1.0), "equilibria", "critical_points"),
        (lambda: analysis.rest_cycles(fish, 1.0), "rest_cycles", "critical_points"),
        (lambda: analysis.refine(fish, np.zeros(4), 1.0), "refine", "critical_point"),
        (lambda: analysis.conditions(fish, np.zeros(4)), "conditions", "critical_points"),
        (lambda: analysis.factorise(fish, np.zeros(4)), "factorise", "linearise"),
        (lambda: continuation(fish, 1.0, [0.0, 1.0]), "continuation", "continuation_n"),
    ):
        with pytest.raises(TypeError, match=rf"`{name}`.*R\^3.*R\^4: use `{instead}`"):
            call()
